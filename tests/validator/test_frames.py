"""Which frames the autopilot takes a navigation item's position in (validator.flight.frames)."""

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from tests.validator.builders import make_site, waypoint_plan
from validator.errors import InputError
from validator.flight import resolve_flight
from validator.flight.frames import PX4_POSITIONED, PX4_ROI, PX4_UNPOSITIONED
from validator.mavlink.wire import mavlink
from validator.plan_format import Autopilot, Cmd, Frame, MissionItem

NAN = float("nan")
# PX4 v1.15.4's source, as checked out beside its SITL build on these machines
PX4_MISSION_CPP = Path("/opt/sitl/px4/src/modules/mavlink/mavlink_mission.cpp")


@pytest.fixture(scope="module")
def site():
    return make_site()


def _with_item_3(site, command: int, lat: float, lon: float, *, px4: bool = False):
    """The second waypoint of a plain plan replaced by ``command`` in frame 2, 30 m above home."""
    plan = waypoint_plan(site, [(50, -40), (150, -40)])
    plan.items[3] = MissionItem(command, [0.0, 0.0, 0.0, NAN, lat, lon, plan.home_alt_m + 30.0],
                                int(Frame.MISSION))
    return dataclasses.replace(plan, firmware_type=int(Autopilot.PX4)) if px4 else plan


@pytest.mark.parametrize("command", [Cmd.NAV_WAYPOINT, Cmd.NAV_LOITER_UNLIM,
                                     Cmd.NAV_LOITER_TURNS, Cmd.NAV_LOITER_TIME, Cmd.NAV_LAND])
def test_an_arducopter_item_with_coordinates_in_the_mission_frame_is_refused(site, command):
    """Frame 2 carries them unscaled (whole degrees, as QGroundControl sends them) and
    AP_Mission reads x and y as degrees x 1e7 in any frame: such a waypoint had been judged
    CLEAR at its latitude and longitude while the vehicle flew toward 0°N 0°E."""
    lat, lon = site.frame.to_geodetic(np.array([150.0, -40.0]))
    with pytest.raises(InputError, match=r"^p\.plan: item 4: frame 2 \(MISSION\) carries "
                                         r"latitude and longitude unscaled.*0°N 0°E"):
        resolve_flight(_with_item_3(site, int(command), float(lat), float(lon)), site, "p.plan")


@pytest.mark.parametrize("command", [Cmd.NAV_WAYPOINT, Cmd.NAV_LAND, Cmd.NAV_TAKEOFF])
def test_px4_refuses_a_navigation_item_in_the_mission_frame(site, command):
    # without coordinates too: PX4 takes no navigation command in frame 2 at all
    plan = _with_item_3(site, int(command), NAN, NAN, px4=True)
    with pytest.raises(InputError, match=rf"^p\.plan: item 4: .*PX4 refuses {command.name} "
                                         r"in it \(MAV_MISSION_UNSUPPORTED\)"):
        resolve_flight(plan, site, "p.plan")


def test_an_arducopter_waypoint_without_coordinates_in_the_mission_frame_stays_put(site):
    """x and y 0 are "where the vehicle is" to ArduPilot in any frame; frame 2's altitude is
    above sea level."""
    flight = resolve_flight(_with_item_3(site, int(Cmd.NAV_WAYPOINT), NAN, NAN), site)
    np.testing.assert_allclose(flight.legs[2].end_xy_m, flight.legs[1].end_xy_m, atol=1e-9)
    assert flight.legs[2].end_alt_m == pytest.approx(30.0)


def test_an_arducopter_takeoff_with_coordinates_in_the_mission_frame_climbs_where_it_is(site):
    # ArduCopter's takeoff uses only the item's altitude, so its coordinates mislead nothing
    plan = waypoint_plan(site, [(50, -40)])
    lat, lon = site.frame.to_geodetic(np.array([150.0, -40.0]))
    plan.items[0] = MissionItem(int(Cmd.NAV_TAKEOFF), [0.0, 0.0, 0.0, NAN, float(lat),
                                                       float(lon), plan.home_alt_m + 25.0],
                                int(Frame.MISSION))
    takeoff = resolve_flight(plan, site).legs[0]
    np.testing.assert_allclose(takeoff.end_xy_m, site.home_xy_m, atol=1e-9)
    assert takeoff.end_alt_m == pytest.approx(25.0)


