"""Re-timing an optimised path the way a multicopter flies it (dynamics="vehicle")."""

from __future__ import annotations

import numpy as np
import pytest

from mission_planner.optimize import PlannerOptions, Solution, plan
from mission_planner.optimize.corners import CycleMotion
from mission_planner.optimize.retime import (
    MIN_HOLD_S,
    Skeleton,
    cycle_motion,
    fit_holds,
    resample,
    skeleton,
    started_near,
    time_cycle,
)
from mission_planner.study.sites import random_site
from validator.geometry import min_leg_clearance
from validator.item_numbers import item_number
from validator.motion.arducopter import STOP_LAG_S
from validator.motion.speed_model import cruise_speed_mps, leg_profiles, top_speed_mps
from validator.site import Site


def _hover_dash() -> tuple[np.ndarray, np.ndarray]:
    """Hover 3 slots at A, dash to B in 2 collinear slots, hover 2 at B, dash back in 1."""
    a, b, mid = np.array([0.0, 0.0]), np.array([100.0, 0.0]), np.array([50.0, 0.0])
    traj = np.array([a, a, a, a, mid, b, b, b, a])
    delta = np.array([2.0, 2.0, 2.0, 1.5, 1.5, 3.0, 3.0, 5.0])
    return traj, delta


def test_skeleton_keeps_hover_points_and_drops_collinear_ones() -> None:
    traj, delta = _hover_dash()
    sk = skeleton(traj, delta, np.zeros((0, 2)), np.zeros(0))
    assert len(sk.points_m) == 2
    holds = {tuple(p): h for p, h in zip(sk.points_m.tolist(), sk.hold_s, strict=True)}
    assert holds[(0.0, 0.0)] == pytest.approx(6.0)
    assert holds[(100.0, 0.0)] == pytest.approx(6.0)


def test_skeleton_keeps_a_corner_that_would_cut_a_zone() -> None:
    # A detour round a zone: dropping its apex would send the leg through the zone.
    traj = np.array([[0.0, 0.0], [0.0, 0.0], [50.0, 40.0], [100.0, 0.0], [100.0, 0.0], [0.0, 0.0]])
    delta = np.array([5.0, 3.0, 3.0, 5.0, 4.0])
    centres, radii = np.array([[50.0, 5.0]]), np.array([10.0])
    sk = skeleton(traj, delta, centres, radii)
    assert any(np.allclose(p, [50.0, 40.0]) for p in sk.points_m)


def test_skeleton_straightens_wiggles_far_from_zones_and_keeps_a_zone_hugging_arc() -> None:
    """Judged chord by chord: a loop wrapping half of a circle and wiggling by a metre away
    from it keeps the arc's vertices (a chord would cut the circle) and loses the wiggles but
    the one the path needs to come back round the circle (a whole-loop judgement kept them
    all, each a corner the vehicle slows for)."""
    arc = [20.2 * np.array([np.cos(a), np.sin(a)]) for a in np.radians(np.arange(90, 271, 15))]
    top = [np.array([20.0 * k, 20.2 + k % 2]) for k in range(1, 10)]
    bottom = [np.array([20.0 * k, -20.2 - k % 2]) for k in range(9, 0, -1)]
    loop = [*arc, *bottom, np.array([200.0, -20.2]), np.array([200.0, 20.2]), *top[::-1]]
    traj = np.array([*loop, loop[0]])
    sk = skeleton(traj, np.ones(len(loop)), np.zeros((1, 2)), np.array([20.0]))
    kept = {tuple(np.round(p, 6)) for p in sk.points_m}
    assert all(tuple(np.round(p, 6)) in kept for p in arc)
    assert sum(tuple(np.round(p, 6)) in kept for p in top + bottom) <= 1
    assert min_leg_clearance(np.vstack([sk.points_m, sk.points_m[:1]]), np.zeros((1, 2)),
                             np.array([20.0])) >= 0.0


def test_a_cycle_starts_at_its_hover_point_nearest_home() -> None:
    square = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])
    sk = Skeleton(square, np.array([5.0, 0.0, 3.0, 0.0]))
    # home (100, 40) is nearest the corner (100, 0), which is flown through: the nearest
    # hover point is (100, 100), 60 m away (the start, (0, 0), is 108 m)
    moved = started_near(sk, np.array([100.0, 40.0]))
    assert moved.points_m.tolist() == [[100.0, 100.0], [0.0, 100.0], [0.0, 0.0], [100.0, 0.0]]
    assert moved.hold_s.tolist() == [3.0, 0.0, 5.0, 0.0]
    kept = started_near(sk, np.array([-10.0, -10.0]))
    assert np.array_equal(kept.points_m, square) and np.array_equal(kept.hold_s, sk.hold_s)


