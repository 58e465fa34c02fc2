"""Shortest safe transits around circles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mission_planner.transit import drop_collinear, path_length_m, shortest_safe_path
from validator.geometry import min_leg_clearance


def _polygon_graph_length(start, goal, centres, radii, sides=96):
    """Independent oracle: shortest path through the vertices of circumscribed polygons.

    Every edge it may use is checked exactly against the circles, so its answer is a feasible
    path: no shorter than the optimum and at most a fraction ~1/cos(π/sides) − 1 longer.
    """
    ang = np.linspace(0, 2 * math.pi, sides, endpoint=False)
    pts = [np.asarray(start, float), np.asarray(goal, float)]
    for c, r in zip(centres, radii, strict=True):
        rv = r / math.cos(math.pi / sides) * (1 + 1e-9)
        pts += list(np.c_[c[0] + rv * np.cos(ang), c[1] + rv * np.sin(ang)])
    pts = np.array(pts)
    a, b = pts[:, None, None, :], pts[None, :, None, :]
    ab = b - a
    ac = np.asarray(centres, float)[None, None, :, :] - a
    t = np.clip(np.sum(ac * ab, -1) / np.maximum(np.sum(ab * ab, -1), 1e-300), 0, 1)
    d = np.linalg.norm(ac - t[..., None] * ab, axis=-1)
    ok = np.all(d >= np.asarray(radii)[None, None, :] - 1e-9, axis=-1)
    w = np.where(ok, np.linalg.norm(pts[:, None] - pts[None, :], axis=-1), np.inf)
    dist = np.full(len(pts), np.inf)
    dist[0] = 0.0
    done = np.zeros(len(pts), bool)
    for _ in range(len(pts)):
        u = int(np.argmin(np.where(done, np.inf, dist)))
        done[u] = True
        dist = np.minimum(dist, dist[u] + w[u])
    return float(dist[1])


def test_clear_line_is_kept_straight():
    path = shortest_safe_path([0, 0], [100, 0], [[50, 40]], [30])
    np.testing.assert_allclose(path, [[0, 0], [100, 0]])


def test_path_around_one_circle_has_the_analytic_length():
    # Two tangents of sqrt(20² − 10²) and the arc between the tangent points.
    path = shortest_safe_path([-20, 0], [20, 0], [[0, 0]], [10], arc_step_deg=1.0)
    exact = 2 * math.sqrt(300) + 10 * (math.pi - 2 * math.acos(10 / 20))
    assert exact <= path_length_m(path) <= exact * (1 / math.cos(math.radians(0.5)))
    assert min_leg_clearance(path, [[0, 0]], [10]) >= -1e-9


def test_chord_vertices_never_enter_the_circle_even_with_coarse_steps():
    path = shortest_safe_path([-50, 1], [50, -1], [[0, 0]], [30], arc_step_deg=45.0)
    assert len(path) > 2
    assert min_leg_clearance(path, [[0, 0]], [30]) >= -1e-9


def test_path_threads_between_two_circles_when_that_is_shorter():
    centres = [[0, 25], [0, -25]]
    path = shortest_safe_path([-100, 0], [100, 0], centres, [20, 20])
    assert np.max(np.abs(path[:, 1])) <= 5.0 + 1e-9  # through the 10 m gap, not around
    assert min_leg_clearance(path, centres, [20, 20]) >= -1e-9


@settings(max_examples=20, deadline=None)
@given(st.integers(min_value=0, max_value=10_000))
def test_random_fields_match_an_independent_polygon_oracle(seed):
    rng = np.random.default_rng(seed)
    centres, radii = [], []
    while len(centres) < 4:
        c = rng.uniform(40, 360, 2)
        r = rng.uniform(10, 40)
        if all(np.linalg.norm(c - d) > r + s + 1 for d, s in zip(centres, radii, strict=True)):
            centres.append(c)
            radii.append(r)
    start, goal = np.array([0.0, 0.0]), np.array([400.0, 400.0])
    path = shortest_safe_path(start, goal, centres, radii, arc_step_deg=2.0)
    np.testing.assert_allclose(path[0], start)
    np.testing.assert_allclose(path[-1], goal)
    assert min_leg_clearance(path, centres, radii) >= -1e-7
    oracle = _polygon_graph_length(start, goal, centres, radii)
    # Both are within ~0.02 % (chords, 256-gons) of the true shortest length.
    assert path_length_m(path) == pytest.approx(oracle, rel=2e-3)


def test_overlapping_circles_are_passed_as_one_obstacle():
    centres = [[0, 0], [15, 0]]
    path = shortest_safe_path([-40, 0], [55, 0], centres, [10, 10])
    assert min_leg_clearance(path, centres, [10, 10]) >= -1e-7


def test_end_point_inside_a_circle_is_refused():
    with pytest.raises(ValueError, match="start point lies inside circle 0"):
        shortest_safe_path([1, 0], [100, 0], [[0, 0]], [10])


def test_walled_in_goal_is_refused():
    ring = [[20 * math.cos(a), 20 * math.sin(a)] for a in np.linspace(0, 2 * math.pi, 12,
                                                                        endpoint=False)]
    with pytest.raises(ValueError, match="no safe path"):
        shortest_safe_path([100, 0], [0, 0], ring, [8.0] * 12)


def test_drop_collinear_removes_points_on_a_line_and_repeats():
    path = np.array([[0, 0], [1, 0], [1, 0], [2, 0], [2, 1], [2, 2]])
    np.testing.assert_allclose(drop_collinear(path), [[0, 0], [2, 0], [2, 2]])


def test_a_transit_obstacle_near_an_end_point_keeps_what_that_point_allows():
    """An end point 3.2 m from a zone (buffer + margin 3.5 m): the zone is grown as far as the
    point allows, not halved to 1.75 m, so a transit from it keeps almost 3.2 m."""
    import shapely

    from mission_planner.mission.clearance import _largest_outline_clear_of
    from validator.zones import polygon_zone

    zone = polygon_zone("Z", [(0, 0), (100, 0), (100, 50), (0, 50)], "test")
    ends = shapely.MultiPoint([(50.0, 53.2), (50.0, 300.0)])
    outline = shapely.Polygon(_largest_outline_clear_of(zone, 3.5, ends))
    assert not outline.intersects(ends)
    assert 3.0 <= outline.exterior.distance(zone.shape) <= 3.2  # halving gave 1.75
    far = shapely.MultiPoint([(50.0, 60.0), (50.0, 300.0)])
    whole = shapely.Polygon(_largest_outline_clear_of(zone, 3.5, far))
    assert whole.exterior.distance(zone.shape) == pytest.approx(3.5)


def test_an_end_point_round_a_corner_keeps_the_outline_at_the_whole_grow():
    """An end point just beyond the grown margin, round a corner (harbour in 8 m/s from 45°:
    the cycle's first waypoint 3.45 m from the breakwater's corner, the transit grown by
    3.44 m): the fence's 30° chords stand off the corner up to 3.56 m and held the point in,
    and shrinking them until it was out let the transit's last chord pass 3.33 m from the
    zone. Rounded with finer chords, the outline keeps the whole margin."""
    import shapely

    from mission_planner.mission.clearance import _largest_outline_clear_of
    from validator.zones import fence_outline_m, polygon_zone

    zone = polygon_zone("Z", [(0, 0), (100, 0), (100, 50), (0, 50)], "test")
    corner = np.array([100.0, 50.0])
    at = corner + 3.45 * np.array([math.cos(math.radians(60)), math.sin(math.radians(60))])
    ends = shapely.MultiPoint([at, (300.0, 300.0)])
    assert shapely.Polygon(fence_outline_m(zone, 3.44)).intersects(ends)  # the old trap
    outline = shapely.Polygon(_largest_outline_clear_of(zone, 3.44, ends))
    assert not outline.intersects(ends)
    assert outline.exterior.distance(zone.shape) >= 3.43  # the buffer, not 3.33
