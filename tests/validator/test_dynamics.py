"""Hand-computed cases for the multicopter profiles."""

import math

import numpy as np
import pytest

from tests.validator.builders import make_site, nav, plan_of, speed
from validator.errors import InputError
from validator.flight import resolve_flight
from validator.motion.arducopter import (
    LAND_DETECT_S,
    LIFTOFF_DELAY_S,
    STOP_LAG_S,
    corner_overlaps_s,
)
from validator.motion.fly import fly
from validator.motion.limits import air_density_ratio, site_limits, top_speed_mps
from validator.motion.path import LegGeometry
from validator.motion.profile import make_profile, parse_param_overrides
from validator.motion.scurve import (
    SEG_CRUISE,
    change_reach_mps,
    scurve_peak_speed,
    scurve_rest_to_rest,
)
from validator.plan_format import Cmd


def one(x: float) -> np.ndarray:
    return np.array([x], dtype=float)


def sampled(prof, n=20001):
    t = np.linspace(0.0, float(prof.total_s[0]), n)
    p, v, a = prof.state(np.zeros(n, dtype=np.int64), t)
    return t, p, v, a


def test_long_move_lasts_L_over_V_plus_V_over_A_plus_A_over_J():
    # 100 m at V = 10, A = 2.5, J = 1: 10 + 4 + 2.5 = 16.5 s
    prof = scurve_rest_to_rest(one(100.0), one(10.0), one(2.5), one(1.0))
    assert prof.total_s[0] == pytest.approx(16.5, abs=1e-9)
    t, p, v, a = sampled(prof)
    assert p[-1] == pytest.approx(100.0, abs=1e-9)
    assert v.max() == pytest.approx(10.0, abs=1e-6)
    assert np.abs(a).max() == pytest.approx(2.5, abs=1e-3)
    jerk = np.diff(a) / np.diff(t)
    assert np.abs(jerk).max() <= 1.0 + 1e-6


def test_jerk_ramps_add_their_duration_once():
    # snap-limited jerk changes (ramp 0.3 s) lengthen the long move by exactly 0.3 s
    prof = scurve_rest_to_rest(one(100.0), one(10.0), one(2.5), one(1.0), 0.3)
    assert prof.total_s[0] == pytest.approx(16.8, abs=1e-9)
    t, p, v, _ = sampled(prof)
    assert p[-1] == pytest.approx(100.0, abs=1e-9)
    assert v.max() == pytest.approx(10.0, abs=1e-6)


def test_short_leg_never_reaches_its_speed():
    # 26 m with J = 1 (A = 2.5 is never reached): peak (L·sqrt(J)/2)^(2/3) = 13^(2/3) m/s,
    # duration 4·sqrt(v/J)
    v = 13.0 ** (2.0 / 3.0)
    assert scurve_peak_speed(26.0, 30.0, 2.5, 1.0)[0] == pytest.approx(v, rel=1e-9)
    prof = scurve_rest_to_rest(one(26.0), one(30.0), one(2.5), one(1.0))
    assert prof.total_s[0] == pytest.approx(4.0 * math.sqrt(v), rel=1e-9)


def test_distance_needed_to_reach_v_is_v2_over_A_plus_vA_over_J():
    # the notes' rule: ~65 m to reach 10 m/s at A = 2.5, J = 1 (40 + 25)
    assert scurve_peak_speed(65.0, 10.0, 2.5, 1.0)[0] == pytest.approx(10.0, rel=1e-9)
    assert scurve_peak_speed(64.0, 10.0, 2.5, 1.0)[0] < 10.0
    assert scurve_peak_speed(30.0, 10.0, 5.0, 5.0)[0] == pytest.approx(10.0, rel=1e-9)