@pytest.mark.parametrize("frame", [10, 11])  # GLOBAL_TERRAIN_ALT, its _INT twin
def test_px4_refuses_a_position_above_terrain(site, frame):
    """PX4 takes a position only in frames 0, 3, 5 and 6: a terrain frame had been read as
    above home with a warning, as ArduPilot may fly it."""
    plan = dataclasses.replace(waypoint_plan(site, [(50, -40), (150, -40)]),
                               firmware_type=int(Autopilot.PX4))
    plan.items[3] = dataclasses.replace(plan.items[3], frame=frame)
    with pytest.raises(InputError, match=rf"^p\.plan: item 4: frame {frame} \(above terrain\): "
                                         r"PX4 refuses the item \(MAV_MISSION_UNSUPPORTED_FRAME\)"):
        resolve_flight(plan, site, "p.plan")


def _px4(plan):
    return dataclasses.replace(plan, firmware_type=int(Autopilot.PX4))


@pytest.mark.parametrize("index, command", [(1, Cmd.DO_CHANGE_SPEED), (4, Cmd.DO_JUMP),
                                            (5, Cmd.NAV_RETURN_TO_LAUNCH)])
def test_px4_refuses_a_command_without_a_position_in_a_global_frame(site, index, command):
    """parse_mavlink_mission_item takes RTL, DO_CHANGE_SPEED, DO_JUMP... only in frame 2: sent
    in frame 3 the upload fails (MAV_MISSION_UNSUPPORTED), as PX4 v1.15.4 SITL showed for RTL;
    such a plan had been judged as if PX4 flew it."""
    plan = waypoint_plan(site, [(50, -40), (150, -40)], end="rtl")
    plan.items.insert(4, MissionItem(int(Cmd.DO_JUMP), [3.0, 1.0, 0, 0, 0, 0, 0],
                                     int(Frame.MISSION)))
    plan = _px4(plan)
    plan.items[index] = dataclasses.replace(plan.items[index],
                                            frame=int(Frame.GLOBAL_RELATIVE_ALT))
    with pytest.raises(InputError, match=rf"^p\.plan: item {index + 1}: PX4 takes {command.name} "
                                         r"only in frame 2 \(MISSION\).* in frame 3 "
                                         r"\(MAV_MISSION_UNSUPPORTED\); use 2 \(MISSION\)$"):
        resolve_flight(plan, site, "p.plan")


def test_px4_takes_rtl_in_the_mission_frame(site):
    flight = resolve_flight(_px4(waypoint_plan(site, [(50, -40)], end="rtl")), site)
    assert [leg.kind for leg in flight.legs][-2:] == ["rtl", "land"]


def test_arducopter_takes_rtl_in_a_global_frame(site):
    # AP_Mission checks the frame only of a command with a location, and RTL has none
    plan = waypoint_plan(site, [(50, -40)], end="rtl")
    plan.items[-1] = dataclasses.replace(plan.items[-1], frame=int(Frame.GLOBAL_RELATIVE_ALT))
    assert [leg.kind for leg in resolve_flight(plan, site).legs][-2:] == ["rtl", "land"]


def test_px4_refuses_an_item_the_mission_never_reaches(site):
    """One refused item fails PX4's whole upload: an RTL after the LAND, never flown, had
    never been looked at."""
    plan = _px4(waypoint_plan(site, [(50, -40)]))
    plan.items.append(MissionItem(int(Cmd.NAV_RETURN_TO_LAUNCH), [0.0] * 7,
                                  int(Frame.GLOBAL_RELATIVE_ALT)))
    with pytest.raises(InputError, match=r"^p\.plan: item 5: PX4 takes NAV_RETURN_TO_LAUNCH"):
        resolve_flight(plan, site, "p.plan")


@pytest.mark.parametrize("frame, mode, refused", [(2, 3.0, True), (2, 1.0, False),
                                                  (3, 1.0, True), (3, 3.0, False)])