def test_a_cycle_without_a_hover_point_keeps_its_start() -> None:
    sk = Skeleton(np.array([[0.0, 0.0], [100.0, 0.0], [50.0, 80.0]]), np.zeros(3))
    assert started_near(sk, np.array([100.0, 0.0])) is sk


def test_fit_holds_fills_the_period_in_whole_seconds_but_one() -> None:
    holds = fit_holds(np.array([4.0, 2.0, 0.0]), move_s=20.0, period_s=32.5)
    assert holds is not None
    assert holds.sum() == pytest.approx(12.5)
    assert np.all(holds >= 1.0)
    assert np.count_nonzero(holds != np.round(holds)) <= 1
    # The spare 9.5 s beyond the 1 s minimum goes 2:1 to the two hover points.
    assert holds[0] > holds[1] > holds[2] == 1.0


def test_fit_holds_refuses_moves_that_leave_no_time_to_stop() -> None:
    assert fit_holds(np.array([1.0]), move_s=30.0, period_s=26.0) is None
    assert fit_holds(np.array([0.0, 0.0, 0.0]), move_s=24.0, period_s=26.0) is None


def test_resample_lays_slots_on_the_s_curves(site: Site) -> None:
    traj, delta = _hover_dash()
    sk = skeleton(traj, delta, np.zeros((0, 2)), np.zeros(0))
    move = float(leg_profiles(site, sk.leg_lengths_m).total_s.sum())
    move_s, out = time_cycle(site, sk, move + 10.0, 12)
    assert move_s == pytest.approx(move)
    assert out is not None
    q, d = out
    assert q.shape == (13, 2) and d.shape == (12,)
    assert d.sum() == pytest.approx(move + 10.0)
    assert np.allclose(q[0], q[-1])
    # Slot speeds never exceed the top speed, and every slot stays on the A-B line.
    speed = np.linalg.norm(np.diff(q, axis=0), axis=1) / d
    assert np.all(speed <= site.max_speed_mps + 1e-9)
    assert np.allclose(q[:, 1], 0.0)


def test_resample_lays_moving_slots_where_the_cycle_flew_the_leg(site: Site) -> None:
    """A leg entered through a corner first runs at the speed of the leg before, so the
    vehicle is not where the leg's own S-curve would put it: the slots follow the flight."""
    sk = Skeleton(np.array([[0.0, 0.0], [100.0, 0.0]]), np.array([4.0, 4.0]))
    profiles = leg_profiles(site, sk.leg_lengths_m)
    t = np.linspace(0.0, 20.0, 401)
    steady = (t, 5.0 * t)  # 100 m at 5 m/s, whatever the S-curve would do
    motion = CycleMotion(np.array([True, True]), np.zeros(2), np.array([20.0, 20.0]),
                         np.zeros(2), (steady, steady))
    out = resample(sk, np.array([4.0, 4.0]), profiles, 12, motion)
    assert out is not None
    q, d = out
    clock = np.r_[0.0, np.cumsum(d)]
    out_n = int(np.flatnonzero(q[:, 0] > 0)[0])  # the first slot of the outbound move
    back_n = int(np.flatnonzero(q[:, 0] >= 100.0)[0])  # its last
    first = np.arange(out_n, back_n + 1)
    assert len(first) >= 2
    began = clock[out_n - 1]
    assert q[first, 0] == pytest.approx(5.0 * (clock[first] - began), abs=1e-6)
    # read from the S-curve instead, the same slots sit elsewhere along the leg
    own = resample(sk, np.array([4.0, 4.0]), profiles, 12,
                   CycleMotion(motion.stops, motion.offset_s, motion.duration_s,
                               motion.arrival_lag_s))
    assert own is not None and not np.allclose(own[0][first, 0], q[first, 0], atol=1.0)


def test_legs_are_timed_no_faster_than_the_vehicle_flies(site: Site) -> None:
    top = top_speed_mps(site)
    assert top < site.max_speed_mps  # a 30 m/s site; the quad tops out near 10 m/s
    assert cruise_speed_mps(site) == top
    capped = float(leg_profiles(site, [2000.0]).total_s[0])
    at_top = float(leg_profiles(site.with_limits(max_speed_mps=top), [2000.0]).total_s[0])
    assert capped == pytest.approx(at_top)
    assert capped > 2000.0 / top  # it cruises at the top speed, plus its ramps
    assert float(leg_profiles(site, [2000.0], 30.0).total_s[0]) == pytest.approx(capped)


