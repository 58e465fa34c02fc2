"""Pass-through corners: the vehicle flies through a corner unless its turn would cut a zone."""

from __future__ import annotations

import numpy as np
import pytest

from mission_planner.optimize.corners import PX4_MAX_TURN_DEG, blended_motion, px4_motion
from mission_planner.optimize.retime import Skeleton
from mission_planner.study.sites import random_site
from validator.motion.arducopter import STOP_LAG_S, scurve_limits
from validator.motion.px4_mission import px4_top_speed_mps
from validator.motion.speed_model import leg_profiles, motion_profile
from validator.site import Site
from validator.zones import PolygonZone, polygon_zone

SQUARE = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])


@pytest.fixture(scope="module")
def site() -> Site:
    return random_site(2, slots=12, buffer_m=3.0)  # a 1.5 m waypoint radius


def _motion(site: Site, centres: list[list[float]] = (), radii: list[float] = (),
            polygons: tuple[PolygonZone, ...] = (), hover: tuple[int, ...] = (0,)):
    sk = Skeleton(SQUARE, np.array([1.0 if k in hover else 0.0 for k in range(4)]))
    profiles = leg_profiles(site, sk.leg_lengths_m)
    profile = motion_profile(site)
    lim = scurve_limits(profile)
    return profiles, blended_motion(
        SQUARE, profiles.total_s, sk.hold_s > 0, min(lim.default_speed_mps, lim.top_speed_mps),
        profile, np.array(centres, dtype=float).reshape(-1, 2), np.array(radii, dtype=float),
        polygons, 0.0)


def test_clear_corners_are_flown_through_and_save_time(site: Site) -> None:
    profiles, m = _motion(site, [[50.0, 50.0]], [45.0])  # 5 m inside every leg
    assert m.stops.tolist() == [True, False, False, False]
    assert m.move_s < float(profiles.total_s.sum()) - 1.0  # three stops saved
    # a lag only where it stops (the return to waypoint 0)
    assert m.arrival_lag_s.tolist() == pytest.approx([STOP_LAG_S, 0.0, 0.0, 0.0])


def test_hover_points_stop(site: Site) -> None:
    _, m = _motion(site, hover=(0, 2))
    assert m.stops.tolist() == [True, False, True, False]


@pytest.mark.parametrize(("centre", "radius"), [([96.5, 3.5], 3.4), ([99.0, 1.0], 0.9)])
def test_a_turn_that_would_cut_a_circle_stops(site: Site, centre: list[float],
                                              radius: float) -> None:
    # The legs clear the circle by 10 cm; the turn at (100, 0), cutting the corner by the
    # 1.5 m waypoint radius, would not.
    _, m = _motion(site, [centre], [radius])
    assert m.stops.tolist() == [True, True, False, False]


def test_a_turn_that_would_cut_a_polygon_stops(site: Site) -> None:
    inside = polygon_zone("P", [[99.9, 0.1], [99.9, 40.0], [60.0, 0.1]], "test")
    _, m = _motion(site, polygons=(inside,))
    assert m.stops.tolist() == [True, True, False, False]


def test_the_moves_tile_the_flight(site: Site) -> None:
    """Offsets and durations come from one flight: the first leg leaves from rest, a blended
    leg starts where the previous corner counted as reached, and the moves plus the lags add
    up to the flight's length."""
    from mission_planner.optimize.corners import _fly_cycle

    profiles, m = _motion(site)
    assert m.offset_s[0] == 0.0 and np.all(m.offset_s[1:] > 0)
    lim = scurve_limits(motion_profile(site))
    path = _fly_cycle(SQUARE, m.stops, min(lim.default_speed_mps, lim.top_speed_mps),
                      motion_profile(site))
    assert path.end_s is not None
    moving = path.end_s - path.start_s  # each leg's motion, its corners' lag in it
    assert np.all(moving > profiles.total_s)  # 90° turns: past the lag-free 72°
    assert np.all(m.duration_s <= moving - m.offset_s + 1e-9)
    assert m.duration_s[-1] == pytest.approx(moving[-1] - m.offset_s[-1])
    assert float(np.sum(m.duration_s) + np.sum(m.arrival_lag_s)) == pytest.approx(
        float(path.reached_s[-1] - path.start_s[0]))