def test_a_leg_too_short_for_its_speed_peaks_with_no_cruise_left():
    # The peak speed is the largest whose rest-to-rest distance fits the leg: any lower and
    # the profile would cruise, any higher and it would overrun (jerk ramps or not).
    rng = np.random.default_rng(5)
    n = 200
    L, V = rng.uniform(0.5, 300.0, n), rng.uniform(1.0, 20.0, n)
    A, J, tj = rng.uniform(0.5, 5.0, n), rng.uniform(0.5, 10.0, n), rng.uniform(0.0, 0.5, n)
    peak = scurve_peak_speed(L, V, A, J, tj)
    short = peak < V
    assert 0 < np.count_nonzero(short) < n  # both kinds of leg are in the sample
    cruise_s = scurve_rest_to_rest(L, V, A, J, tj).dur_s[:, SEG_CRUISE]
    assert np.all(cruise_s[short] < 1e-6)
    assert np.all(cruise_s[~short] > 0.0)


def test_a_speed_change_with_room_reaches_its_target():
    # 3 -> 5 m/s at J = 1 without ramps: 2·sqrt(2) s at a mean 4 m/s, 11.3 m; down likewise
    reach = change_reach_mps(np.array([3.0, 5.0]), np.array([5.0, 3.0]), np.full(2, 11.4),
                             np.full(2, 2.5), np.ones(2), np.zeros(2))
    assert reach == pytest.approx([5.0, 3.0])


def test_a_speed_change_without_room_goes_as_far_as_its_length_from_the_lower_speed():
    # 5.66 m from 3 m/s: a gain g with (3 + g/2)·2·sqrt(g) = 5.66 is g = 0.5 (3.25 x 1.41 x 2 / 2)
    length = (3.0 + 0.25) * 2.0 * math.sqrt(0.5)
    reach = change_reach_mps(np.array([3.0, 5.0]), np.array([5.0, 3.0]), np.full(2, length),
                             np.full(2, 2.5), np.ones(2), np.zeros(2))
    assert reach == pytest.approx([3.5, 4.5], abs=1e-6)


def test_a_speed_change_given_no_room_stays_at_its_speed():
    reach = change_reach_mps(np.array([3.0]), np.array([10.0]), np.array([0.0]),
                             np.array([2.5]), np.array([1.0]), np.array([0.3]))
    assert reach == pytest.approx([3.0])


def test_corner_overlap_keeps_the_blend_inside_the_waypoint_radius():
    # 90° corner between two long legs, R = 2 m, J = 1, A = 2.5, no jerk ramps. The blended
    # target at mid-overlap sits at sqrt(2)·D(τ/2) from the corner with D(t) = J t³/6, so the
    # next leg starts with τ = 2·(6·R/(sqrt(2)·J))^(1/3) s left on this one.
    geom = LegGeometry(np.array([[0.0, 0, 0], [100.0, 0, 0]]),
                       np.array([[100.0, 0, 0], [0.0, 100, 0]]))
    prof = scurve_rest_to_rest(geom.length_m, np.full(2, 10.0), np.full(2, 2.5), np.ones(2))
    tau = corner_overlaps_s(geom, prof, np.array([0]), np.full(2, 10.0), 2.0, 5.0)[0]
    expected = 2.0 * (6.0 * 2.0 / (math.sqrt(2.0) * 1.0)) ** (1.0 / 3.0)
    assert tau == pytest.approx(expected, abs=0.005)


def corner_mission(site, radius_cm: float):
    items = [nav(site, Cmd.NAV_TAKEOFF, (0, 0)), speed(10.0),
             nav(site, Cmd.NAV_WAYPOINT, (0, 0)), nav(site, Cmd.NAV_WAYPOINT, (100, 0)),
             nav(site, Cmd.NAV_WAYPOINT, (100, 100))]
    flight = resolve_flight(plan_of(site, items, fence=False), site)
    prof = make_profile("arducopter", site_limits(site), {"WPNAV_RADIUS": radius_cm,
                        "WPNAV_SPEED": 1000})
    return fly(flight, prof, dt_s=0.01)


@pytest.fixture(scope="module")
def open_site():
    return make_site(nfz=(), max_speed=10.0)


@pytest.mark.parametrize("radius_cm", [200.0, 50.0])
def test_arducopter_cuts_the_corner_inside_the_turn_within_wpnav_radius(open_site, radius_cm):
    path = corner_mission(open_site, radius_cm)
    xy = path.xyz_m[:, :2]
    d = np.hypot(xy[:, 0] - 100.0, xy[:, 1])
    closest = int(np.argmin(d))
    r = radius_cm / 100.0
    assert d[closest] == pytest.approx(r, abs=0.03)  # the blend starts as soon as it may
    # inside the turn: west of the second leg and north of the first
    assert xy[closest, 0] < 100.0 and xy[closest, 1] > 0.0
    # it does not stop at the corner
    speed_at = np.hypot(*path.vel_mps[closest, :2])
    assert speed_at > 1.0