def _hovers(q: np.ndarray, d: np.ndarray) -> list[tuple[tuple[float, ...], float]]:
    """(position, duration) of each run of slots spent in place, in flying order."""
    out: list[tuple[tuple[float, ...], float]] = []
    prev_still = False
    for i in range(len(d)):
        still = bool(np.hypot(*(q[i + 1] - q[i])) < 1e-9)
        if still and prev_still:
            out[-1] = (out[-1][0], out[-1][1] + float(d[i]))
        elif still:
            out.append((tuple(q[i].tolist()), float(d[i])))
        prev_still = still
    return out


def test_every_stop_hovers_the_autopilots_stop_lag_before_its_whole_second_hold(
    site: Site,
) -> None:
    sk = skeleton(*_hover_dash(), np.zeros((0, 2)), np.zeros(0))
    move = float(leg_profiles(site, sk.leg_lengths_m).total_s.sum())
    _, out = time_cycle(site, sk, move + 20.0, 40)
    assert out is not None
    q, d = out
    assert d.sum() == pytest.approx(move + 20.0)
    hovers = _hovers(q, d)
    assert [p for p, _ in hovers] == [(0.0, 0.0), (100.0, 0.0), (0.0, 0.0)]
    at_b, back_at_a = hovers[1][1], hovers[2][1]
    # B's hover is the lag, then a whole-second hold; the cycle ends with A's lag and a second
    assert at_b - STOP_LAG_S == pytest.approx(round(at_b - STOP_LAG_S))
    assert at_b - STOP_LAG_S >= MIN_HOLD_S
    assert back_at_a == pytest.approx(MIN_HOLD_S + STOP_LAG_S)


@pytest.fixture(scope="module")
def site() -> Site:
    return random_site(2, slots=12)


@pytest.fixture(scope="module")
def flyable(site: Site) -> Solution:
    return plan(site, "proposed", options=PlannerOptions(dynamics="vehicle", max_iterations=10))


def test_flyable_plan_fills_the_period_and_respects_the_top_speed(
    site: Site, flyable: Solution
) -> None:
    assert flyable.delta_s.sum() == pytest.approx(site.period_s)
    # never faster than the vehicle really flies (a 30 m/s site, a quad topping out near 10)
    top = top_speed_mps(site)
    assert np.all(flyable.leg_length_m <= top * flyable.delta_s * (1 + 1e-9))
    assert flyable.timing is not None
    assert isinstance(flyable.timing.planning_speed_mps, float)
    assert flyable.timing.planning_speed_mps <= top


def test_flyable_moves_take_as_long_as_the_vehicle_flies_them(
    site: Site, flyable: Solution
) -> None:
    """The moving slots last exactly what the ArduCopter model takes to fly the waypoints,
    stopping where the plan hovers and passing through the other corners."""
    assert flyable.timing is not None
    idx = list(flyable.timing.waypoint_slots)
    pts = flyable.trajectory_m[idx]
    still = flyable.leg_length_m <= 1e-6
    hover = np.array([still[i % len(still)] for i in idx])  # a hover starts on arrival
    sk = Skeleton(pts, hover.astype(float))
    profiles = leg_profiles(site, sk.leg_lengths_m)
    motion = cycle_motion(site, sk, profiles)
    assert not motion.stops.all()  # it passes through some corners
    assert float(flyable.delta_s[~still].sum()) == pytest.approx(motion.move_s, rel=1e-6)


def test_pass_through_corners_can_be_turned_off(site: Site) -> None:
    """Without pass-through every corner stops, and the moves are the rest-to-rest S-curves."""
    sol = plan(site, "proposed", options=PlannerOptions(
        dynamics="vehicle", max_iterations=10, pass_through_corners=False))
    assert sol.timing is not None
    pts = sol.trajectory_m[list(sol.timing.waypoint_slots)]
    lengths = np.linalg.norm(np.roll(pts, -1, axis=0) - pts, axis=1)
    move = float(leg_profiles(site, lengths[lengths > 1e-6]).total_s.sum())
    moving = sol.leg_length_m > 1e-6
    assert float(sol.delta_s[moving].sum()) == pytest.approx(move, rel=1e-6)


