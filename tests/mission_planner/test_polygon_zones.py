"""Polygon zones in the optimiser: the separating-line rows keep whole legs out, plans obey them.

The rows (module docstring of :mod:`mission_planner.optimize.trajectory`): for each convex part P
of a zone, at the current leg a unit direction u (:func:`validator.zones.leg_separation`, as the
optimiser picks it) and both ends of the new leg with u·x ≥ h_P(u) + b.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from mission_planner.optimize import PlannerOptions, plan
from mission_planner.optimize.initial import initial_tour
from mission_planner.optimize.scaled import scale_site
from mission_planner.optimize.trajectory import separating_lines
from mission_planner.study.sites import random_polygon_site, random_site
from validator.site import Site, parse_site
from validator.zones import (
    leg_clearance_m,
    leg_separation,
    point_clearance_m,
    polygon_zone,
    support_m,
)

FAST = PlannerOptions(max_iterations=15, dynamics="none")
coord = st.floats(-200.0, 200.0, allow_nan=False)


@st.composite
def polygons(draw: st.DrawFn) -> np.ndarray:
    """A convex polygon (hull of random points) or a star-shaped, usually non-convex, one."""
    count = draw(st.integers(3, 9))
    angle = np.sort(np.array(draw(st.lists(st.floats(0.0, 2 * np.pi), min_size=count,
                                           max_size=count, unique=True))))
    reach = np.array(draw(st.lists(st.floats(10.0, 80.0), min_size=count, max_size=count)))
    pts = np.stack([reach * np.cos(angle), reach * np.sin(angle)], axis=1)
    if draw(st.booleans()):
        hull = shapely.MultiPoint(pts).convex_hull
        assume(isinstance(hull, shapely.Polygon) and hull.area > 1.0)
        return np.asarray(hull.exterior.coords)[:-1]
    poly = shapely.Polygon(pts)
    assume(poly.is_valid and poly.area > 1.0)
    return pts


# Found by CI: three vertices on one line, 1e-277 m apart, made Delaunay a triangle with no
# area, whose part had no vertices.
SLIVERED = np.array([[13.0, 0.0], [13.0, 7.17298969e-278], [13.0, 1.20171299e-137],
                     [5.40302306, 8.41470985], [-4.16146837, 9.09297427],
                     [-9.89992497, 1.41120008], [2.83662185, -9.58924275],
                     [9.60170287, -2.79415498]])
# Found by CI again: triangles of 1e-37 m², kept for having an area, merged into a part that
# simplified to nothing.
SPECKED = np.array([[11.0, 0.0], [10.0, 3.30726842e-182], [11.0, 1.83176163e-071],
                    [10.0, 1.17549435e-037], [5.40302306, 8.41470985],
                    [-7.19007983, -8.32482745]])


@settings(max_examples=300, deadline=None)
@given(polygons(), st.tuples(coord, coord, coord, coord), st.tuples(coord, coord, coord, coord),
       st.floats(0.0, 20.0), st.booleans())
@example(SLIVERED, (0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0), 0.0, False)
@example(SPECKED, (0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0), 0.0, False)
def test_a_leg_the_rows_accept_keeps_the_buffer(verts, current, move, buffer_m, projected):
    zone = polygon_zone("Z", verts, "test")
    a0, b0 = np.array(current[:2]), np.array(current[2:])
    lines = []
    for part in zone.parts:  # the optimiser's direction at the current leg (touching or not)
        u, _ = leg_separation(part, a0[None], b0[None])
        lines.append((u[0], float(support_m(part, u[0])) + buffer_m))
    a, b = np.array(move[:2]), np.array(move[2:])
    if projected:  # pull the new ends into the accepted region (alternating projections)
        for _ in range(100):
            for u, h in lines:
                a = a + max(0.0, h - u @ a) * u
                b = b + max(0.0, h - u @ b) * u
    assume(all(u @ a >= h and u @ b >= h for u, h in lines))
    leg = shapely.LineString([a, b]) if np.any(a != b) else shapely.Point(a)
    with np.errstate(divide="ignore", invalid="ignore"):  # GEOS on nearly parallel edges
        distance = shapely.distance(zone.shape, leg)
    assert distance >= buffer_m - 1e-6


@pytest.mark.parametrize("verts", [SLIVERED, SPECKED])
def test_every_convex_part_has_a_ring_and_together_they_are_the_zone(verts) -> None:
    zone = polygon_zone("Z", verts, "test")
    assert all(len(part) >= 3 for part in zone.parts)
    union = shapely.union_all([shapely.Polygon(part) for part in zone.parts])
    assert union.symmetric_difference(zone.shape).area < 1e-9


def test_leg_separation_direction_is_the_distance_at_a_clear_leg() -> None:
    square = np.array([(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)])
    u, gap = leg_separation(square, [(13.0, -5.0), (20.0, 20.0)], [(13.0, 15.0), (20.0, 20.0)])
    assert np.allclose(u, [[1.0, 0.0], [np.sqrt(0.5), np.sqrt(0.5)]])
    assert np.allclose(gap, [3.0, np.hypot(10.0, 10.0)])
    # A leg through the square: the best edge normal, and a negative gap.
    u, gap = leg_separation(square, [(5.0, -5.0)], [(5.0, 15.0)])
    assert gap[0] < 0 and abs(np.linalg.norm(u[0]) - 1.0) < 1e-12


def _site(zones: list[dict], *, slots: int, buffer_m: float = 2.0) -> Site:
    return parse_site({
        "name": "crafted-polygons",
        "origin": {"lat": 37.5585, "lon": 126.999, "alt": 40.0},
        "home": {"x": 0.0, "y": -100.0},
        "uav": {"altitude": 30.0, "max_speed": 30.0, "period": 30.0, "slots": slots},
        "radio": {"p_avg_dbm": 20.0, "p_peak_dbm": 26.0206, "beta0_db": -30.0,
                  "noise_dbm": -70.0},
        "ground_nodes": [{"name": "W", "x": 0.0, "y": 0.0}, {"name": "E", "x": 240.0, "y": 0.0}],
        "no_fly_zones": zones,
        "safety": {"buffer_m": buffer_m},
    })


# A non-convex "C" between the two nodes, open to the north, and a convex one beyond E.
WALL = [{"x": 100.0, "y": -60.0}, {"x": 140.0, "y": -60.0}, {"x": 140.0, "y": 60.0},
        {"x": 125.0, "y": 60.0}, {"x": 125.0, "y": -20.0}, {"x": 115.0, "y": -20.0},
        {"x": 115.0, "y": 60.0}, {"x": 100.0, "y": 60.0}]
WEDGE = [{"x": 280.0, "y": -30.0}, {"x": 320.0, "y": 0.0}, {"x": 280.0, "y": 30.0}]
ZONES = [{"name": "WALL", "polygon": WALL}, {"name": "WEDGE", "polygon": WEDGE}]


def test_initial_tour_keeps_every_leg_clear_of_the_polygons() -> None:
    for site in (_site(ZONES, slots=12), *(random_polygon_site(s, buffer_m=2.0) for s in range(6))):
        sc = scale_site(site, 0.02)
        q, delta = initial_tour(sc)
        traj = np.vstack([q[-1], q]) * 100.0
        for z in site.polygon_zones:
            worst = min(leg_clearance_m(z, a, b) for a, b in zip(traj[:-1], traj[1:], strict=True))
            assert worst >= site.buffer_m
        legs = np.linalg.norm(np.diff(traj, axis=0), axis=1)
        assert np.all(legs <= site.max_speed_mps * site.period_s / site.slots * (1 + 1e-9))


def test_proposed_keeps_every_leg_clear_of_a_non_convex_zone() -> None:
    site = _site(ZONES, slots=6)
    sol = plan(site, "proposed", options=FAST)
    assert sol.polygon_clearance_m.min() >= site.buffer_m - 1e-6
    assert sol.report()["zone_clearance_min_m"]["WALL"] >= site.buffer_m - 1e-6


def test_conventional_keeps_only_the_waypoints_clear() -> None:
    site = random_polygon_site(1, buffer_m=2.0)
    conventional = plan(site, "conventional", options=FAST)
    proposed = plan(site, "proposed", options=FAST)
    for z in site.polygon_zones:
        assert np.all(point_clearance_m(z, conventional.trajectory_m) >= site.buffer_m - 1e-6)
    assert conventional.polygon_clearance_m.min() < 0.0  # a leg cuts a corner of a zone
    assert proposed.polygon_clearance_m.min() >= site.buffer_m - 1e-6


@pytest.mark.parametrize("seed", range(6))
def test_proposed_never_enters_a_random_polygon_zone(seed: int) -> None:
    site = random_polygon_site(seed, slots=10, size_m=60.0, buffer_m=2.0)
    for scheme in ("proposed", "tangent"):  # tangent uses the proposed rule on polygons
        sol = plan(site, scheme, options=FAST)
        assert sol.polygon_clearance_m.min() >= site.buffer_m - 1e-6, scheme


@pytest.mark.parametrize("seed", range(8))
def test_tangent_keeps_every_leg_outside_the_circles(seed: int) -> None:
    site = random_site(seed, slots=10, radius_m=45.0, num_nfzs=4, buffer_m=2.0)
    sol = plan(site, "tangent", options=FAST)
    assert sol.nfz_clearance_min_m >= site.buffer_m - 1e-6


def test_separating_lines_hold_at_the_current_point() -> None:
    # The current legs satisfy their own rows with the slack the lines report (monotone SCA).
    site = random_polygon_site(2, buffer_m=2.0)
    sc = scale_site(site, 0.02)
    q, _ = initial_tour(sc)
    u, h, slack = separating_lines(sc, q, "proposed")
    prev = np.r_[sc.num_slots - 1, np.arange(sc.num_slots - 1)]
    ends = np.minimum(np.einsum("onk,nk->on", u, q), np.einsum("onk,nk->on", u, q[prev]))
    assert np.allclose(ends - h, slack, atol=1e-12)
    assert np.all(slack >= -1e-12)
