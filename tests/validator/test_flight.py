import dataclasses
import re

import numpy as np
import pytest

from tests.validator.builders import (
    ALT_M,
    jump,
    make_site,
    nav,
    plan_of,
    service_plan,
    speed,
    waypoint_plan,
)
from validator.errors import InputError
from validator.flight import DO_SET_HOME, parse_service, resolve_flight
from validator.plan_format import Autopilot, Cmd, Frame, MissionItem


@pytest.fixture(scope="module")
def site():
    return make_site()


def test_waypoints_become_straight_legs_from_home(site):
    flight = resolve_flight(waypoint_plan(site, [(50, -40), (150, -40)]), site)
    kinds = [leg.kind for leg in flight.legs]
    assert kinds == ["takeoff", "waypoint", "waypoint", "waypoint", "land"]
    np.testing.assert_allclose(flight.legs[1].start_xy_m, site.home_xy_m, atol=1e-6)
    np.testing.assert_allclose(flight.legs[2].end_xy_m, [150, -40], atol=1e-3)
    assert flight.legs[3].end_alt_m == 30.0 and flight.legs[4].end_alt_m == 0.0


def test_do_change_speed_holds_until_changed(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(3.0),
             nav(site, Cmd.NAV_WAYPOINT, (10, 0)), nav(site, Cmd.NAV_WAYPOINT, (20, 0)),
             speed(7.0), nav(site, Cmd.NAV_WAYPOINT, (30, 0))]
    legs = resolve_flight(plan_of(site, items), site).legs
    assert [leg.speed_mps for leg in legs[1:]] == [3.0, 3.0, 7.0]
    assert legs[3].first_item == 4  # the speed change belongs to the leg it governs


def test_do_jump_repeats_the_block(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), nav(site, Cmd.NAV_WAYPOINT, (10, 0)),
             nav(site, Cmd.NAV_WAYPOINT, (10, 10)), jump(1, 2),
             nav(site, Cmd.NAV_WAYPOINT, (0, 10))]
    flight = resolve_flight(plan_of(site, items), site)
    assert [leg.item for leg in flight.legs] == [0, 1, 2, 1, 2, 1, 2, 4]
    assert flight.cycle is not None and flight.cycle.cycles == 3


def test_do_jump_to_a_missing_item_is_bad_input(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), jump(40, 1)]
    with pytest.raises(InputError, match=r"item 2 \(DO_JUMP\): target 41 "):
        resolve_flight(plan_of(site, items), site)


def test_a_home_of_0_0_is_bad_input_not_a_leg_across_the_globe(site):
    # a leg of 4,600 km from 0°, 0° to the site took the replay and the depth steps of the
    # audit to tens of GB (a plan downloaded from a SITL with no home yet)
    plan = dataclasses.replace(waypoint_plan(site, [(50, -40)]), home_lat_deg=0.0,
                               home_lon_deg=0.0)
    with pytest.raises(InputError, match=r"^plan: plannedHomePosition at 0°, 0°: no home"):
        resolve_flight(plan, site)
    rally = dataclasses.replace(waypoint_plan(site, [(50, -40)]), rally=[(0.0, 0.0, 30.0)])
    with pytest.raises(InputError, match=r"^plan: rally point 0 at \(0.000000, 0.000000\), "
                                         r".* a plan for another site\?"):
        resolve_flight(rally, site)


def test_a_plan_for_another_site_is_bad_input_naming_the_item(site):
    plan = waypoint_plan(site, [(50, -40), (150_000, 0)])
    far = next(i for i, it in enumerate(plan.items) if it.params[5] > site.frame.lon0_deg + 1)
    with pytest.raises(InputError, match=rf"^plan: item {far + 1} at \(.*\), 150 km from the "
                                         r"origin of site .* \(beyond 100 km\)"):
        resolve_flight(plan, site)
    rally = waypoint_plan(site, [(50, -40)], rally=[(0, 120_000)])
    with pytest.raises(InputError, match=r"^plan: rally point 0 at .* 120 km from"):
        resolve_flight(rally, site)


def test_rtl_flies_straight_to_the_nearest_of_home_and_rally(site):
    plan = waypoint_plan(site, [(150, 30)], end="rtl", rally=[(160, 60)])
    flight = resolve_flight(plan, site)
    rtl = [leg for leg in flight.legs if leg.kind == "rtl"][0]
    np.testing.assert_allclose(rtl.start_xy_m, [150, 30], atol=1e-3)
    np.testing.assert_allclose(rtl.end_xy_m, [160, 60], atol=1e-3)
    assert flight.legs[-1].kind == "land"


