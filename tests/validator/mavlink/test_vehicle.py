import time

import numpy as np
import pytest

from tests.validator.builders import make_site, waypoint_plan
from tests.validator.mavlink.conftest import rtl_plan, url_of
from validator.flight import resolve_flight
from validator.mavlink.driver import fly_mission
from validator.mavlink.link import Link, upload_to
from validator.mavlink.modes import ARDUCOPTER_MODES
from validator.mavlink.sim import CopterMode
from validator.mavlink.telemetry import telemetry_track
from validator.mavlink.wire import mavlink
from validator.motion.limits import site_limits
from validator.motion.profile import make_profile
from validator.replay import replay

FAST = 50.0


def heartbeat(link: Link):
    return link.recv(["HEARTBEAT"], time.monotonic() + 2.0)


def test_heartbeat_is_an_arducopter_quad_in_stabilize(plan, start_vehicle):
    with Link(url_of(start_vehicle(plan)), timeout_s=3) as link:
        hb = heartbeat(link)
    assert (hb.type, hb.autopilot) == (mavlink.MAV_TYPE_QUADROTOR,
                                       mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA)
    assert hb.custom_mode == CopterMode.STABILIZE == 0
    assert hb.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert not hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED


def test_arducopter_mode_numbers():
    assert (ARDUCOPTER_MODES.hold, ARDUCOPTER_MODES.auto) == (4, 3)
    assert (CopterMode.GUIDED, CopterMode.AUTO, CopterMode.RTL, CopterMode.LAND) == (4, 3, 6, 9)


def test_auto_needs_a_mission_and_does_not_arm(plan, start_vehicle):
    vehicle = start_vehicle(plan)
    with Link(url_of(vehicle), timeout_s=3) as link:
        assert link.command(mavlink.MAV_CMD_DO_SET_MODE, 1, 3) == mavlink.MAV_RESULT_FAILED
        upload_to(link, plan)
        link.command_ok(mavlink.MAV_CMD_DO_SET_MODE, 1, 3)
        assert link.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mavlink.MAV_RESULT_FAILED
        assert heartbeat(link).custom_mode == 3


