import dataclasses
import math

import numpy as np
import pytest

from tests.validator.builders import ALT_M, make_site, service_plan, waypoint_plan
from validator.audit import audit
from validator.flight import resolve_flight
from validator.motion.limits import site_limits
from validator.motion.profile import make_profile
from validator.replay import replay, score_track, track_from_samples


@pytest.fixture(scope="module")
def site():
    return make_site()  # NFZ of 20 m at (100, 0); GN1 (0, 50), GN2 (200, 50); V = 10 m/s


@pytest.fixture(scope="module")
def service(site):
    # 60 m east at 10 m/s, a 3 s hover, 40 m north, 72 m back at 9 m/s: T = 21 s
    q = [(0, 60), (60, 60), (60, 60), (60, 100), (0, 60)]
    return service_plan(site, q, [6.0, 3.0, 4.0, 8.0], [0.1, 0.2, 0.1, 0.1],
                        ["GN1", "GN1", None, "GN2"], cycles=3)


def test_ideal_profile_reproduces_the_planned_cycle_time(site, service):
    flight = resolve_flight(service, site)
    rep = score_track(replay(flight, make_profile("ideal", site_limits(site))), flight, site,
                      service)
    assert rep.cycle is not None
    assert rep.cycle.planned_period_s == pytest.approx(21.0)
    assert rep.cycle.flown_cycle_s == pytest.approx(21.0, rel=0.01)
    assert rep.cycle.flown_cycles_s == pytest.approx((21.0, 21.0, 21.0), rel=0.01)


def test_arducopter_cycle_is_longer_than_planned(site, service):
    flight = resolve_flight(service, site)
    rep = score_track(replay(flight, make_profile("arducopter", site_limits(site))), flight, site,
                      service)
    assert rep.cycle is not None and rep.cycle.ratio > 1.2
    assert len(rep.cycle.flown_cycles_s) == 3
    assert rep.max_lag_s > 0


def test_track_is_sampled_at_20_hz_by_default(site, service):
    track = replay(resolve_flight(service, site), make_profile("arducopter", site_limits(site)))
    assert np.diff(track.t_s).max() <= 0.05 + 1e-9
    assert track.mission_seq.min() >= 0


def test_hover_slots_get_exactly_the_planned_rate(site):
    q = [(60, 60)] * 5
    plan = service_plan(site, q, [2.0, 3.0, 1.0, 4.0], [0.1, 0.3, 0.2, 0.1],
                        ["GN1", "GN2", "GN1", None])
    flight = resolve_flight(plan, site)
    for name in ("ideal", "arducopter"):
        rep = score_track(replay(flight, make_profile(name, site_limits(site)), dt_s=0.01),
                          flight, site, plan)
        assert rep.throughput is not None
        np.testing.assert_allclose(rep.throughput.flown_bps_hz, rep.throughput.planned_bps_hz,
                                   rtol=2e-3)


def test_flown_rate_is_the_rate_integrated_along_the_leg(site):
    # out 100 m east at 10 m/s serving GN1, back serving GN2: T = 20 s
    q = [(0, 60), (100, 60), (0, 60)]
    p = 0.1
    plan = service_plan(site, q, [10.0, 10.0], [p, p], ["GN1", "GN2"])
    flight = resolve_flight(plan, site)
    rep = score_track(replay(flight, make_profile("ideal", site_limits(site))), flight, site, plan)
    t = np.linspace(0.0, 10.0, 200001)
    snr0 = site.beta0 * p / site.noise_w

    def bits(x, gn):
        d2 = (x - site.gn_xy_m[gn, 0]) ** 2 + (60 - site.gn_xy_m[gn, 1]) ** 2 + ALT_M**2
        return np.trapezoid(np.log2(1 + snr0 / d2), t)

    expected = np.array([bits(10.0 * t, 0), bits(100.0 - 10.0 * t, 1)]) / 20.0
    assert rep.throughput is not None
    np.testing.assert_allclose(rep.throughput.flown_bps_hz, expected, rtol=2e-3)
    # the paper's discrete model scores slot n at its end point q[n]: not the same number
    assert not np.allclose(rep.throughput.planned_bps_hz, expected, rtol=2e-3)