def test_arducopter_speed_never_exceeds_its_limits(open_site):
    path = corner_mission(open_site, 200.0)
    v = np.hypot(path.vel_mps[:, 0], path.vel_mps[:, 1])
    assert v.max() <= 10.0 + 1e-6
    acc = np.diff(path.vel_mps[:, :2], axis=0) / 0.01
    # legs add up in the corner: ArduCopter bounds that by the corner acceleration 2·WPNAV_ACCEL
    assert np.hypot(acc[:, 0], acc[:, 1]).max() <= 5.0 + 0.05


def test_arducopter_speed_change_follows_wpnav_accel_and_jerk(open_site):
    # from rest to 10 m/s along a 200 m leg: S-curve with A = 2.5 (WPNAV_ACCEL 250) and
    # J = 1, jerk ramps of 2·ATC_INPUT_TC = 0.3 s: 200/10 + 10/2.5 + 2.5/1 + 0.3 = 26.8 s, and the
    # autopilot counts the stop STOP_LAG_S later
    items = [nav(open_site, Cmd.NAV_TAKEOFF, (0, 0)), speed(10.0),
             nav(open_site, Cmd.NAV_WAYPOINT, (0, 0), p1=1.0),
             nav(open_site, Cmd.NAV_WAYPOINT, (200, 0), p1=1.0)]
    flight = resolve_flight(plan_of(open_site, items, fence=False), open_site)
    path = fly(flight, make_profile("arducopter", site_limits(open_site)), dt_s=0.01)
    leg = 2
    assert path.reached_s[leg] - path.start_s[leg] == pytest.approx(26.8 + STOP_LAG_S, abs=1e-6)
    moving = (path.t_s >= path.start_s[leg]) & (path.t_s <= path.reached_s[leg])
    v = np.hypot(path.vel_mps[moving, 0], path.vel_mps[moving, 1])
    a = np.diff(v) / 0.01
    assert v.max() == pytest.approx(10.0, abs=1e-3)
    assert np.abs(a).max() <= 2.5 + 1e-3
    assert np.abs(np.diff(a) / 0.01).max() <= 1.0 + 0.01


def test_ideal_profile_flies_the_commanded_speed_exactly(open_site):
    items = [nav(open_site, Cmd.NAV_TAKEOFF, (0, 0)), speed(4.0),
             nav(open_site, Cmd.NAV_WAYPOINT, (0, 0)), nav(open_site, Cmd.NAV_WAYPOINT, (40, 30)),
             speed(5.0), nav(open_site, Cmd.NAV_WAYPOINT, (40, 80), p1=2.0)]
    flight = resolve_flight(plan_of(open_site, items, fence=False), open_site)
    path = fly(flight, make_profile("ideal", site_limits(open_site)))
    assert path.reached_s[2] - path.start_s[2] == pytest.approx(50.0 / 4.0)
    assert path.done_s[3] - path.start_s[3] == pytest.approx(50.0 / 5.0 + 2.0)


def test_px4_rounds_corners_inside_nav_acc_rad(open_site):
    items = [nav(open_site, Cmd.NAV_TAKEOFF, (0, 0)), speed(8.0),
             nav(open_site, Cmd.NAV_WAYPOINT, (0, 0)), nav(open_site, Cmd.NAV_WAYPOINT, (100, 0)),
             nav(open_site, Cmd.NAV_WAYPOINT, (100, 100))]
    flight = resolve_flight(plan_of(open_site, items, fence=False), open_site)
    prof = make_profile("px4", site_limits(open_site), {"NAV_ACC_RAD": 5.0, "MPC_ACC_HOR": 3.0,
                                           "MPC_JERK_AUTO": 4.0})
    path = fly(flight, prof, dt_s=0.01)
    xy = path.xyz_m[:, :2]
    d = np.hypot(xy[:, 0] - 100.0, xy[:, 1])
    k = int(np.argmin(d))
    # arc tangent 5 m before and after the corner: radius 5 m, apex 5·(sqrt(2) − 1) m away
    assert d[k] == pytest.approx(5.0 * (math.sqrt(2.0) - 1.0), abs=0.05)
    # PX4's corner speed sqrt(MPC_XY_TRAJ_P·A·NAV_ACC_RAD·tan(45°)) = sqrt(7.5) for the
    # trajectory; the vehicle, lagging it, is a little faster at the apex
    corner = math.sqrt(0.5 * 3.0 * 5.0)
    assert corner <= np.hypot(*path.vel_mps[k, :2]) <= 1.25 * corner


