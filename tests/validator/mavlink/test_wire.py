import json
import math

import numpy as np
import pytest

from validator.errors import InputError
from validator.flight import resolve_flight
from validator.mavlink.wire import (
    MissionType,
    WireItem,
    first_difference,
    mission_result_name,
    plan_to_wire,
    wire_to_plan,
)
from validator.plan_format import Cmd, FenceCircle, Frame, MissionItem, loads_plan, plan_to_dict


def test_ardupilot_mission_starts_with_home_and_keeps_plan_order(plan):
    wire = plan_to_wire(plan, home_item=True)
    assert [w.seq for w in wire.mission] == list(range(len(plan.items) + 1))
    home = wire.mission[0]
    assert (home.command, home.frame) == (Cmd.NAV_WAYPOINT, 0)
    assert home.x == round(plan.home_lat_deg * 1e7) and home.z == pytest.approx(plan.home_alt_m)
    assert [w.command for w in wire.mission[1:]] == [it.command for it in plan.items]


def test_px4_mission_has_no_home_item(plan):
    wire = plan_to_wire(plan, home_item=False)
    assert [w.command for w in wire.mission] == [it.command for it in plan.items]


def test_coordinates_are_int32_degrees_e7_rounded_to_nearest(plan):
    wp = plan_to_wire(plan, home_item=True).mission[3]
    assert wp.x == int(np.rint(plan.items[2].lat_deg * 1e7))
    assert wp.y == int(np.rint(plan.items[2].lon_deg * 1e7))


@pytest.mark.parametrize("home_item, target_seq", [(True, 3), (False, 2)])
def test_do_jump_target_is_a_wire_sequence_number(plan, home_item, target_seq):
    wire = plan_to_wire(plan, home_item=home_item).mission
    jumps = [w for w in wire if w.command == Cmd.DO_JUMP]
    assert [j.param1 for j in jumps] == [target_seq]
    assert wire[target_seq].command == Cmd.NAV_WAYPOINT  # the item the plan's doJumpId names


@pytest.mark.parametrize("home_item, target_seq", [(True, 3), (False, 2)])
def test_a_plan_files_jump_goes_up_as_the_sequence_number_of_the_item_with_its_doJumpId(
        plan, home_item, target_seq):
    data = plan_to_dict(plan)
    for entry, jump_id in zip(data["mission"]["items"], range(11, 17), strict=True):
        entry["doJumpId"] = jump_id  # as another tool may number them
    data["mission"]["items"][4]["params"][0] = 13  # item 2, the first waypoint
    wire = plan_to_wire(loads_plan(json.dumps(data)), home_item=home_item).mission
    assert [w.param1 for w in wire if w.command == Cmd.DO_JUMP] == [target_seq]


def test_fence_circle_polygon_and_return_point(plan):
    fence = plan_to_wire(plan, home_item=True).fence
    vertices = [w for w in fence if w.command == Cmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION]
    circles = [w for w in fence if w.command == Cmd.NAV_FENCE_CIRCLE_EXCLUSION]
    assert len(vertices) == 4 and {w.param1 for w in vertices} == {4.0}
    assert [c.param1 for c in circles] == [pytest.approx(20.0)]
    assert fence[-1].command == 5000 and fence[-1].z == pytest.approx(25.0)
    assert all(w.mission_type == MissionType.FENCE for w in fence)


def test_rally_points_are_nav_rally_point_above_home(plan):
    rally = plan_to_wire(plan, home_item=True).rally
    assert [w.command for w in rally] == [Cmd.NAV_RALLY_POINT] * 2
    assert {w.frame for w in rally} == {3} and rally[0].z == pytest.approx(30.0)