def test_a_slot_moving_less_than_the_match_tolerance_is_still_scored(site):
    # An 8 cm last slot (the slow end of a jerk-limited leg) is a move, not a hover: it is
    # longer than the exporter's 5 cm stationary tolerance.
    q = [(0, 60), (60, 60), (0.08, 60), (0, 60)]
    plan = service_plan(site, q, [6.0, 6.0, 1.0], [0.1, 0.1, 0.1], ["GN1", "GN2", "GN1"])
    flight = resolve_flight(plan, site)
    rep = score_track(replay(flight, make_profile("ideal", site_limits(site))), flight, site, plan)
    assert rep.throughput is not None, [f.message for f in rep.findings]


def test_slots_slowing_into_a_waypoint_all_belong_to_its_leg(site):
    # The last two slots of the cycle's last leg end 9 cm and then 0 cm from its waypoint (an
    # S-curve's slow arrival): both are flown on the leg, neither is a hover.
    plan = service_plan(site, [(0, 60), (60, 60), (0, 60)], [6.0, 7.0], [0.1, 0.1],
                        ["GN1", "GN2"])
    plan.extra.update(trajectory_m=[[0, 60], [60, 60], [0.09, 60], [0, 60]],
                      delta_s=[6.0, 6.0, 1.0], power_w=[0.1] * 3, schedule=["GN1", "GN2", "GN2"])
    flight = resolve_flight(plan, site)
    rep = score_track(replay(flight, make_profile("ideal", site_limits(site))), flight, site, plan)
    assert rep.throughput is not None, [f.message for f in rep.findings]


def test_throughput_is_skipped_without_metadata(site):
    plan = waypoint_plan(site, [(0, -40), (200, -40)], end="none")
    flight = resolve_flight(plan, site)
    rep = score_track(replay(flight, make_profile("arducopter", site_limits(site))), flight, site,
                      plan)
    assert rep.throughput is None
    assert any("throughput not scored" in f.message for f in rep.findings)


def test_corner_cut_enters_an_nfz_the_straight_legs_clear():
    # two legs tangent to a 20 m NFZ (0.05 m clear) meeting 0.6 m outside it in a 26.6° turn
    # toward it: ArduCopter cuts inside the turn, up to WPNAV_RADIUS (2 m) from the waypoint,
    # less where the corner speed rule binds first
    site = make_site(nfz=((100.0, 0.0, 20.0),), buffer_m=0.0)
    a = math.asin(20.05 / 20.6)
    v = np.array([100.0, -20.6])
    p1 = v + 60.0 * np.array([-math.sin(a), math.cos(a)])
    p2 = v + 60.0 * np.array([math.sin(a), math.cos(a)])
    plan = waypoint_plan(site, [p1, v, p2], v=8.0, end="none")
    assert audit(plan, site).ok
    flight = resolve_flight(plan, site)
    ideal = score_track(replay(flight, make_profile("ideal", site_limits(site))), flight, site,
                        plan)
    assert ideal.nfz[0].clearance_m == pytest.approx(0.05, abs=1e-3)
    ardu = score_track(replay(flight, make_profile("arducopter", site_limits(site))), flight,
                       site, plan)
    assert -1.41 < ardu.nfz[0].clearance_m < -1.0
    assert any("flown track enters NFZ1" in f.message for f in ardu.violations)


def test_recorded_track_is_scored_like_the_replay(site, service):
    flight = resolve_flight(service, site)
    track = replay(flight, make_profile("arducopter", site_limits(site)))
    rep = score_track(track, flight, site, service)
    recorded = track_from_samples(flight, track.t_s, track.xy_m, track.mission_seq,
                                  alt_m=track.alt_m)
    rec = score_track(recorded, flight, site, service)
    assert rec.cycle is not None and rep.cycle is not None
    assert rec.cycle.flown_cycle_s == pytest.approx(rep.cycle.flown_cycle_s, abs=0.1)
    assert rec.nfz[0].clearance_m == pytest.approx(rep.nfz[0].clearance_m, abs=1e-9)
    assert rec.throughput is not None and rep.throughput is not None
    np.testing.assert_allclose(rec.throughput.flown_bps_hz, rep.throughput.flown_bps_hz,
                               rtol=0.02)