def test_unknown_parameter_is_bad_input(open_site):
    with pytest.raises(InputError, match="--param WPNAV_SPED"):
        make_profile("arducopter", site_limits(open_site), {"WPNAV_SPED": 500})
    with pytest.raises(InputError, match="--param NAV_ACC_RAD: must be a number > 0"):
        make_profile("px4", site_limits(open_site), {"NAV_ACC_RAD": -1})


def test_param_overrides_parse_name_value_pairs():
    assert parse_param_overrides(["wpnav_accel=500", "WPNAV_JERK=5"]) == {
        "WPNAV_ACCEL": 500.0, "WPNAV_JERK": 5.0}
    with pytest.raises(InputError, match="--param WPNAV_JERK: 'fast' is not a number"):
        parse_param_overrides(["WPNAV_JERK=fast"])


def test_defaults_come_from_the_site_limits():
    site = make_site(nfz=(), max_accel=4.0, max_jerk=3.0)
    prof = make_profile("arducopter", site_limits(site))
    assert prof.si("WPNAV_ACCEL") == 4.0 and prof.si("WPNAV_JERK") == 3.0
    assert make_profile("px4", site_limits(site)).si("MPC_JERK_AUTO") == 3.0


def _px4_straight(open_site, **params):
    items = [nav(open_site, Cmd.NAV_TAKEOFF, (0, 0)), speed(10.0),
             nav(open_site, Cmd.NAV_WAYPOINT, (0, 0), p1=1.0),
             nav(open_site, Cmd.NAV_WAYPOINT, (100, 0), p1=20.0)]
    flight = resolve_flight(plan_of(open_site, items, fence=False), open_site)
    path = fly(flight, make_profile("px4", site_limits(open_site), params), dt_s=0.01)
    return path, path.reached_s[2] - path.start_s[2]


def test_px4_brakes_more_cautiously_than_an_s_curve(open_site):
    # rest to rest over 100 m at 10 m/s, A = 2.5, J = 1: a jerk-limited S-curve takes
    # 100/10 + 10/2.5 + 2.5/1 = 16.5 s; PX4 plans its braking with a 2A/J reaction delay and
    # counts the waypoint only within NAV_ACC_RAD, so it takes longer
    path, took = _px4_straight(open_site, MPC_ACC_HOR=2.5, MPC_JERK_AUTO=1.0)
    assert took > 16.5 * 1.2
    # ... and a larger jerk shortens that delay
    _, quicker = _px4_straight(open_site, MPC_ACC_HOR=2.5, MPC_JERK_AUTO=4.0)
    assert quicker < took - 3.0
    # the hold starts within NAV_ACC_RAD (2 m); the vehicle closes in on the waypoint during it
    at = np.searchsorted(path.t_s, path.reached_s[2])
    assert 1.5 < 100.0 - path.xyz_m[at, 0] <= 2.0
    assert path.xyz_m[-1, 0] == pytest.approx(100.0, abs=0.05)