def test_holds_and_loiter_time_are_kept(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m),
             nav(site, Cmd.NAV_WAYPOINT, (10, 0), p1=2.5),
             nav(site, Cmd.NAV_LOITER_TIME, (10, 10), p1=4.0)]
    legs = resolve_flight(plan_of(site, items), site).legs
    assert [leg.hold_s for leg in legs[1:]] == [2.5, 4.0]
    assert not legs[1].pass_through  # a hold stops the vehicle


def test_zero_position_means_here(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), nav(site, Cmd.NAV_WAYPOINT, (10, 5)),
             MissionItem(int(Cmd.NAV_WAYPOINT), [3.0, 0, 0, 0, 0.0, 0.0, 30.0],
                         int(Frame.GLOBAL_RELATIVE_ALT))]
    legs = resolve_flight(plan_of(site, items), site).legs
    np.testing.assert_allclose(legs[2].end_xy_m, [10, 5], atol=1e-3)


def test_unknown_command_is_listed_as_a_warning(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m),
             MissionItem(31337, [0.0] * 7, int(Frame.MISSION)),
             nav(site, Cmd.NAV_WAYPOINT, (10, 0))]
    findings = resolve_flight(plan_of(site, items), site).findings
    assert any(f.item == 1 and f.severity == "warning" and "31337" in f.message
               for f in findings)


def test_unsupported_navigation_command_is_a_violation(site):
    spline = nav(site, 82, (40, 40))
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), spline]
    findings = resolve_flight(plan_of(site, items), site).findings
    assert any(f.item == 1 and f.severity == "violation" and "SPLINE" in f.message
               for f in findings)


def test_metadata_defines_the_service_cycle(site):
    q = [(0, 60), (40, 60), (40, 60), (80, 60), (0, 60)]
    plan = service_plan(site, q, [4, 4, 2, 4], [0.1] * 4, ["GN1", None, "GN2", "GN1"],
                        cycles=2)
    flight = resolve_flight(plan, site)
    c = flight.cycle
    assert c is not None and c.source == "metadata" and c.cycles == 2
    assert flight.legs[c.end_leg].item == plan.extra["cycle_items"][1]
    assert flight.service is not None and flight.service.period_s == 14.0


@pytest.mark.parametrize(
    "patch, field",
    [
        ({"delta_s": [1.0, 2.0]}, "delta_s"),
        ({"schedule": ["GN9", None, None, None]}, "schedule[0]"),
        ({"cycles": 0}, "cycles"),
        ({"surprise": 1}, "surprise"),
        ({"format": 2}, "format"),
        # numbers that overflowed the scoring's geometry and rates (the hostile mutations)
        ({"trajectory_m": [[0, 0], [1, 1e308], [2, 0], [3, 0], [0, 0]]}, "trajectory_m[1]"),
        ({"delta_s": [1.0, 1e308, 1.0, 1.0]}, "delta_s: a period of 1e+308 s, beyond a day"),
        ({"power_w": [0.1, 0.1, 1e300, 0.1]}, "power_w[2]: must be within"),
    ],
)
def test_bad_metadata_names_the_field(site, patch, field):
    extra = {"format": 1, "site": "x", "scheme": "proposed",
             "trajectory_m": [[0, 0], [1, 0], [2, 0], [3, 0], [0, 0]],
             "delta_s": [1.0] * 4, "power_w": [0.1] * 4, "schedule": [None] * 4,
             "cycle_items": [1, 3], "cycles": 1, **patch}
    with pytest.raises(InputError, match=re.escape(f"nfzMission.{field}")):
        parse_service(extra, site)


def test_no_metadata_is_none(site):
    assert parse_service(None, site) is None


def test_legs_after_a_jump_start_at_its_target(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(4.0),
             nav(site, Cmd.NAV_WAYPOINT, (10, 0)), nav(site, Cmd.NAV_WAYPOINT, (10, 10)),
             jump(1, 1)]
    legs = resolve_flight(plan_of(site, items), site).legs
    assert [(leg.first_item, leg.item) for leg in legs[1:]] == [(1, 2), (3, 3), (1, 2), (3, 3)]