def _failsafe_return(site, flight):
    """A replayed flight that leaves the mission in its last cycle's closing leg and returns
    home by way of that leg's destination, reporting the closing item all the way (as
    ArduCopter does through SmartRTL): samples (t, xy, seq) and the index where it left."""
    track = replay(flight, make_profile("arducopter", site_limits(site)))
    assert flight.cycle is not None
    closing = flight.legs[flight.cycle.end_leg].item
    on_closing = np.flatnonzero(track.mission_seq == closing)
    last_run = on_closing[np.flatnonzero(np.diff(on_closing) > 1)[-1] + 1:]  # the last cycle's
    left = int(last_run[len(last_run) // 2])
    # the return: by way of the closing leg's destination (SmartRTL retraces the cycle's start)
    dest = flight.legs[flight.cycle.end_leg].end_xy_m
    way = [track.xy_m[left - 1], dest, flight.home_xy_m]
    back = np.concatenate([a + np.linspace(0.0, 1.0, 400)[:, None] * (b - a)
                           for a, b in zip(way[:-1], way[1:], strict=True)])
    t = np.concatenate([track.t_s[:left],
                        track.t_s[left - 1] + 0.05 * np.arange(1, len(back) + 1)])
    xy = np.concatenate([track.xy_m[:left], back])
    seq = np.concatenate([track.mission_seq[:left], np.full(len(back), closing)])
    seq[-5:] = -1  # disarmed
    return t, xy, seq, left


def test_a_return_after_the_vehicle_left_the_mission_is_no_cycle_flown(site, service):
    """ArduCopter keeps reporting the item it was flying through a failsafe's SmartRTL until
    it has landed and disarmed: that run's end, or the return passing the item's destination,
    counted the item as done, a cycle flown (ArduCopter 4.5.6 SITL, realistic.yaml in 6 m/s
    from 135°, RC loss on the closing leg: "2.01 x planned"). Aligned on the samples before
    the vehicle left, the recording covers no cycle; its clearances still cover the whole
    track."""
    flight = resolve_flight(service, site)
    t, xy, seq, left = _failsafe_return(site, flight)
    flown_on = track_from_samples(flight, t, xy, seq)
    counted = score_track(flown_on, flight, site, service)
    assert counted.cycle is not None  # what the run's end made of it before
    recorded = track_from_samples(flight, t, xy, seq, left_mission_s=float(t[left]))
    rec = score_track(recorded, flight, site, service)
    assert rec.cycle is None
    # the return is scored for clearance as the mission is: to the last reported item
    assert np.array_equal(recorded.leg >= 0, flown_on.leg >= 0)
    assert rec.nfz[0].clearance_m == pytest.approx(counted.nfz[0].clearance_m, abs=1e-9)


def test_a_track_that_left_the_mission_is_timed_from_its_cycle_start(site, service):
    """A recording that completes no cycle (a failsafe took the vehicle home in its last one)
    counts its waypoint lags from where it started the cycle, as a complete one does. They
    had counted from its first sample: every lag 37 s late by the take-off and transit
    (ArduCopter 4.5.6 SITL, realistic.yaml, RC loss)."""
    flight = resolve_flight(service, site)
    t, xy, seq, left = _failsafe_return(site, flight)
    whole = score_track(track_from_samples(flight, t, xy, seq), flight, site, service)
    rec = score_track(track_from_samples(flight, t, xy, seq, left_mission_s=float(t[left])),
                      flight, site, service)
    assert whole.cycle is not None and rec.cycle is None
    both = [(a["lag_s"], b["lag_s"]) for a, b in zip(whole.waypoint_lag, rec.waypoint_lag,
                                                      strict=True) if b["lag_s"] is not None]
    assert len(both) > 5
    for counted, lag in both:
        assert lag == pytest.approx(counted, abs=1e-9)


def test_the_flight_after_the_vehicle_left_the_mission_is_no_cross_track_error(site, service):
    """The cross-track deviation measures the mission's legs flown; a failsafe's own path,
    here 80 m to the side, is scored for clearance only (it had read "max 87.53 m" after an
    RC loss on ArduCopter 4.5.6 SITL)."""
    flight = resolve_flight(service, site)
    t, xy, seq, left = _failsafe_return(site, flight)
    xy[left:] += np.linspace(0.0, 1.0, t.size - left)[:, None] * np.array([0.0, 80.0])
    whole = score_track(track_from_samples(flight, t, xy, seq), flight, site, service)
    rec = score_track(track_from_samples(flight, t, xy, seq, left_mission_s=float(t[left])),
                      flight, site, service)
    before = score_track(track_from_samples(flight, t[:left], xy[:left], seq[:left]), flight,
                         site, service)
    assert whole.cross_track_max_m > 20.0
    assert rec.cross_track_max_m == pytest.approx(before.cross_track_max_m, abs=1e-9)
    assert rec.cross_track_max_m < 5.0


def test_a_track_file_keeps_when_the_vehicle_left_the_mission(site, service, tmp_path):
    """Scored again from its track file (``validate-mission --track``, ``score_recorded``),
    the same return is still no cycle flown: the file's ``left_mission`` column says when the
    vehicle left; a file without it is scored as before."""
    from validator import api
    from validator.track_file import RecordedTrack, write_track

    flight = resolve_flight(service, site)
    t, xy, seq, left = _failsafe_return(site, flight)
    lat, lon = site.frame.to_geodetic(xy)
    n = t.size
    rec = RecordedTrack(t, lat, lon, np.full(n, site.altitude_m), np.zeros((n, 3)), seq,
                        seq >= 0, np.zeros(n, bool), t >= t[left])
    write_track(tmp_path / "left.csv", rec)
    assert api.score_recorded(service, site, tmp_path / "left.csv").cycle is None
    write_track(tmp_path / "unsaid.csv", dataclasses.replace(rec, left_mission=None))
    assert api.score_recorded(service, site, tmp_path / "unsaid.csv").cycle is not None


def test_a_flight_longer_than_the_endurance_is_a_violation_naming_both_times(site, service):
    flight = resolve_flight(service, site)
    track = replay(flight, make_profile("arducopter", site_limits(site)))
    flying_s = float(track.t_s[track.leg >= 0][-1] - track.t_s[track.leg >= 0][0])
    held = score_track(track, flight, site.with_limits(endurance_s=flying_s + 1.0), service)
    assert held.violations == []
    short = score_track(track, flight, site.with_limits(endurance_s=flying_s - 1.0), service)
    assert [f.message for f in short.violations] == [
        f"the mission flies {flying_s:.0f} s from take-off to landing, beyond the UAV's "
        f"endurance of {flying_s - 1.0:g} s (uav.endurance): fewer cycles or a shorter period"]


def test_no_endurance_no_check_and_wind_is_named_as_the_remedy():
    from validator.replay.score import endurance_finding

    assert endurance_finding(1e6, None) is None
    windy = endurance_finding(300.0, 250.0, windy=True)
    assert windy is not None and windy.severity == "violation"
    assert windy.message.endswith("fewer cycles or a calmer day")


def test_the_lag_is_judged_by_the_planners_slot_times_not_the_ideal_landing(capsys):
    """A plan that carries its slot times is timed by them through the service cycle; the
    transit and landing after it only by the commanded speeds with no acceleration, which
    the landing always lags (ArduCopter's descent, LAND_SPEED): the report's worst lag is
    the cycle's, and the text says which is which."""
    from pathlib import Path

    from validator.cli import validate_mission_main
    from validator.validation import validate_mission

    repo = Path(__file__).resolve().parents[2]
    plan = repo / "tests/golden/realistic-vehicle/mission.plan"
    site = repo / "samples/realistic.yaml"
    rep = validate_mission(plan, site, replay_flight=True).replay
    assert rep is not None
    lags = [w for w in rep.waypoint_lag if w["lag_s"] is not None]
    slots = [w["lag_s"] for w in lags if w["timed_by"] == "slots"]
    assert len(slots) > 5 and lags[-1]["timed_by"] == "commanded"
    assert lags[-1]["lag_s"] > 10.0 > rep.max_lag_s == max(slots)
    validate_mission_main([str(plan), "--site", str(site), "--replay"])
    out = capsys.readouterr().out
    assert f"lag behind the planner's slot times: max {max(slots):.1f} s" in out
    assert f"at the last waypoint {lags[-1]['lag_s']:.1f} s behind the commanded speeds" in out