def test_top_speed_is_where_drag_uses_up_the_lean_limit():
    # g·tan θ = k·σ·v²: 30° and k = 0.0561 1/m at sea level give sqrt(5.662 / 0.0561) m/s
    v = math.sqrt(9.80665 * math.tan(math.radians(30.0)) / 0.0561)
    assert top_speed_mps(30.0, 0.0561) == pytest.approx(v, rel=1e-12)
    assert v == pytest.approx(10.05, abs=0.01)
    # thinner air, less drag: faster by 1/sqrt(σ); steeper lean, faster
    sigma = air_density_ratio(584.0)
    assert sigma == pytest.approx(0.9448, abs=1e-3)
    assert top_speed_mps(30.0, 0.0561, sigma) == pytest.approx(v / math.sqrt(sigma), rel=1e-12)
    assert top_speed_mps(45.0, 0.0561) > v
    assert top_speed_mps(30.0, 0.0) == math.inf
    with pytest.raises(InputError, match="lean angle limit"):
        top_speed_mps(90.0)


def test_arducopter_flies_no_faster_than_its_lean_limit_allows(open_site):
    # WPNAV_SPEED 30 m/s on a 500 m leg: the SITL quad still tops out at its 30° lean
    items = [nav(open_site, Cmd.NAV_TAKEOFF, (0, 0)), nav(open_site, Cmd.NAV_WAYPOINT, (0, 0)),
             nav(open_site, Cmd.NAV_WAYPOINT, (500, 0), p1=1.0)]
    flight = resolve_flight(plan_of(open_site, items, fence=False), open_site)
    fast = {"WPNAV_SPEED": 3000, "VEHICLE_SPEED_MAX": 30, "ALT_AMSL": 0}
    path = fly(flight, make_profile("arducopter", site_limits(open_site), fast), dt_s=0.02)
    top = top_speed_mps(30.0)
    assert np.hypot(path.vel_mps[:, 0], path.vel_mps[:, 1]).max() == pytest.approx(top, rel=1e-6)
    # PSC_ANGLE_MAX, when set, is the limit instead of ANGLE_MAX
    path = fly(flight,
               make_profile("arducopter", site_limits(open_site), {**fast, "PSC_ANGLE_MAX": 20}),
               dt_s=0.02)
    assert np.hypot(path.vel_mps[:, 0], path.vel_mps[:, 1]).max() == pytest.approx(
        top_speed_mps(20.0), rel=1e-6)


def test_takeoff_waits_for_liftoff_and_landing_slows_below_land_alt_low(open_site):
    # climb 30 m: lift-off delay, then a rest-to-rest S-curve at 2.5 m/s, 1 m/s², 5 m/s³ with
    # jerk ramps of 0.3 s, which bound the jerk to 1/0.3: a speed change by dv takes dv/1 + 0.6 s
    # over its mean speed times that, so the climb lasts 30/2.5 + 2.5 + 0.6 = 15.1 s. Land from
    # 30 m: 1.5 m/s down to 10 m, then 0.5 m/s: the start takes 2.1 s over 1.575 m, the slow-down
    # 1.6 s over 1.6 m, leaving 16.825 m at 1.5 m/s and 10 m at 0.5 m/s; then the land detector
    items = [nav(open_site, Cmd.NAV_TAKEOFF, (0, 0)), nav(open_site, Cmd.NAV_LAND, (0, 0), alt=0)]
    flight = resolve_flight(plan_of(open_site, items, fence=False), open_site)
    path = fly(flight, make_profile("arducopter", site_limits(open_site)), dt_s=0.01)
    kinds = [leg.kind for leg in flight.legs]
    assert kinds == ["takeoff", "land"]
    assert path.start_s[0] == pytest.approx(LIFTOFF_DELAY_S)
    assert path.reached_s[0] - path.start_s[0] == pytest.approx(15.1, abs=1e-6)
    descent = 2.1 + 16.825 / 1.5 + 1.6 + 20.0
    assert path.reached_s[1] - path.start_s[1] == pytest.approx(descent, abs=1e-6)
    assert path.done_s[1] - path.reached_s[1] == pytest.approx(LAND_DETECT_S)
    below = (path.t_s > path.start_s[1] + 14.95) & (path.t_s < path.reached_s[1] - 0.05)
    assert np.abs(path.vel_mps[below, 2]).max() == pytest.approx(0.5, abs=1e-3)
    assert path.xyz_m[below, 2].max() == pytest.approx(10.0, abs=0.03)


