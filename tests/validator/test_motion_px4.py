"""PX4's motion rules (validator.motion.px4), one behaviour per test."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from validator.motion import px4


@settings(max_examples=60, deadline=None)
@given(d=st.floats(0.0, 500.0), vf=st.floats(0.0, 15.0), a=st.floats(0.5, 8.0),
       j=st.floats(0.5, 20.0))
def test_max_speed_solves_pxs_braking_equation(d, vf, a, j):
    v = px4.max_speed_from_distance(d, vf, a, j)
    assert v >= vf
    # v² = v_f² + 2A·(d − v·2A/J) wherever it is above the final speed
    if v > vf + 1e-9:
        assert v * v == pytest.approx(vf * vf + 2 * a * (d - v * 2 * a / j), rel=1e-9, abs=1e-9)


def test_max_speed_grows_with_distance_and_jerk():
    near = px4.max_speed_from_distance(5.0, 0.0, 2.5, 1.0)
    far = px4.max_speed_from_distance(50.0, 0.0, 2.5, 1.0)
    jerkier = px4.max_speed_from_distance(5.0, 0.0, 2.5, 4.0)
    assert near < far and near < jerkier
    # close in, the crawl is about d·J/(2A)
    assert px4.max_speed_from_distance(0.5, 0.0, 2.5, 1.0) == pytest.approx(0.5 / 5.0, rel=0.01)


def test_corner_speed_of_a_right_angle():
    # α = 90°: sqrt(P·A·r·tan 45°)
    assert px4.corner_speed_mps(math.pi / 2, 3.0, 5.0, 0.5) == pytest.approx(math.sqrt(7.5))
    assert px4.corner_speed_mps(0.0, 3.0, 5.0) == math.inf
    assert px4.corner_speed_mps(2.5, 3.0, 5.0) < px4.corner_speed_mps(1.0, 3.0, 5.0)


def _drive(target_mps, accel, jerk, seconds, dt=0.01):
    vs = px4.VelocitySmoothing(accel, jerk)
    out = []
    for _ in range(int(round(seconds / dt))):
        vs.update_durations(target_mps)
        vs.step(dt)
        out.append((vs.x, vs.v, vs.a))
    return np.array(out)


def test_velocity_smoothing_reaches_the_target_in_minimum_time():
    # from rest to 5 m/s with A = 2, J = 1: jerk up 2 s, constant 0.5 s, jerk down 2 s
    run = _drive(5.0, 2.0, 1.0, 8.0)
    v, a = run[:, 1], run[:, 2]
    assert v[int(4.5 / 0.01) - 1] == pytest.approx(5.0, abs=0.02)
    assert v[int(4.3 / 0.01)] < 4.99
    assert np.max(np.abs(a)) <= 2.0 + 1e-9
    assert np.max(np.abs(np.diff(a))) / 0.01 <= 1.0 + 1e-6
    assert v[-1] == pytest.approx(5.0, abs=1e-6)


def test_a_run_counts_its_waypoint_reached_at_the_acceptance_radius():
    run = px4.fly_run([60.0], [0.0], [8.0], 2.5, 2.0, 1.5, 3.0)
    at = int(np.searchsorted(run.t_s, run.reached_s[0]))
    assert 60.0 - run.s_m[at] <= 1.5 < 60.0 - run.s_m[at - 1]
    # the item completes when the hold is over (or earlier, once at rest on the waypoint)
    assert run.end_s == pytest.approx(run.reached_s[0] + 3.0, abs=0.03)


def test_a_run_passes_its_inner_waypoints_in_order():
    run = px4.fly_run([40.0, 80.0, 120.0], [5.0, 5.0, 0.0], [8.0, 8.0, 8.0], 2.5, 2.0, 2.0,
                      0.0)
    r = run.reached_s
    assert r[0] < r[1] < r[2]
    # through the inner waypoints without stopping
    v = np.gradient(run.s_m, run.t_s)
    at = np.searchsorted(run.t_s, r[:2])
    assert np.all(v[at] > 3.0)


def test_a_landing_follows_its_speed_schedule():
    schedule = (np.array([0.0, 5.0, 10.0, 40.0]), np.array([0.7, 0.7, 1.5, 1.5]))
    run = px4.fly_run([30.0], [0.0], [1.5], 3.0, 1.0, 0.0, 0.0, speed_profile=schedule)
    v = np.gradient(run.s_m, run.t_s)
    low = run.s_m > 27.0  # the last 3 m: at MPC_LAND_SPEED
    assert np.all(v[low][:-5] <= 0.7 + 0.05)
    assert np.max(v) == pytest.approx(1.5, abs=0.05)
    assert run.s_m[-1] == pytest.approx(30.0, abs=0.01)


def test_tracking_caps_the_speed_where_drag_uses_up_the_tilt():
    # linear drag 1/s at 45°: 9.81 m/s at most, whatever the cruise speed
    track = px4.Tracking(drag_per_s=1.0, tilt_max_deg=45.0)
    run = px4.fly_run([400.0], [0.0], [15.0], 5.0, 4.0, 1.0, 0.0, tracking=track)
    v = np.gradient(run.s_m, run.t_s)
    assert np.max(v) == pytest.approx(9.81, abs=0.1)


def test_rest_to_rest_legs_end_on_their_waypoints():
    legs = px4.rest_to_rest(np.array([0.0, 20.0, 80.0]), 8.0, 2.5, 1.0, 1.5, px4.Tracking())
    assert legs.total_s[0] == 0.0 and legs.total_s[1] < legs.total_s[2]
    pos, _, _ = legs.state(np.array([1, 2]), legs.total_s[1:])
    assert pos == pytest.approx([20.0, 80.0])
    grid = np.linspace(0.0, legs.total_s[2], 200)
    along, _, _ = legs.state(np.full(grid.size, 2), grid)
    assert np.all(np.diff(along) >= -1e-9)


def test_a_departure_crawl_matches_the_sih_flight():
    # realistic.yaml, waypoint 9 of tests/data/px4-sih/realistic-shifts-nolock: the trajectory
    # left 1.55 m short at 0.31 m/s onto a leg turning 77°, and crawled for 6.8 s
    assert px4.departure_lock_s(1.55, 0.31, math.radians(77.0), 1.5) == pytest.approx(6.8,
                                                                                      abs=0.3)


def test_no_crawl_below_pxs_turning_speed():
    assert px4.departure_lock_s(1.55, 0.19, math.radians(77.0), 1.5) == 0.0


@pytest.mark.parametrize("turn_deg", [0.0, 20.0, 170.0, 180.0])
def test_no_crawl_when_the_trajectory_starts_close_to_the_new_line(turn_deg):
    # 1.55·|sin turn| within L1·sin(acos 0.98) = 0.995 m of the line: aligned at once
    assert px4.departure_lock_s(1.55, 0.31, math.radians(turn_deg), 1.5) == 0.0


def test_the_crawl_is_longest_off_a_right_angle_and_slower_when_slower():
    right = px4.departure_lock_s(1.5, 0.3, math.pi / 2, 1.5)
    assert right > px4.departure_lock_s(1.5, 0.3, math.radians(60.0), 1.5) > 0.0
    assert px4.departure_lock_s(1.5, 0.25, math.pi / 2, 1.5) > right


def test_a_wider_acceptance_radius_aims_further_ahead():
    # L1 = max(NAV_ACC_RAD, 5 m): at 8 m the crossing point is further, the angle smaller
    assert px4.departure_lock_s(1.55, 0.31, math.pi / 2, 8.0) == 0.0


def test_a_hold_lets_the_trajectory_creep_in_until_it_is_too_slow_to_crawl():
    togo, speed = px4.creep_on(1.55, 0.31, 0.0, 1.0, 2.5, 1.0)
    assert togo < 1.55 and speed < 0.31
    # close in, the braking law is an exponential approach with time constant 2A/J = 5 s
    assert togo == pytest.approx(1.55 * math.exp(-1.0 / 5.0), rel=0.05)
    _, later = px4.creep_on(1.55, 0.31, 0.0, 10.0, 2.5, 1.0)
    assert later <= px4.TURNING_MIN_MPS