def test_a_flyable_cycle_starts_near_home_at_no_cost_to_the_nodes(monkeypatch) -> None:
    """The transits out and back are the mission's only other flying: on the golden files'
    realistic1 site the cycle started where Algorithm 1's tour begins is 242 m from home, and
    72 m at the hover point nearest it; the nodes get the same (a closed cycle serves alike
    from any stop; the re-timing differs in a hold's rounding)."""
    from mission_planner.optimize import retime

    site = random_site(1, buffer_m=3.0, max_speed_mps=9.4, period_s=231.0, slots=64)
    options = PlannerOptions(dynamics="vehicle")
    near = plan(site, "proposed", options=options)
    monkeypatch.setattr(retime, "started_near", lambda sk, home: sk)
    first = plan(site, "proposed", options=options)
    gap = [float(np.linalg.norm(s.trajectory_m[0] - site.home_xy_m)) for s in (near, first)]
    assert gap[0] < gap[1] - 100.0, gap
    assert near.min_rate_bps_hz == pytest.approx(first.min_rate_bps_hz, rel=0.01)


def test_flyable_plan_keeps_clear_of_every_zone(flyable: Solution) -> None:
    assert flyable.nfz_clearance_min_m >= flyable.site.buffer_m - 1e-6


def test_flyable_plan_is_flown_on_time_by_the_arducopter_replay(flyable: Solution) -> None:
    """Exported and replayed as ArduCopter flies it, the cycle keeps T, every cycle waypoint
    is reached when the planner's slot times say, and the nodes get the planned min rate."""
    from mission_planner.flight_report import replay_mission
    from mission_planner.mission import build_mission

    mission = build_mission(flyable)
    report = replay_mission(mission).report
    assert report.cycle is not None
    assert report.cycle.ratio == pytest.approx(1.0, abs=0.05)
    first, last = mission.cycle_items
    in_cycle = [
        w["lag_s"]
        for w in report.waypoint_lag
        if w["lag_s"] is not None and item_number(first) <= w["item"] <= item_number(last)
    ]
    assert len(in_cycle) >= 2
    assert max(abs(x) for x in in_cycle) < 1.5
    assert report.throughput is not None
    # 12 slots in 50 s, most of them moving: the paper model rates a moving slot at its end
    # point, the flown track averages over it (24 slots: within 1 %)
    assert report.throughput.flown_min == pytest.approx(report.throughput.planned_min, rel=0.08)


def test_arducopter_holds_are_written_net_of_the_stop_lag(
    flyable: Solution, flyable_px4: Solution
) -> None:
    """The plan's hover at a stop begins with the autopilot's lag; the written holds leave it
    out, and the cycle as laid out (legs, holds, lags) still lasts T."""
    from mission_planner.mission import (
        MissionOptions,
        build_mission,
        cycle_duration_s,
        mission_summary,
    )

    mission = build_mission(flyable)
    stops = [s for s in mission.steps if s.stop_lag_s > 0]
    assert len(stops) >= 1 and all(s.stop_lag_s == STOP_LAG_S for s in stops)
    # the corners it flies through hold nothing and arrive without a lag
    passed = [s for s in mission.steps if s.leg_s > 0 and s.hold_s == 0]
    assert passed and all(s.stop_lag_s == 0 for s in passed)
    summary = mission_summary(mission)
    assert summary["waypoints_flown_through"] == len(passed)
    assert summary["stop_lag_s"] == pytest.approx(STOP_LAG_S * len(stops))
    assert summary["hold_written_s"] + summary["stop_lag_s"] == pytest.approx(
        summary["hold_planned_s"], abs=0.5)
    assert cycle_duration_s(mission) == pytest.approx(flyable.site.period_s, abs=0.5)
    # PX4 is not modelled with the lag: its holds are the plan's
    px4 = build_mission(flyable_px4, MissionOptions(autopilot="px4"))
    assert all(s.stop_lag_s == 0.0 for s in px4.steps)


def test_every_moving_slot_moves_visibly(site: Site) -> None:
    """An S-curve starts and ends slowly; its first and last slots must still move, or the
    exporter would read them as holds and split the leg."""
    sk = skeleton(*_hover_dash(), np.zeros((0, 2)), np.zeros(0))
    move = float(leg_profiles(site, sk.leg_lengths_m).total_s.sum())
    _, out = time_cycle(site, sk, move + 6.0, 60)
    assert out is not None
    q, d = out
    steps = np.linalg.norm(np.diff(q, axis=0), axis=1)
    assert np.all(d > 0)
    assert np.all((steps == 0.0) | (steps >= 0.1 - 1e-9))