def test_guided_takeoff_climbs_and_reports_position_at_20_hz(plan, start_vehicle):
    vehicle = start_vehicle(plan, speedup=FAST)
    with Link(url_of(vehicle), timeout_s=3) as link:
        link.command_ok(mavlink.MAV_CMD_DO_SET_MODE, 1, 4)
        link.command_ok(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        link.command_ok(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 12.0)
        times, alts = [], []
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and (not alts or alts[-1] < 11.99):
            m = link.recv(["GLOBAL_POSITION_INT"], deadline)
            if m is not None:
                times.append(m.time_boot_ms)
                alts.append(m.relative_alt / 1000.0)
    assert alts[-1] == pytest.approx(12.0, abs=0.01)
    gaps = np.diff(times)
    assert np.median(gaps) == 50 and gaps.max() <= 100  # >= 10 Hz in vehicle time


def test_mission_in_auto_reaches_every_item_and_lands(start_vehicle):
    site = make_site(nfz=((100.0, 0.0, 20.0),))
    plan = waypoint_plan(site, [(0.0, 60.0), (80.0, 60.0)], v=6.0)
    vehicle = start_vehicle(plan, speedup=FAST)
    with Link(url_of(vehicle), timeout_s=3) as link:
        upload_to(link, plan)
        tel = fly_mission(link, plan, time_limit_s=300)
    assert tel.end_reason == "landed"
    assert [seq for _, seq in tel.reached] == [1, 3, 4, 5]  # ArduPilot seq: takeoff, wps, land
    assert tel.rel_alt_m[-1] == 0.0 and not vehicle.armed
    seqs = tel.mission_seq[tel.t_s >= tel.mission_start_s]
    assert list(dict.fromkeys(seqs)) == [1, 3, 4, 5]  # DO_CHANGE_SPEED (2) takes no time


@pytest.mark.realtime
def test_the_vehicle_flies_the_validators_replay(start_vehicle):
    site = make_site(nfz=((100.0, 0.0, 20.0),))
    plan = waypoint_plan(site, [(0.0, 60.0), (80.0, 60.0), (80.0, 120.0)], v=8.0)
    profile = make_profile("arducopter", site_limits(site))
    vehicle = start_vehicle(plan, speedup=FAST, params=dict(profile.params),
                            max_speed_mps=site.max_speed_mps)
    with Link(url_of(vehicle), timeout_s=3) as link:
        upload_to(link, plan)
        tel = fly_mission(link, plan, time_limit_s=300)
    flight = resolve_flight(plan, site)
    model = replay(flight, profile)
    done = {leg.item: t for leg, t in zip(flight.legs, model.leg_done_s, strict=True)}
    # ArduPilot seq -> plan item; times from NAV_TAKEOFF, as the track's
    reached = {seq - 1: t - tel.takeoff_start_s for t, seq in tel.reached}
    assert sorted(reached) == sorted(done)
    # The vehicle took off in GUIDED, the replay in AUTO: compare from the first waypoint.
    t0_flown, t0_model = reached[2], done[2]
    for item in done:
        if item >= 2:
            # a reached message is timed by the last position before it: a position lost on a
            # busy machine's socket shifts it by a step or two of telemetry (0.05 s each)
            assert reached[item] - t0_flown == pytest.approx(done[item] - t0_model, abs=0.16)
    flown = telemetry_track(tel, flight, site, ardupilot=True, source="sitl")
    sel = flown.t_s >= t0_flown
    t_model = flown.t_s[sel] - t0_flown + t0_model
    xy_model = np.column_stack([np.interp(t_model, model.t_s, model.xy_m[:, i])
                                for i in range(2)])
    assert np.max(np.hypot(*(flown.xy_m[sel] - xy_model).T)) < 0.5


def test_fence_breach_is_reported_and_fence_action_rtl_brings_it_home(start_vehicle):
    site = make_site(nfz=((100.0, 0.0, 20.0),))
    plan = waypoint_plan(site, [(40.0, 0.0), (160.0, 0.0)], v=8.0, end="none")
    vehicle = start_vehicle(plan, speedup=FAST, params={"FENCE_ACTION": 1})
    with Link(url_of(vehicle), timeout_s=3) as link:
        upload_to(link, plan, require_fence=False)
        tel = fly_mission(link, plan, time_limit_s=300)
    assert tel.fence_breach.any()
    assert vehicle.breach_count == 1
    assert tel.end_reason == "landed"
    assert np.hypot(*site.frame.to_local(tel.lat_deg[-1], tel.lon_deg[-1])) < 0.05
    # it turned back: never got near the far side of the zone
    xy = site.frame.to_local(tel.lat_deg, tel.lon_deg)
    assert xy[:, 0].max() < 100.0


def test_rtl_command_flies_home_and_lands(start_vehicle):
    site = make_site(nfz=((100.0, 0.0, 20.0),))
    plan = rtl_plan(site, [(0.0, 80.0)])
    vehicle = start_vehicle(plan, speedup=FAST)
    with Link(url_of(vehicle), timeout_s=3) as link:
        upload_to(link, plan)
        link.command_ok(mavlink.MAV_CMD_DO_SET_MODE, 1, 4)
        link.command_ok(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        link.command_ok(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 5.0)
        time.sleep(0.3)
        link.command_ok(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and vehicle.armed:
            time.sleep(0.05)
    assert not vehicle.armed and vehicle.landed
    assert vehicle.mode == CopterMode.RTL


def test_loss_drops_about_that_fraction(plan, start_vehicle):
    vehicle = start_vehicle(plan, speedup=FAST, loss=0.3, seed=1)
    w = vehicle.writer
    deadline = time.monotonic() + 30.0  # a busy machine sends slower: count, not time
    while w.sent + w.dropped < 500 and time.monotonic() < deadline:
        time.sleep(0.1)
    n = w.sent + w.dropped
    assert n >= 500
    assert w.dropped / n == pytest.approx(0.3, abs=4 * (0.3 * 0.7 / n) ** 0.5)


def test_a_whole_flight_survives_20_percent_packet_loss(start_vehicle):
    site = make_site(nfz=((100.0, 0.0, 20.0),))
    plan = waypoint_plan(site, [(0.0, 60.0), (80.0, 60.0)], v=6.0)
    vehicle = start_vehicle(plan, speedup=FAST, loss=0.2, seed=3)
    with Link(url_of(vehicle), timeout_s=8, retry_s=0.1) as link:
        upload_to(link, plan)
        tel = fly_mission(link, plan, time_limit_s=300)
    assert tel.end_reason == "landed"
    assert vehicle.writer.dropped > 100
    flight = resolve_flight(plan, site)
    flown = telemetry_track(tel, flight, site, ardupilot=True, source="sitl")
    assert np.isfinite(flown.leg_done_s[1:]).all()  # every leg seen despite the gaps
