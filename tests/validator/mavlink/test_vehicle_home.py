"""The built-in vehicle's home after a mission's DO_SET_HOME: where RTL flies, what
HOME_POSITION and the relative altitude report (the copter stepped by hand, no socket; the
rule itself is validator.flight.home's, tested in test_flight.py)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from tests.validator.builders import make_site, nav, plan_of, speed
from tests.validator.mavlink.conftest import url_of
from validator.flight import DO_SET_HOME
from validator.geodesy import LocalFrame, from_int_e7
from validator.mavlink.autoflight import build_auto_track
from validator.mavlink.driver import fly_mission
from validator.mavlink.link import Link, home_of, upload_to
from validator.mavlink.sim import CopterMode, VehicleConfig
from validator.mavlink.sim.copter import Copter
from validator.mavlink.sim.params import ParamTable
from validator.mavlink.wire import plan_to_wire
from validator.motion.limits import site_limits
from validator.motion.profile import make_profile
from validator.plan_format import Cmd, Frame, MissionItem, Plan

ALT_M = 20.0
A_XY, B_XY = (0.0, 60.0), (80.0, 60.0)
DT_S = 0.05


class Sent:
    """A stand-in for the vehicle's pymavlink sender: keeps every ``*_send`` call's args."""

    def __init__(self) -> None:
        self.calls: dict[str, list[tuple[Any, ...]]] = {}

    def __getattr__(self, name: str) -> Any:
        return lambda *args: self.calls.setdefault(name, []).append(args)


@pytest.fixture()
def site():
    return make_site(nfz=((300.0, 300.0, 10.0),), gns=(A_XY, B_XY))


def set_home_plan(site, *, end: str = "rtl") -> Plan:
    """Takeoff, A, DO_SET_HOME where the vehicle is (at A, 20 m up), B, C and RTL."""
    items = [nav(site, Cmd.NAV_TAKEOFF, (0, 0), ALT_M), speed(8.0),
             nav(site, Cmd.NAV_WAYPOINT, A_XY, ALT_M),
             MissionItem(DO_SET_HOME, [1.0, 0, 0, 0, 0, 0, 0], int(Frame.GLOBAL_RELATIVE_ALT)),
             nav(site, Cmd.NAV_WAYPOINT, B_XY, ALT_M),
             nav(site, Cmd.NAV_WAYPOINT, (80.0, 160.0), ALT_M)]
    if end == "rtl":
        items.append(MissionItem(int(Cmd.NAV_RETURN_TO_LAUNCH), [0.0] * 7, int(Frame.MISSION)))
    return plan_of(site, items, fence=False)


def copter_for(plan: Plan) -> tuple[Copter, Sent]:
    home = (plan.home_lat_deg, plan.home_lon_deg, plan.home_alt_m)
    config = VehicleConfig(home=home)
    lists = plan_to_wire(plan, home_item=True)
    sent = Sent()
    copter = Copter(config, LocalFrame(*home), ParamTable(config, config.limits), sent,
                    lambda: lists)
    return copter, sent


def fly_until(copter: Copter, done, limit_s: float = 300.0) -> None:
    t = copter.t_s
    while not done() and t < copter.t_s + limit_s + 1.0:
        t += DT_S
        copter.step(t, DT_S)
    assert done(), "the copter did not get there in time"


def start_mission(copter: Copter) -> None:
    copter.set_mode(CopterMode.GUIDED)
    copter.arm(True, False)
    copter.mission_start(0)


CORNER_M = 3.0  # the corner at A is cut inside WPNAV_RADIUS (2 m), and sampled at 20 Hz


def on_leg_to_b(copter: Copter) -> bool:
    return copter.current_seq == 5 and copter.xy[0] > 20.0  # seq 5: B (index 4, item 5)


def past_set_home(site) -> tuple[Copter, Sent]:
    """The copter flying the set-home plan, on its leg to B: the home moved to where it cut
    the corner at A."""
    copter, sent = copter_for(set_home_plan(site))
    start_mission(copter)
    fly_until(copter, lambda: on_leg_to_b(copter))
    return copter, sent


def test_rtl_after_a_do_set_home_lands_at_the_new_home(site):
    copter, _ = past_set_home(site)
    home_xy = copter.home.xy_m.copy()
    assert 0.0 < np.hypot(*(home_xy - np.asarray(A_XY))) < CORNER_M
    copter.set_mode(CopterMode.RTL)
    fly_until(copter, lambda: not copter.armed)
    np.testing.assert_allclose(copter.xy, home_xy, atol=0.1)


def test_rtl_climbs_rtl_alt_above_the_new_home(site):
    """The home set at A's corner, 20 m up: RTL_ALT (15 m) above it is 35 m above the
    ground."""
    copter, _ = past_set_home(site)
    copter.set_mode(CopterMode.RTL)
    assert copter._target is not None
    assert copter._target[1] == pytest.approx(ALT_M + copter._param_si("RTL_ALT"))


def test_the_vehicle_sends_its_new_home_unasked(site):
    copter, sent = past_set_home(site)
    lat, lon, alt = sent.calls["home_position_send"][-1][:3]
    xy = site.frame.to_local(from_int_e7(lat), from_int_e7(lon))
    np.testing.assert_allclose(xy, copter.home.xy_m, atol=0.02)
    assert np.hypot(*(xy - np.asarray(A_XY))) < CORNER_M
    assert alt / 1000.0 == pytest.approx(site.frame.alt0_m + ALT_M, abs=0.01)


def test_relative_altitude_is_reported_above_the_new_home(site):
    copter, sent = past_set_home(site)
    before = len(sent.calls["global_position_int_send"])
    copter.step(copter.t_s + DT_S, DT_S)
    amsl_mm, rel_mm = sent.calls["global_position_int_send"][before][3:5]
    assert amsl_mm / 1000.0 == pytest.approx(site.frame.alt0_m + ALT_M, abs=0.01)
    assert rel_mm / 1000.0 == pytest.approx(0.0, abs=0.01)


def test_arming_again_homes_where_the_vehicle_is(site):
    copter, _ = past_set_home(site)
    copter.set_mode(CopterMode.LAND)
    fly_until(copter, lambda: not copter.armed)
    landed_xy = copter.xy.copy()
    copter.set_mode(CopterMode.GUIDED)
    copter.arm(True, False)
    assert copter.home.set_by_item is None
    np.testing.assert_allclose(copter.home.xy_m, landed_xy, atol=1e-9)


def _track_from(plan: Plan, site, start_index: int):
    profile = make_profile("arducopter", site_limits(site))
    return build_auto_track(plan, site.frame, start_index=start_index,
                            start_xy_m=np.asarray(A_XY), start_alt_m=ALT_M, profile=profile,
                            dt_s=DT_S)


def test_a_mission_flown_through_its_do_set_home_moves_home_as_the_next_leg_becomes_current(site):
    track = _track_from(set_home_plan(site), site, start_index=2)
    assert [home.set_by_item for _, home in track.homes] == [3]
    t_s, _ = track.homes[0]
    assert track.current_index_at(t_s + DT_S) == 4  # flying to B


def test_a_home_set_at_the_current_position_is_where_the_flown_track_is_not_the_waypoint(site):
    """Flown from the ground, the copter cuts the corner at A; the DO_SET_HOME after A runs as
    the leg to B becomes current, where the vehicle is then (ArduCopter 4.5.6 SITL: 1.7 m
    from the waypoint), which is not A."""
    profile = make_profile("arducopter", site_limits(site))
    track = build_auto_track(set_home_plan(site), site.frame, start_index=0,
                             start_xy_m=np.zeros(2), start_alt_m=0.0, profile=profile,
                             dt_s=DT_S)
    t_s, home = track.homes[0]
    xy, alt, _ = track.state_at(t_s)
    assert np.hypot(*(xy - np.asarray(A_XY))) > 1.0  # the corner is cut: the test can tell
    np.testing.assert_allclose(home.xy_m, xy, atol=1e-9)
    assert home.alt_m == pytest.approx(alt)


def test_a_restart_after_the_do_set_home_does_not_move_home_again(site):
    assert _track_from(set_home_plan(site), site, start_index=4).homes == ()


def test_over_mavlink_the_vehicle_answers_with_the_home_its_mission_set(site, start_vehicle):
    plan = set_home_plan(site)
    vehicle = start_vehicle(plan, speedup=50.0)
    with Link(url_of(vehicle), timeout_s=3) as link:
        upload_to(link, plan, require_fence=False)
        tel = fly_mission(link, plan, time_limit_s=300)
        home = home_of(link)
    assert tel.end_reason == "landed"
    assert home is not None
    home_xy = np.asarray(site.frame.to_local(home[0], home[1]), dtype=float)
    assert np.hypot(*(home_xy - np.asarray(A_XY))) < CORNER_M