@pytest.fixture(scope="module")
def flyable_px4(site: Site) -> Solution:
    return plan(site, "proposed", options=PlannerOptions(
        dynamics="vehicle", max_iterations=10, autopilot="px4",
        timing_params={"NAV_ACC_RAD": 0.05}))  # what a site without a buffer gets


def test_px4_plans_are_timed_with_px4s_own_rules(site: Site, flyable_px4: Solution) -> None:
    """Timed with PX4's braking rule (slower to a stop than ArduCopter's S-curve when the jerk
    is small), exported for PX4 and replayed as PX4 flies it, the cycle keeps T and the nodes
    get the planned min rate."""
    from mission_planner.autopilot_params import recommended_params
    from mission_planner.flight_report import replay_mission
    from mission_planner.mission import MissionOptions, build_mission

    assert flyable_px4.timing is not None and flyable_px4.timing.autopilot == "px4"
    assert leg_profiles(site, [50.0], autopilot="px4").total_s[0] > leg_profiles(
        site, [50.0]).total_s[0]
    mission = build_mission(flyable_px4, MissionOptions(autopilot="px4"))
    params = recommended_params(mission)
    assert params.values["NAV_ACC_RAD"] == 0.05
    report = replay_mission(mission, params).report
    assert report.cycle is not None and report.throughput is not None
    assert report.cycle.ratio == pytest.approx(1.0, abs=0.03)
    # 12 slots in 50 s, most of them moving: the paper model rates a moving slot at its end
    # point, the flown track averages over it (24 slots: within 1 %)
    assert report.throughput.flown_min == pytest.approx(report.throughput.planned_min, rel=0.08)


def test_px4_timelines_count_the_departure_crawl() -> None:
    """Off a right angle after a short hold PX4 crawls for seconds before it speeds up
    (:func:`validator.motion.px4.departure_lock_s`), less after a longer hold: a period whose
    holds are too short to let the crawls die down, and too short to fit them, does not fit,
    though the moves and the minimum holds alone would."""
    from pathlib import Path

    from mission_planner.optimize.retime import px4_departures_s
    from validator.motion.speed_model import motion_profile
    from validator.site import load_site

    site = load_site(Path(__file__).resolve().parents[2] / "samples" / "realistic.yaml")
    sk = Skeleton(np.array([[100.0, 100.0], [300.0, 100.0], [300.0, 300.0], [100.0, 300.0]]),
                  np.zeros(4))
    legs = leg_profiles(site, sk.leg_lengths_m, autopilot="px4")
    least = np.array([2.0, 1.0, 1.0, 1.0]) * MIN_HOLD_S  # fit_holds' minimum holds
    crawl = px4_departures_s(sk, legs, least, motion_profile(site, "px4"))
    assert np.all(crawl[1:] > 1.0)
    assert np.all(px4_departures_s(sk, legs, least + 6.0, motion_profile(site, "px4")) < crawl)
    # timed for the far end of SIH's arrivals: 3-s holds, on which the model's own arrival just
    # stops crawling, still leave a crawl (realistic.yaml flew one of 3-4 s after them)
    assert px4_departures_s(sk, legs, np.full(4, 3.0), motion_profile(site, "px4"))[1] > 2.0
    tight = float(legs.total_s.sum() + least.sum()) + 1.0
    assert fit_holds(sk.hold_s, float(legs.total_s.sum()), tight) is not None
    assert time_cycle(site, sk, tight, 40, autopilot="px4")[1] is None
    # given the time, holds of about 6 s let the trajectory creep in too slowly to crawl
    move_s, timed = time_cycle(site, sk, tight + 20.0, 40, autopilot="px4")
    assert timed is not None and timed[1].sum() == pytest.approx(tight + 20.0)
    assert move_s == pytest.approx(float(legs.total_s.sum()))


def test_a_plan_timed_for_one_autopilot_is_not_built_for_the_other(
    flyable: Solution, flyable_px4: Solution
) -> None:
    """The timing record and the mission options must name the same autopilot: a cycle timed
    by ArduCopter's S-curves would be late on PX4 (and the reverse)."""
    from mission_planner.mission import MissionOptions, build_mission
    from validator.errors import InputError

    with pytest.raises(InputError, match="timed for 'ardupilot'.*built for 'px4'"):
        build_mission(flyable, MissionOptions(autopilot="px4"))
    with pytest.raises(InputError, match="timed for 'px4'.*built for 'ardupilot'"):
        build_mission(flyable_px4, MissionOptions(autopilot="ardupilot"))