def test_cycle_items_beyond_the_mission_are_bad_input(site):
    q = [(0, 60), (40, 60), (0, 60)]
    plan = service_plan(site, q, [4, 4], [0.1] * 2, ["GN1", "GN2"])
    plan.extra["cycle_items"] = [3, 99]
    with pytest.raises(InputError, match=r"nfzMission\.cycle_items: index 99 \(item 100\) "
                                         "does not exist"):
        resolve_flight(plan, site)


@pytest.mark.parametrize("frame", [1, 4, 99])  # LOCAL_NED, LOCAL_ENU, nothing
def test_a_position_in_a_frame_the_autopilot_refuses_is_refused(site, frame):
    """ArduPilot answers MAV_MISSION_UNSUPPORTED_FRAME to such an item: it had been read as
    metres above home, with a warning, and the plan judged CLEAR."""
    plan = waypoint_plan(site, [(50, -40), (150, -40)])
    plan.items[3] = dataclasses.replace(plan.items[3], frame=frame)
    with pytest.raises(InputError, match=rf"^p\.plan: item 4: frame {frame} is no frame for a "
                                         "position"):
        resolve_flight(plan, site, "p.plan")


@pytest.mark.parametrize("frame", [0, 5])  # GLOBAL, GLOBAL_INT (MISSION: test_frames)
def test_an_absolute_frame_is_altitude_above_sea_level(site, frame):
    plan = waypoint_plan(site, [(50, -40), (150, -40)])
    plan.items[3] = dataclasses.replace(plan.items[3], frame=frame,
                                        params=[*plan.items[3].params[:6],
                                                plan.home_alt_m + 25.0])
    flight = resolve_flight(plan, site)
    assert flight.legs[2].end_alt_m == pytest.approx(25.0)
    assert not any("frame" in f.message for f in flight.findings)


def _loiter_turns_plan(site):
    turns = nav(site, Cmd.NAV_LOITER_TURNS, (60, 0), p1=1.0)
    return plan_of(site, [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(5.0), turns,
                          nav(site, Cmd.NAV_LAND, site.home_xy_m, 0.0)])


def test_a_loiter_turns_of_radius_0_flies_arducopters_circle_radius(site):
    """ArduCopter keeps its circle's radius for a LOITER_TURNS of radius 0 (CIRCLE_RADIUS,
    10 m by default): read as a hover at the centre, a loiter 8 m from a zone was CLEAR while
    the vehicle circles 2 m into it."""
    plan = _loiter_turns_plan(site)
    loiter = next(leg for leg in resolve_flight(plan, site).legs if leg.kind == "loiter")
    assert loiter.loiter_radius_m == 10.0


def test_px4_refuses_a_loiter_turns(site):
    """PX4 v1.15's mission parser has no LOITER_TURNS in any frame: the upload fails, where
    it had been resolved as a hover at the centre."""
    plan = dataclasses.replace(_loiter_turns_plan(site), firmware_type=int(Autopilot.PX4))
    with pytest.raises(InputError, match=r"^plan: item 3: PX4 takes NAV_LOITER_TURNS in no "
                                         r"frame: it refuses the item "
                                         r"\(MAV_MISSION_UNSUPPORTED\)$"):
        resolve_flight(plan, site)


def test_a_jump_that_repeats_forever_is_a_violation_where_the_endurance_is_known(site):
    """Resolved with one repeat it had passed the endurance check; ArduPilot flies it until a
    failsafe ends it."""
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(5.0),
             nav(site, Cmd.NAV_WAYPOINT, (40, 0)), nav(site, Cmd.NAV_WAYPOINT, (40, 40)),
             jump(2, -1), nav(site, Cmd.NAV_LAND, site.home_xy_m, 0.0)]
    plan = plan_of(site, items)
    open_ended = [f.severity for f in resolve_flight(plan, site).findings
                  if "repeats forever" in f.message]
    assert open_ended == ["warning"]
    timed = site.with_limits(endurance_s=900.0)
    found = [f for f in resolve_flight(plan, timed).findings if "repeats forever" in f.message]
    assert [(f.severity, f.item) for f in found] == [("violation", 4)]
    assert "beyond the UAV's endurance of 900 s" in found[0].message