def test_the_realistic_sample_gives_more_per_flown_second_than_the_paper_plan() -> None:
    """Issue 11's measure on the quick-start site: the vehicle plan, flying through its clear
    corners and keeping T, gives the worst node more per flown second than the paper-model
    plan flown as it is (which overruns T); stopping at every corner it gave 0.63 of it."""
    from pathlib import Path

    from mission_planner.flight_report import replay_mission
    from mission_planner.pipeline import plan_and_build
    from validator.site import load_site

    site = load_site(Path(__file__).resolve().parents[2] / "samples" / "realistic.yaml")
    flown = {}
    for dynamics in ("none", "vehicle"):
        mission = plan_and_build(site, dynamics=dynamics)
        check = replay_mission(mission)
        assert check.replayed_min_rate_bps_hz is not None and check.replayed_cycle_s is not None
        flown[dynamics] = (check.replayed_min_rate_bps_hz, check.replayed_cycle_s)
    # it flies through corners, and the replayed track (turns included) keeps the buffer
    assert mission.steps and any(s.leg_s > 0 and s.hold_s <= 0 for s in mission.steps)
    assert min(check.clearance_by_nfz_m.values()) >= site.buffer_m - 0.01
    assert flown["none"][1] > 1.2 * site.period_s  # the paper plan overruns T when flown
    assert flown["vehicle"][1] == pytest.approx(site.period_s, rel=0.02)
    assert flown["vehicle"][0] > flown["none"][0]


OCTAGON = 60.0 * np.array([[np.cos(a), np.sin(a)] for a in np.arange(8) * np.pi / 4])


def _px4_motion(site: Site, points: np.ndarray = OCTAGON, centres: list[list[float]] = (),
                radii: list[float] = (), hover: tuple[int, ...] = (0,)):
    sk = Skeleton(points, np.array([1.0 if k in hover else 0.0 for k in range(len(points))]))
    profiles = leg_profiles(site, sk.leg_lengths_m, autopilot="px4")
    profile = motion_profile(site, "px4")
    return profiles, px4_motion(
        points, profiles.total_s, sk.hold_s > 0, px4_top_speed_mps(profile), profile,
        np.array(centres, dtype=float).reshape(-1, 2), np.array(radii, dtype=float))


def test_px4_flies_through_clear_gentle_corners_and_saves_time(site: Site) -> None:
    inner = 60.0 * np.cos(np.pi / 8) - 5.0  # 5 m inside every leg; the turns are 45°
    profiles, m = _px4_motion(site, centres=[[0.0, 0.0]], radii=[inner])
    assert m.stops.tolist() == [True] + [False] * 7
    assert m.move_s < float(profiles.total_s.sum()) - 7.0  # seven stops saved
    assert np.all(m.arrival_lag_s == 0.0)  # PX4's legs end when it counts them reached
    # a run from a stop: its first leg from rest, shorter than flown to a stop
    assert m.offset_s[0] == 0.0 and m.duration_s[0] < profiles.total_s[0]


def test_px4_stops_at_turns_sharper_than_calibrated(site: Site) -> None:
    # 90° corners: beyond the 12-60° turns the px4 model was timed on (PX4_MAX_TURN_DEG)
    _, m = _px4_motion(site, SQUARE)
    assert PX4_MAX_TURN_DEG < 90.0 and m.stops.all()


def test_px4_stops_where_its_swing_outside_the_turn_would_reach_a_zone(site: Site) -> None:
    # A circle (its radius with the buffer) 1 m outside corner 1, beyond the turn: ArduCopter
    # cuts the corner inside and flies through; PX4 swings outside by up to NAV_ACC_RAD
    # (1.5 m here) and stops.
    radius = 2.0
    centre = [OCTAGON[1] / 60.0 * (60.0 + 1.0 + radius)]
    w = len(OCTAGON)
    lim = scurve_limits(motion_profile(site))
    arducopter = blended_motion(
        OCTAGON, leg_profiles(site, np.full(w, 60.0 * 2 * np.sin(np.pi / 8))).total_s,
        np.eye(w, dtype=bool)[0], min(lim.default_speed_mps, lim.top_speed_mps),
        motion_profile(site), np.array(centre), np.array([radius]))
    _, m = _px4_motion(site, centres=centre, radii=[radius])
    assert not arducopter.stops[1]
    assert m.stops.tolist() == [True, True] + [False] * 6
    _, hover = _px4_motion(site, hover=(0, 2))
    assert hover.stops.tolist() == [True, False, True] + [False] * 5
