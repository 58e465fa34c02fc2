"""Polygon zones: validation, convex parts, signed clearances, the fence outline."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
import shapely
from hypothesis import example, given, settings
from hypothesis import strategies as st

from validator.errors import InputError
from validator.zones import (
    MIN_AREA_M2,
    buffer_intrusion,
    convex_parts,
    fence_outline_m,
    leg_clearance_m,
    point_clearance_m,
    polygon_zone,
    support_m,
    zone_point_clearances_m,
)

SQUARE = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]
# a "U": non-convex, the notch between x = 4 and 6 from y = 4 up
U = [(0, 0), (10, 0), (10, 10), (6, 10), (6, 4), (4, 4), (4, 10), (0, 10)]


def test_vertices_are_oriented_counter_clockwise_without_the_closing_repeat():
    z = polygon_zone("Z", SQUARE[::-1] + [SQUARE[-1]], "z")
    assert len(z.vertices_xy_m) == 4
    assert shapely.LinearRing(z.vertices_xy_m).is_ccw


@pytest.mark.parametrize("verts, words", [
    ([(0, 0), (1, 0)], "at least 3"),
    ([(0, 0), (1, 0), (1, 0), (0, 0)], "at least 3"),
    ([(0, 0), (10, 10), (10, 0), (0, 10)], "intersects itself"),
    ([(0, 0), (1, 1), (2, 2)], "no area"),
    ([(0, 0), (5e-4, 0), (5e-4, 5e-4), (0, 5e-4)], r"no area \(less than 1e-06 m²\)"),
])
def test_bad_polygons_are_refused_naming_the_field(verts, words):
    with pytest.raises(InputError, match=words) as err:
        polygon_zone("Z", verts, "site.yaml: no_fly_zones[1] (Z).polygon")
    assert str(err.value).startswith("site.yaml: no_fly_zones[1] (Z).polygon: ")


def test_a_convex_polygon_is_its_own_part():
    assert len(polygon_zone("Z", SQUARE, "z").parts) == 1


def test_convex_parts_of_a_non_convex_polygon_cover_it_exactly_and_are_convex():
    z = polygon_zone("U", U, "z")
    parts = [shapely.Polygon(p) for p in z.parts]
    assert len(parts) >= 3  # the U cannot be cut into fewer
    for p in parts:
        assert p.convex_hull.area == pytest.approx(p.area)
        assert shapely.LinearRing(p.exterior.coords).is_ccw
    assert sum(p.area for p in parts) == pytest.approx(z.area_m2)
    assert shapely.union_all(parts).symmetric_difference(z.shape).area == pytest.approx(0.0,
                                                                                        abs=1e-9)


def test_support_line_leaves_the_part_on_its_inner_side():
    part = polygon_zone("Z", SQUARE, "z").parts[0]
    assert float(support_m(part, [1.0, 0.0])) == 10.0
    assert float(support_m(part, [-1.0, 0.0])) == 0.0
    diag = np.array([1.0, 1.0]) / np.sqrt(2.0)
    assert float(support_m(part, diag)) == pytest.approx(20.0 / np.sqrt(2.0))


def test_point_clearance_is_distance_outside_and_minus_depth_inside():
    z = polygon_zone("Z", SQUARE, "z")
    got = point_clearance_m(z, [[13.0, 5.0], [5.0, 1.0], [13.0, 14.0]])
    assert got == pytest.approx([3.0, -1.0, 5.0])


@dataclass(frozen=True)
class _Zones:
    nfz_xy_m: np.ndarray
    nfz_radius_m: np.ndarray
    polygon_zones: tuple
    buffer_m: float

    @property
    def zone_names(self) -> tuple[str, ...]:
        return ("C1", *(z.name for z in self.polygon_zones))


# a circle of radius 5 at (30, 5) and the square (0, 0)-(10, 10); buffer 2 m
ZONES = _Zones(np.array([[30.0, 5.0]]), np.array([5.0]), (polygon_zone("Z", SQUARE, "z"),), 2.0)


def test_a_points_clearance_from_every_zone_is_signed_circles_then_polygons():
    assert zone_point_clearances_m(ZONES, [12.0, 5.0]) == pytest.approx([13.0, 2.0])
    assert zone_point_clearances_m(ZONES, [29.0, 5.0]) == pytest.approx([-4.0, 19.0])


@pytest.mark.parametrize(("xy", "words"), [
    ((12.0, 5.0), ""),  # 2 m from the square: on its buffer's edge, clear
    ((11.5, 5.0), "Z plus its 2 m safety buffer (1.5 m from it)"),
    ((5.0, 9.0), "Z plus its 2 m safety buffer (1.0 m inside it)"),
    ((23.5, 5.0), "C1 plus its 2 m safety buffer (1.5 m from it)"),
])
def test_buffer_intrusion_names_the_zone_whose_buffer_holds_a_point(xy, words):
    assert buffer_intrusion(ZONES, xy) == words


def test_leg_clearance_is_exact_outside_and_the_depth_inside():
    z = polygon_zone("U", U, "z")
    # down the notch's middle: 1 m from both arms, never inside
    assert leg_clearance_m(z, [5.0, 12.0], [5.0, 5.0]) == pytest.approx(1.0)
    # across the left arm at y = 7: 2 m deep at its middle (x = 2, 2 m from x = 0 and x = 4)
    assert leg_clearance_m(z, [-3.0, 7.0], [5.0, 7.0]) == pytest.approx(-2.0, abs=0.03)
    # a leg that just touches a corner
    assert leg_clearance_m(z, [10.0, 12.0], [12.0, 10.0]) == pytest.approx(np.sqrt(2.0))


@pytest.mark.parametrize("margin_m", [0.5, 3.0, 25.0])
@pytest.mark.parametrize("verts", [SQUARE, U, [(0, 0), (100, 0), (0, 3)]])
def test_fence_outline_holds_every_point_within_the_margin(verts, margin_m):
    z = polygon_zone("Z", verts, "z")
    out = shapely.Polygon(fence_outline_m(z, margin_m))
    assert out.contains(z.shape)
    assert shapely.distance(out.exterior, z.shape) >= margin_m * (1 - 1e-9)
    # rounded corners: no vertex stands off much more than the margin, even at a sliver's
    # corner (a mitre stood off sqrt(2) margins at a right angle, 1.8 at a sharp one), so a fence
    # at half the buffer stays well inside the planner's buffer
    far = shapely.distance(z.shape, shapely.points(fence_outline_m(z, margin_m))).max()
    assert far <= 1.1 * margin_m


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-50, 50), st.floats(-50, 50)), min_size=3, max_size=9))
@example(points=[(1.0, 0.0), (1.0, 2.6486263667899944e-48), (0.0, 1.0), (0.0, 1.0)])
def test_convex_parts_cover_any_simple_polygon(points):
    poly = shapely.Polygon(points)
    if not poly.is_valid or poly.area <= MIN_AREA_M2:
        with pytest.raises(InputError):
            polygon_zone("Z", points, "z")
        return
    parts = [shapely.Polygon(p) for p in convex_parts(np.asarray(poly.exterior.coords)[:-1])]
    assert sum(p.area for p in parts) == pytest.approx(poly.area, rel=1e-9)
    for p in parts:
        assert p.convex_hull.area == pytest.approx(p.area, rel=1e-9)