def test_a_home_moved_into_a_zone_is_a_violation(site):
    """DO_SET_HOME (param1 0: at its coordinates) into a zone had been a note: every return
    after it lands there."""
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(5.0),
             nav(site, Cmd.NAV_WAYPOINT, (40, -40)),
             nav(site, DO_SET_HOME, (100, 0)),
             nav(site, Cmd.NAV_WAYPOINT, (40, -40))]
    found = [(f.severity, f.item) for f in resolve_flight(plan_of(site, items), site).findings
             if "DO_SET_HOME" in f.message]
    assert found == [("violation", 3)]
    items[3] = dataclasses.replace(items[3], params=[*items[3].params[:4],
                                                     *items[2].params[4:]])
    found = [(f.severity, f.item) for f in resolve_flight(plan_of(site, items), site).findings
             if "DO_SET_HOME" in f.message]
    assert found == [("note", 3)]


# --------------------------------------------------------------------------------------------
# DO_SET_HOME: the home in force on each leg (validator.flight.home)


def _set_home(p1: float, lat_deg: float, lon_deg: float, alt_m: float,
              frame: int = int(Frame.GLOBAL_RELATIVE_ALT)) -> MissionItem:
    return MissionItem(DO_SET_HOME, [p1, 0.0, 0.0, 0.0, lat_deg, lon_deg, alt_m], frame)


def _around(site, set_home: MissionItem, px4: bool = False):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), nav(site, Cmd.NAV_WAYPOINT, (40, -40)),
             set_home, nav(site, Cmd.NAV_WAYPOINT, (0, -40))]
    plan = plan_of(site, items)
    return dataclasses.replace(plan, firmware_type=int(Autopilot.PX4)) if px4 else plan


def test_each_leg_carries_the_home_in_force_while_it_is_flown(site):
    lat, lon = site.frame.to_geodetic(np.array([60.0, -60.0]))
    flight = resolve_flight(_around(site, _set_home(0.0, lat, lon, 30.0)), site)
    homes = [flight.home_of(k) for k in range(len(flight.legs))]
    assert [h.set_by_item for h in homes] == [None, None, 2]
    np.testing.assert_allclose(homes[0].xy_m, site.home_xy_m, atol=1e-9)
    np.testing.assert_allclose(homes[2].xy_m, [60, -60], atol=1e-3)


def test_the_missions_rtl_after_a_do_set_home_flies_to_the_new_home(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), nav(site, Cmd.NAV_WAYPOINT, (40, -40)),
             _set_home(1.0, 0.0, 0.0, 0.0), nav(site, Cmd.NAV_WAYPOINT, (0, -40)),
             MissionItem(int(Cmd.NAV_RETURN_TO_LAUNCH), [0.0] * 7, int(Frame.MISSION))]
    rtl = next(leg for leg in resolve_flight(plan_of(site, items), site).legs
               if leg.kind == "rtl")
    np.testing.assert_allclose(rtl.end_xy_m, [40, -40], atol=1e-3)


def test_a_home_set_where_the_vehicle_is_in_the_air_is_at_its_altitude(site):
    """ArduCopter and PX4 take the whole current location: home moves up to the vehicle
    (measured on ArduCopter 4.5.6 SITL: HOME_POSITION 20 m above the ground)."""
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m, 25.0),
             nav(site, Cmd.NAV_WAYPOINT, (40, -40), 18.0),
             _set_home(1.0, 0.0, 0.0, 0.0), nav(site, Cmd.NAV_WAYPOINT, (0, -40), 18.0)]
    assert resolve_flight(plan_of(site, items), site).home_of(2).alt_m == pytest.approx(18.0)


def test_a_home_set_at_a_location_above_home_is_above_the_home_in_force(site):
    """AP_AHRS::set_home makes a frame-3 altitude absolute against the home it replaces."""
    lat, lon = site.frame.to_geodetic(np.array([60.0, -60.0]))
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), nav(site, Cmd.NAV_WAYPOINT, (40, -40)),
             _set_home(1.0, 0.0, 0.0, 0.0),  # in the air: home 30 m up
             nav(site, Cmd.NAV_WAYPOINT, (0, -40)),
             _set_home(0.0, lat, lon, -26.0), nav(site, Cmd.NAV_WAYPOINT, (40, -40))]
    home = resolve_flight(plan_of(site, items), site).home_of(3)
    assert home.set_by_item == 4 and home.alt_m == pytest.approx(ALT_M - 26.0)