@pytest.mark.parametrize("home_item", [True, False])
def test_plan_survives_the_wire_to_int32_precision(plan, home_item):
    wire = plan_to_wire(plan, home_item=home_item)
    home = None if home_item else (plan.home_lat_deg, plan.home_lon_deg, plan.home_alt_m)
    back = wire_to_plan(wire, home_item=home_item, home=home)
    assert len(back.items) == len(plan.items)
    for a, b in zip(plan.items, back.items, strict=True):
        assert a.command == b.command and a.frame == b.frame
        for pa, pb in zip(a.params, b.params, strict=True):
            assert (math.isnan(pa) and math.isnan(pb)) or pb == pytest.approx(pa, abs=1e-6)
    assert back.circles == [
        FenceCircle(pytest.approx(c.lat_deg, abs=1e-7), pytest.approx(c.lon_deg, abs=1e-7),
                    pytest.approx(c.radius_m), c.inclusion) for c in plan.circles]
    assert len(back.polygons) == 1 and len(back.polygons[0].vertices_deg) == 4
    assert back.rally == [pytest.approx(r, abs=1e-7) for r in plan.rally]
    assert back.breach_return == pytest.approx(plan.breach_return, abs=1e-7)
    assert back.home_alt_m == pytest.approx(plan.home_alt_m)
    assert wire_to_plan(plan_to_wire(back, home_item=home_item), home_item=home_item,
                        home=home).items[2].params[4] == back.items[2].params[4]


def test_an_ardupilot_home_of_0_0_is_no_home_and_the_first_waypoint_stands_in(plan):
    """ArduPilot reads back seq 0 at 0°, 0° until it has a home (a SITL without a GPS fix
    yet): that is no position, and the plan's home is the vehicle's HOME_POSITION if it
    said one, else the first positioned item at altitude 0."""
    import dataclasses

    wire = plan_to_wire(plan, home_item=True)
    nowhere = dataclasses.replace(wire.mission[0], x=0, y=0)
    lists = dataclasses.replace(wire, mission=[nowhere, *wire.mission[1:]])
    back = wire_to_plan(lists, home_item=True)
    first = next(w for w in wire.mission[1:] if w.x or w.y)
    assert (back.home_lat_deg, back.home_lon_deg) == pytest.approx((first.x / 1e7,
                                                                    first.y / 1e7))
    said = wire_to_plan(lists, home_item=True, home=(1.0, 2.0, 3.0))
    assert (said.home_lat_deg, said.home_lon_deg, said.home_alt_m) == (1.0, 2.0, 3.0)


def _without_home(plan):
    import dataclasses

    wire = plan_to_wire(plan, home_item=True)
    return dataclasses.replace(wire, mission=(dataclasses.replace(wire.mission[0], x=0, y=0),
                                              *wire.mission[1:]))


def test_the_first_waypoint_standing_in_for_a_missing_home_is_told(plan):
    notes: list[str] = []
    wire_to_plan(_without_home(plan), home_item=True, note=notes.append)
    assert notes == ["the vehicle reported no home (its seq 0 at 0°, 0°); the plan's home is "
                     "the position of item 1, the first item with one, at altitude "
                     "0 m AMSL"]


def test_a_home_the_vehicle_said_through_home_position_is_not_remarked(plan):
    notes: list[str] = []
    wire_to_plan(_without_home(plan), home_item=True, home=(1.0, 2.0, 3.0), note=notes.append)
    assert notes == []


def test_a_px4_mission_without_home_position_tells_whose_position_stands_in(plan):
    notes: list[str] = []
    wire_to_plan(plan_to_wire(plan, home_item=False), home_item=False, note=notes.append)
    assert len(notes) == 1 and notes[0].startswith("the vehicle reported no home (no "
                                                   "HOME_POSITION); the plan's home is the "
                                                   "position of item 1,")


def test_latitude_out_of_range_names_the_item(plan):
    plan.items[2].params[4] = 95.0
    with pytest.raises(InputError, match=r"mission.items\[2\]: latitude 95.0"):
        plan_to_wire(plan, home_item=True)


def test_jump_to_a_missing_item_is_refused(plan):
    plan.items[4].params[0] = 99.0
    with pytest.raises(InputError, match=r"mission.items\[4\]: DO_JUMP target 99"):
        plan_to_wire(plan, home_item=True)


