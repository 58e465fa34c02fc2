"""Re-timing an optimised path the way a multicopter flies it (dynamics="vehicle")."""

from __future__ import annotations

import numpy as np
import pytest

from mission_planner.optimize import PlannerOptions, Solution, plan
from mission_planner.optimize.retime import fit_holds, leg_profiles, skeleton, time_cycle
from mission_planner.study.sites import random_site
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
    assert np.all(flyable.leg_length_m <= site.max_speed_mps * flyable.delta_s * (1 + 1e-9))
    assert flyable.notes["dynamics"] == "vehicle"


def test_flyable_moves_take_as_long_as_the_s_curves(site: Site, flyable: Solution) -> None:
    idx = flyable.notes["waypoint_slots"]
    pts = flyable.trajectory_m[idx]
    lengths = np.linalg.norm(np.roll(pts, -1, axis=0) - pts, axis=1)
    move = float(leg_profiles(site, lengths[lengths > 1e-6]).total_s.sum())
    moving = flyable.leg_length_m > 1e-6
    assert float(flyable.delta_s[moving].sum()) == pytest.approx(move, rel=1e-6)


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
        if w["lag_s"] is not None and first <= w["item"] <= last
    ]
    assert len(in_cycle) >= 2
    assert max(abs(x) for x in in_cycle) < 1.5
    assert report.throughput is not None
    assert report.throughput.flown_min == pytest.approx(report.throughput.planned_min, rel=0.05)


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