def test_px4_takes_each_roi_mode_only_in_its_frame(site, frame, mode, refused):
    """DO_SET_ROI at a location (mode 3) goes in a global frame, toward the next waypoint
    (1) in frame 2; the other way round PX4 refuses it (MAV_MISSION_INVALID_PARAM1)."""
    plan = _px4(waypoint_plan(site, [(50, -40)]))
    lat, lon = site.frame.to_geodetic(np.array([50.0, 0.0]))
    plan.items.insert(2, MissionItem(201, [mode, 0.0, 0.0, 0.0, float(lat), float(lon), 0.0],
                                     frame))
    if not refused:
        resolve_flight(plan, site)
        return
    with pytest.raises(InputError, match=r"^plan: item 3: PX4 takes DO_SET_ROI in frame "
                                         rf"{frame} only with param1 .*not {mode:g} "
                                         r"\(MAV_MISSION_INVALID_PARAM1\)"):
        resolve_flight(plan, site)


def test_arducopter_refuses_a_do_item_location_in_a_frame_without_positions(site):
    # DO_SET_ROI is stored with a location, whose frame AP_Mission checks as a waypoint's
    plan = waypoint_plan(site, [(50, -40)])
    plan.items.insert(2, MissionItem(201, [3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], 1))
    with pytest.raises(InputError, match=r"^plan: item 3: frame 1 is no frame for a position: "
                                         r"ArduPilot refuses the item"):
        resolve_flight(plan, site)


@pytest.mark.skipif(not PX4_MISSION_CPP.is_file(), reason=f"no PX4 source at {PX4_MISSION_CPP}")
def test_the_px4_tables_are_the_case_labels_of_its_mission_item_parser():
    """PX4_POSITIONED, PX4_UNPOSITIONED and PX4_ROI are the commands of the global-frame
    switch of parse_mavlink_mission_item, of its frame-2 switch, and of both."""
    text = PX4_MISSION_CPP.read_text(encoding="utf-8")
    body = text[text.index("MavlinkMissionManager::parse_mavlink_mission_item("):]
    body = body[:body.index("MavlinkMissionManager::format_mavlink_mission_item(")]
    in_global, in_mission = body.split("frame == MAV_FRAME_MISSION)", 1)

    def commands(part: str) -> dict[int, str]:
        names = re.findall(r"case (?:MAV|NAV)_CMD_(\w+):", part)
        return {int(getattr(mavlink, f"MAV_CMD_{n}")): n for n in names}

    g, m = commands(in_global), commands(in_mission)
    assert PX4_POSITIONED == {k: v for k, v in g.items() if k not in m}
    assert PX4_UNPOSITIONED == {k: v for k, v in m.items() if k not in g}
    assert PX4_ROI == {k: v for k, v in g.items() if k in m}


@pytest.mark.parametrize("px4", [False, True])
@pytest.mark.parametrize("left_out, given", [(4, "longitude"), (5, "latitude")])
def test_a_waypoint_with_one_coordinate_left_out_is_refused(site, px4, left_out, given):
    """Both autopilots get the missing one as 0 (MISSION_ITEM_INT) and fly toward the equator
    or the prime meridian: the resolver had taken a NaN in either for "where the vehicle is"."""
    plan = waypoint_plan(site, [(50, -40), (150, -40)])
    plan.items[3].params[left_out] = NAN
    with pytest.raises(InputError, match=rf"^p\.plan: item 4: \w+ left out \(null\) but "
                                         rf"{given} -?[\d.]+ given: .*give both or neither$"):
        resolve_flight(_px4(plan) if px4 else plan, site, "p.plan")


@pytest.mark.parametrize("lat, lon", [(NAN, 0.0), (0.0, NAN)])
def test_a_waypoint_whose_coordinates_both_travel_as_0_stays_put(site, lat, lon):
    # one left out and the other 0: both are sent as 0, "where the vehicle is"
    plan = waypoint_plan(site, [(50, -40), (150, -40)])
    plan.items[3].params[4:6] = [lat, lon]
    flight = resolve_flight(plan, site)
    np.testing.assert_allclose(flight.legs[2].end_xy_m, flight.legs[1].end_xy_m, atol=1e-9)