def _item(seq: int, p2: float = 0.0, p4: float = math.nan) -> WireItem:
    return WireItem(seq, 3, 16, 0.0, p2, 0.0, p4, 100, 200, 30.0, 0)


def test_identical_lists_have_no_difference_and_nan_equals_nan():
    a = (_item(0), _item(1))
    assert first_difference(a, (_item(0), _item(1)), MissionType.MISSION) is None


def test_first_difference_names_item_and_field():
    diff = first_difference((_item(0), _item(1, 5.0)), (_item(0), _item(1, 4.0)),
                            MissionType.MISSION)
    assert diff == "mission item 1: param2 sent 5.0, vehicle holds 4.0"


def test_difference_in_count_is_reported():
    assert first_difference((_item(0),), (), MissionType.FENCE) == (
        "fence: sent 1 items, vehicle holds 0")


def test_ardupilot_home_item_is_not_compared():
    moved = WireItem(0, 3, 16, 0.0, 0.0, 0.0, math.nan, 999, 200, 30.0, 0)
    assert first_difference((_item(0),), (moved,), MissionType.MISSION, skip_seq0=True) is None
    assert first_difference((_item(0),), (moved,), MissionType.MISSION) is not None


def test_mission_result_names():
    assert mission_result_name(4) == "MAV_MISSION_NO_SPACE"
    assert mission_result_name(200) == "MAV_MISSION_RESULT 200"


# --------------------------------------------------------------------------------------------
# Frame 2 (MISSION): params 5 and 6 go unscaled, as QGroundControl sends them


def _in_mission_frame(plan, lat: float, lon: float):
    """``plan`` with its first waypoint (item 2) in frame 2 at ``lat``, ``lon``."""
    wp = plan.items[2]
    plan.items[2] = MissionItem(wp.command, [*wp.params[:4], lat, lon, wp.params[6]],
                                int(Frame.MISSION))
    return plan


def test_mission_frame_numbers_travel_unscaled_and_come_back_as_sent(plan):
    plan.items.append(MissionItem(203, [1.0, 0.0, 0.0, 0.0, 1.0, 7.0, 0.0], int(Frame.MISSION)))
    wire = plan_to_wire(plan, home_item=True)
    assert (wire.mission[-1].x, wire.mission[-1].y) == (1, 7)  # DO_DIGICAM_CONTROL's shot, id
    assert wire_to_plan(wire, home_item=True).items[-1].params[4:6] == [1.0, 7.0]


def test_a_fraction_in_the_mission_frame_is_refused_rather_than_cut(plan):
    """It went up rounded (a latitude of 37.56 as 38) and came back changed: no list sent
    and read back could give the plan back."""
    _in_mission_frame(plan, plan.home_lat_deg, plan.home_lon_deg)
    with pytest.raises(InputError, match=r"^mission.items\[2\] param5: 37.5\d* is no whole "
                                         r"number, and frame 2 carries it unscaled"):
        plan_to_wire(plan, home_item=True)


def test_a_mission_frame_waypoint_without_coordinates_goes_up_where_it_resolves(site, plan):
    # x and y 0 are where ArduPilot stays; the resolver keeps the vehicle where it is too
    _in_mission_frame(plan, math.nan, math.nan)
    wp = plan_to_wire(plan, home_item=True).mission[3]
    leg = resolve_flight(plan, site).legs[1]
    assert (wp.x, wp.y) == (0, 0)
    np.testing.assert_allclose(leg.end_xy_m, leg.start_xy_m, atol=1e-9)


def test_a_mission_frame_waypoint_the_wire_can_send_is_refused_by_the_resolver(site, plan):
    """Whole degrees go up as they are, and ArduPilot reads them as degrees x 1e7: a
    waypoint the resolver had put 62 km off at 37°N 127°E flies to 0°N 0°E."""
    _in_mission_frame(plan, 37.0, 127.0)
    wp = plan_to_wire(plan, home_item=True).mission[3]
    assert (wp.x, wp.y) == (37, 127)
    with pytest.raises(InputError, match=r"item 3: frame 2 \(MISSION\) carries latitude"):
        resolve_flight(plan, site)