def test_a_zero_length_leg_takes_no_time(open_site):
    # a hold on the point just reached: ArduCopter reaches it at once (no jerk ramps to run)
    items = [nav(open_site, Cmd.NAV_TAKEOFF, (0, 0)), nav(open_site, Cmd.NAV_WAYPOINT, (0, 0)),
             nav(open_site, Cmd.NAV_WAYPOINT, (50, 0), p1=1.0),
             nav(open_site, Cmd.NAV_WAYPOINT, (50, 0), p1=3.0)]
    flight = resolve_flight(plan_of(open_site, items, fence=False), open_site)
    path = fly(flight, make_profile("arducopter", site_limits(open_site)))
    assert path.reached_s[3] == pytest.approx(path.start_s[3], abs=1e-9)


def test_the_waypoint_before_a_land_is_a_stop(open_site):
    # ArduCopter queues only waypoints as the next destination: no blend into NAV_LAND's approach
    items = [nav(open_site, Cmd.NAV_TAKEOFF, (0, 0)), nav(open_site, Cmd.NAV_WAYPOINT, (0, 0)),
             nav(open_site, Cmd.NAV_WAYPOINT, (60, 0)), nav(open_site, Cmd.NAV_WAYPOINT, (60, 60)),
             nav(open_site, Cmd.NAV_LAND, (0, 0), alt=0)]
    flight = resolve_flight(plan_of(open_site, items, fence=False), open_site)
    assert [leg.pass_through for leg in flight.legs] == [False, True, True, False, False, False]


def test_a_corner_lag_is_free_up_to_its_turn_and_grows_with_turn_and_speed():
    from validator.motion.arducopter import CORNER_LAG_FREE_DEG, corner_lag_s

    lag = corner_lag_s([30.0, CORNER_LAG_FREE_DEG, 120.0, 170.0, 170.0], [10, 10, 10, 10, 6])
    assert lag[0] == lag[1] == 0.0
    assert 0.0 < lag[2] < lag[3] and lag[4] < lag[3]
    assert lag[3] == pytest.approx(1.05, abs=0.1)  # measured: 1.05 s at 165-178° and 10 m/s


def _turn_mission(site, turn_deg: float):
    """100 m east, then 100 m on at ``turn_deg`` to the left, through the corner."""
    h = np.radians(turn_deg)
    items = [nav(site, Cmd.NAV_TAKEOFF, (0, 0)), speed(10.0),
             nav(site, Cmd.NAV_WAYPOINT, (0, 0)), nav(site, Cmd.NAV_WAYPOINT, (100, 0)),
             nav(site, Cmd.NAV_WAYPOINT, (100 + 100 * np.cos(h), 100 * np.sin(h)))]
    flight = resolve_flight(plan_of(site, items, fence=False), site)
    prof = make_profile("arducopter", site_limits(site), {"WPNAV_SPEED": 1000})
    return fly(flight, prof, dt_s=0.01)


def test_a_sharp_corner_takes_its_lag_longer_on_the_same_path(open_site, monkeypatch):
    # measured on ArduCopter 4.5.6 SITL: 0.85 s more than the blend at 150° and 10 m/s
    from validator.motion import arducopter

    sharp = _turn_mission(open_site, 150.0)
    monkeypatch.setattr(arducopter, "CORNER_LAG_S_PER_MPS_DEG", 0.0)
    blended = _turn_mission(open_site, 150.0)  # the two S-curves' blend alone
    extra = (sharp.done_s[-1] - sharp.start_s[2]) - (blended.done_s[-1] - blended.start_s[2])
    assert extra == pytest.approx(0.00108 * 10.0 * (150.0 - 72.0), abs=0.05)
    assert np.allclose(blended.done_s[:2], sharp.done_s[:2])  # nothing before the corner
    # the blend keeps its shape: the closest pass to the corner is still WPNAV_RADIUS
    d = np.hypot(sharp.xyz_m[:, 0] - 100.0, sharp.xyz_m[:, 1])
    assert float(d.min()) == pytest.approx(2.0, abs=0.05)
    # and the clock slows smoothly: no jump in speed
    v = np.hypot(sharp.vel_mps[:, 0], sharp.vel_mps[:, 1])
    assert float(np.max(np.abs(np.diff(v)))) < 0.2  # per 10 ms sample