def test_a_home_set_at_a_location_above_sea_level_is_level_with_it(site):
    lat, lon = site.frame.to_geodetic(np.array([60.0, -60.0]))
    item = _set_home(0.0, lat, lon, site.frame.alt0_m + 7.0, int(Frame.GLOBAL))
    home = resolve_flight(_around(site, item), site).home_of(2)
    assert home.alt_m == pytest.approx(7.0)


def test_a_home_moved_up_in_the_air_is_a_warning(site):
    """Altitudes above home after it move with it: ArduCopter 4.5.6 SITL flew the next leg at
    its old height and hovered at its waypoint for good."""
    found = [(f.severity, f.item) for f in
             resolve_flight(_around(site, _set_home(1.0, 0.0, 0.0, 0.0)), site).findings
             if f.message.startswith("home moves 30 m up")]
    assert found == [("warning", 2)]


def test_a_home_set_at_the_grounds_altitude_moves_no_height(site):
    lat, lon = site.frame.to_geodetic(np.array([60.0, -60.0]))
    item = _set_home(0.0, lat, lon, site.frame.alt0_m, int(Frame.GLOBAL))
    found = [f for f in resolve_flight(_around(site, item), site).findings
             if f.message.startswith("home moves")]
    assert found == []


def test_an_arducopter_do_set_home_at_0_0_with_an_altitude_moves_home_off_the_site(site):
    """AP_AHRS::set_home refuses only latitude, longitude and altitude all 0: with an
    altitude, a DO_SET_HOME without coordinates (param1 0) sends home to 0°N 0°E."""
    found = [(f.severity, f.item) for f in
             resolve_flight(_around(site, _set_home(0.0, 0.0, 0.0, 30.0)), site).findings
             if "0°N 0°E" in f.message]
    assert found == [("violation", 2)]


def test_an_arducopter_do_set_home_with_coordinates_in_the_mission_frame_is_refused(site):
    lat, lon = site.frame.to_geodetic(np.array([60.0, -60.0]))
    flight = resolve_flight(_around(site, _set_home(0.0, lat, lon, 30.0, int(Frame.MISSION))),
                            site)
    found = [(f.severity, f.item) for f in flight.findings if "degrees x 1e7" in f.message]
    assert found == [("violation", 2)]
    assert flight.home_of(2).set_by_item is None  # where it goes is not the item's position


def test_px4_refuses_a_do_set_home_in_a_global_frame(site):
    # as PX4 refuses the upload (frames.py's rule), not a violation of a plan it would fly
    with pytest.raises(InputError, match=r"^p\.plan: item 3: PX4 takes DO_SET_HOME only in "
                                         r"frame 2 .*\(MAV_MISSION_UNSUPPORTED\)"):
        resolve_flight(_around(site, _set_home(1.0, 0.0, 0.0, 0.0), px4=True), site, "p.plan")


def test_px4_cannot_take_a_do_set_home_at_coordinates(site):
    lat, lon = site.frame.to_geodetic(np.array([60.0, -60.0]))
    item = _set_home(0.0, lat, lon, 30.0, int(Frame.MISSION))
    found = [(f.severity, f.item) for f in
             resolve_flight(_around(site, item, px4=True), site).findings
             if "unscaled" in f.message]
    assert found == [("violation", 2)]


def test_px4_takes_any_param1_above_one_half_as_the_current_position(site):
    item = _set_home(0.7, 0.0, 0.0, 0.0, int(Frame.MISSION))
    flight = resolve_flight(_around(site, item, px4=True), site)
    assert flight.home_of(2).set_by_item == 2
    np.testing.assert_allclose(flight.home_of(2).xy_m, [40, -40], atol=1e-3)


def test_a_do_set_home_behind_a_condition_is_a_warning(site):
    """A CONDITION_* item holds back the DO items after it until it is met, or for ever when
    the next waypoint comes first: when home moves is not known."""
    delay = MissionItem(112, [5.0, 0, 0, 0, 0, 0, 0], int(Frame.MISSION))  # CONDITION_DELAY
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), nav(site, Cmd.NAV_WAYPOINT, (40, -40)),
             delay, _set_home(1.0, 0.0, 0.0, 0.0), nav(site, Cmd.NAV_WAYPOINT, (0, -40))]
    found = [(f.severity, f.item) for f in resolve_flight(plan_of(site, items), site).findings
             if "waits for CONDITION_DELAY (item 3)" in f.message]
    assert found == [("warning", 3)]
