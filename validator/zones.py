"""Polygon no-fly zones: their shape, convex parts, clearances of points and legs, fence outline.

A circle zone is a centre and a radius (``Site.nfz_xy_m``, ``Site.nfz_radius_m``); a polygon
zone is a :class:`PolygonZone`: a simple polygon without holes, vertices in metres east/north
of the site origin, counter-clockwise. Clearances are signed like the circles'
(``validator.geometry``): the distance outside the zone, negative for the depth inside it.

The planner keeps a straight leg outside a polygon through its convex parts: a leg lies outside a
convex part (plus a buffer b) when both its end points lie beyond one supporting line of the part
pushed out by b (:func:`support_m`). A non-convex zone is cut into convex parts whose union is the
zone (:func:`convex_parts`), so the same linear test covers it part by part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Protocol

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry.polygon import orient

from validator.errors import InputError

MAX_VERTICES = 1_000  # per zone: published airspace polygons hold tens to hundreds
# A polygon of less than a square millimetre is a line or a point drawn as one: shapely calls
# a sliver of 1e-48 m² valid, but its convex parts and clearances are not meaningful.
MIN_AREA_M2 = 1e-6
# Depth sampling along a leg that enters a polygon: the sign of a clearance is exact (shapely),
# the depth of a violation is measured to within half this step.
DEPTH_STEP_M = 0.05
# The start tour's outline round a polygon (mission_planner.optimize.initial): mitred corners,
# bevelled where the mitre would stand off more than this many times its offset.
FENCE_MITRE_LIMIT = 1.5
# A fence outline goes round each convex corner of its zone in chords of about this angle (deg):
# it then stands off the zone by at most ~1.06 margins anywhere. A mitred corner stood off
# sqrt(2) margins at a right angle and up to 1.8 at a sharp one, where a replayed track the
# exporter keeps inside the buffer, as it may, crossed the fence (bench_safety found two); 45°
# chords stood off up to 1.2 margins (GEOS rounds a corner's chord count). The cost: three more
# vertices per right-angled corner (the airfield's CTR: 26 instead of 8).
FENCE_ARC_STEP_DEG = 30.0


@dataclass(frozen=True, eq=False)
class PolygonZone:
    """A polygon no-fly zone as published (the planner adds the site's buffer).

    ``vertices_xy_m`` is (P, 2), counter-clockwise, without repeating the first vertex;
    ``parts`` are convex (Q, 2) counter-clockwise polygons whose union is the zone.
    """

    name: str
    vertices_xy_m: NDArray[np.float64]
    parts: tuple[NDArray[np.float64], ...] = field(repr=False)

    @cached_property
    def shape(self) -> shapely.Polygon:
        return shapely.Polygon(self.vertices_xy_m)

    @property
    def is_convex(self) -> bool:
        return len(self.parts) == 1

    @property
    def area_m2(self) -> float:
        return float(self.shape.area)


def polygon_zone(name: str, vertices_xy_m: ArrayLike, where: str) -> PolygonZone:
    """A validated :class:`PolygonZone`; :class:`InputError` at ``where`` when the vertices do
    not make a simple polygon of at least 3 corners (repeated and closing vertices are dropped,
    any orientation is accepted)."""
    v = np.asarray(vertices_xy_m, dtype=float).reshape(-1, 2)
    if len(v) > MAX_VERTICES:
        raise InputError(f"{where}: {len(v)} vertices; at most {MAX_VERTICES} are supported")
    keep = np.ones(len(v), dtype=bool)
    keep[1:] = np.any(v[1:] != v[:-1], axis=1)
    v = v[keep]
    if len(v) > 1 and np.all(v[-1] == v[0]):
        v = v[:-1]
    if len(v) < 3:
        raise InputError(f"{where}: a polygon needs at least 3 distinct vertices, got {len(v)}")
    poly = shapely.Polygon(v)
    if not poly.is_valid or poly.area <= MIN_AREA_M2:
        if np.linalg.matrix_rank(v - v[0], tol=1e-9) < 2:
            what = "has no area (its vertices lie on one line)"
        elif poly.is_valid:  # a sliver shapely accepts: it has no reason to give
            what = f"has no area (less than {MIN_AREA_M2:g} m²)"
        else:
            what = "intersects itself"
        reason = "" if poly.is_valid else f" ({shapely.is_valid_reason(poly)})"
        raise InputError(f"{where}: the polygon {what}{reason}; give its vertices in order round "
                         "the boundary")
    poly = orient(poly, 1.0)
    verts = np.asarray(poly.exterior.coords, dtype=float)[:-1]
    return PolygonZone(name, verts, convex_parts(verts))


def convex_parts(vertices_xy_m: ArrayLike) -> tuple[NDArray[np.float64], ...]:
    """Convex counter-clockwise polygons whose union is the simple polygon ``vertices_xy_m``.

    A convex polygon is its own part. Otherwise its constrained Delaunay triangles are merged
    greedily while a union stays convex (Hertel and Mehlhorn: at most four times the fewest parts),
    in a fixed order, so the parts are deterministic.
    """
    v = np.asarray(vertices_xy_m, dtype=float)
    poly = orient(shapely.Polygon(v), 1.0)
    if math.isclose(poly.convex_hull.area, poly.area, rel_tol=1e-12, abs_tol=1e-9):
        return (np.asarray(poly.exterior.coords, dtype=float)[:-1],)
    # A triangle of three (nearly) collinear vertices has no ring worth keeping: none at all,
    # or a sliver (CI's property test drew 1e-37 m²) that a merge simplifies away to nothing.
    # Below a 1e-12 share of the zone's area it changes the zone by less than rounding does.
    least_m2 = 1e-12 * poly.area
    parts = [orient(t, 1.0) for t in shapely.constrained_delaunay_triangles(poly).geoms
             if t.area > least_m2]
    merged = True
    while merged:
        merged = False
        for i in range(len(parts)):
            for j in range(i + 1, len(parts)):
                shared = parts[i].boundary.intersection(parts[j].boundary)
                if shared.length <= 0.0:
                    continue
                union = shapely.union(parts[i], parts[j])
                if isinstance(union, shapely.Polygon) and math.isclose(
                        union.convex_hull.area, union.area, rel_tol=1e-9, abs_tol=1e-9):
                    parts[i] = orient(shapely.simplify(union, 0.0), 1.0)
                    del parts[j]
                    merged = True
                    break
            if merged:
                break
    return tuple(np.asarray(p.exterior.coords, dtype=float)[:-1] for p in parts)


def support_m(part_xy_m: ArrayLike, direction: ArrayLike) -> NDArray[np.float64]:
    """The support function max over the part's vertices of ``direction`` · v (m).

    For a unit ``direction`` a, the line a·x = support_m(part, a) touches the convex part and
    leaves it on the side a·x ≤ support; a leg whose end points both satisfy
    a·x ≥ support + b lies, whole, at least b from the part. ``direction`` may be (..., 2).
    """
    part = np.asarray(part_xy_m, dtype=float)
    d = np.asarray(direction, dtype=float)
    return np.asarray(np.max(d @ part.T, axis=-1), dtype=float)


def point_clearance_m(zone: PolygonZone, xy_m: ArrayLike) -> NDArray[np.float64]:
    """Signed clearance (m) of points (..., 2) from the zone: distance outside, minus the depth
    inside (the distance to its boundary)."""
    xy = np.asarray(xy_m, dtype=float)
    pts = shapely.points(xy.reshape(-1, 2))
    outside = shapely.distance(zone.shape, pts)
    inside = shapely.distance(zone.shape.exterior, pts)
    d = np.where(outside > 0.0, outside, -inside)
    return np.asarray(d.reshape(xy.shape[:-1]), dtype=float)


class ZoneSet(Protocol):
    """Every zone of a site and its buffer: :class:`validator.site.Site` is one."""

    @property
    def nfz_xy_m(self) -> NDArray[np.float64]: ...
    @property
    def nfz_radius_m(self) -> NDArray[np.float64]: ...
    @property
    def polygon_zones(self) -> tuple[PolygonZone, ...]: ...
    @property
    def zone_names(self) -> tuple[str, ...]: ...
    @property
    def buffer_m(self) -> float: ...


def zone_point_clearances_m(zones: ZoneSet, xy_m: ArrayLike) -> NDArray[np.float64]:
    """Signed clearance (m) of the point ``xy_m`` from every zone, circles then polygons
    (``zone_names`` order): distance outside, minus the depth inside."""
    xy = np.asarray(xy_m, dtype=float)
    circles = np.linalg.norm(np.asarray(zones.nfz_xy_m, dtype=float).reshape(-1, 2) - xy,
                             axis=1) - zones.nfz_radius_m
    polygons = [float(point_clearance_m(z, xy)) for z in zones.polygon_zones]
    return np.concatenate([circles, polygons]).astype(float)


def buffer_intrusion(zones: ZoneSet, xy_m: ArrayLike) -> str:
    """The zone whose buffer the point ``xy_m`` lies in, in words ("NFZ1 plus its 2 m safety
    buffer (3.0 m inside it)", the nearest zone when several); "" when it lies clear of all."""
    clear = zone_point_clearances_m(zones, xy_m)
    if not len(clear) or float(np.min(clear)) >= zones.buffer_m:
        return ""
    m = int(np.argmin(clear))
    c = float(clear[m])
    where = f"{-c:.1f} m inside it" if c < 0 else f"{c:.1f} m from it"
    return f"{zones.zone_names[m]} plus its {zones.buffer_m:g} m safety buffer ({where})"


def leg_clearance_m(zone: PolygonZone, a_m: ArrayLike, b_m: ArrayLike) -> float:
    """Signed clearance (m) of the straight leg ``a``→``b`` from the zone: the exact distance when
    it stays outside, else minus the deepest point's depth (to within DEPTH_STEP_M / 2)."""
    a, b = np.asarray(a_m, dtype=float), np.asarray(b_m, dtype=float)
    leg = shapely.LineString([a, b]) if np.any(a != b) else shapely.Point(a)
    d = float(shapely.distance(zone.shape, leg))
    return d if d > 0.0 else _deepest(zone, a, b)[0]


def _deepest(zone: PolygonZone, a: NDArray[np.float64], b: NDArray[np.float64]
             ) -> tuple[float, float]:
    """The least signed clearance (m) of the leg a→b that meets the zone, sampled every
    DEPTH_STEP_M along it, and the fraction along the leg where it occurs."""
    n = max(2, int(math.ceil(float(np.linalg.norm(b - a)) / DEPTH_STEP_M)) + 1)
    t = np.linspace(0.0, 1.0, n)
    c = point_clearance_m(zone, a + t[:, None] * (b - a))
    i = int(np.argmin(c))
    return float(c[i]), float(t[i])


def fence_outline_m(zone: PolygonZone, margin_m: float,
                    arc_step_deg: float | None = FENCE_ARC_STEP_DEG) -> NDArray[np.float64]:
    """Vertices (P, 2), counter-clockwise, of a polygon holding every point within ``margin_m``
    of the zone, and standing off it little more than that: the outline an exclusion fence needs.

    Offsetting each vertex by the margin would cut inside the zone's rounded margin at every
    corner, and mitred corners stand far out. So each convex corner is rounded by chords of at
    most about ``arc_step_deg`` on a circle just wide enough that every chord keeps the margin
    (GEOS's round join, its radius raised until the outline's least distance from the zone is the
    margin: checked, not assumed). Coarser chords take fewer vertices and stand further off
    (90°: up to ~1.4 margins); ``arc_step_deg`` None mitres the corners (fewest vertices,
    bevelled beyond FENCE_MITRE_LIMIT margins, up to 1.8 margins off).
    """
    if margin_m <= 0.0:
        return zone.vertices_xy_m.copy()
    if arc_step_deg is None:
        out = zone.shape.buffer(margin_m, join_style="mitre", mitre_limit=FENCE_MITRE_LIMIT)
        if float(shapely.distance(out.exterior, zone.shape)) < margin_m * (1.0 - 1e-9):
            raise AssertionError(f"fence outline of {zone.name} cuts its {margin_m} m margin")
        return np.asarray(orient(out, 1.0).exterior.coords, dtype=float)[:-1]
    quad_segs = max(1, round(90.0 / arc_step_deg))
    radius = margin_m / math.cos(math.radians(90.0 / quad_segs) / 2.0)
    for _ in range(8):
        out = orient(zone.shape.buffer(radius, quad_segs=quad_segs, join_style="round"), 1.0)
        least = float(shapely.distance(out.exterior, zone.shape))
        if least >= margin_m:
            return np.asarray(out.exterior.coords, dtype=float)[:-1]
        radius *= (margin_m / least) * (1.0 + 1e-9)
    raise AssertionError(f"no fence outline of {zone.name} keeps its {margin_m} m margin")


def _segments(a_m: NDArray[np.float64], b_m: NDArray[np.float64]) -> NDArray[np.object_]:
    """Shapely geometries of the legs a[i]→b[i]: a line, or a point for a leg of no length."""
    lines = shapely.linestrings(np.stack([a_m, b_m], axis=1))
    still = np.all(a_m == b_m, axis=1)
    if np.any(still):
        lines[still] = shapely.points(a_m[still])
    return np.asarray(lines)


def path_clearances_m(zones: tuple[PolygonZone, ...] | list[PolygonZone],
                      path_xy_m: ArrayLike) -> NDArray[np.float64]:
    """Signed clearance (m) of each leg of the polyline ``path_xy_m`` (P, 2) from each zone:
    (P - 1, len(zones)), as :func:`leg_clearance_m` gives it leg by leg."""
    path = np.asarray(path_xy_m, dtype=float).reshape(-1, 2)
    out = np.zeros((max(len(path) - 1, 0), len(zones)))
    if len(path) < 2 or not len(zones):
        return out
    legs = _segments(path[:-1], path[1:])
    for j, zone in enumerate(zones):
        d = np.asarray(shapely.distance(zone.shape, legs), dtype=float)
        for k in np.flatnonzero(d <= 0.0):
            d[k] = leg_clearance_m(zone, path[k], path[k + 1])
        out[:, j] = d
    return out


def polyline_clearance_m(zone: PolygonZone, xy_m: ArrayLike) -> tuple[float, int, float]:
    """Least signed clearance (m) of the polyline through ``xy_m`` (S, 2) from the zone, the
    index k of the chord xy[k]→xy[k+1] where it occurs and the fraction along that chord (a
    flown track judged exactly between its samples; a depth to within DEPTH_STEP_M / 2)."""
    xy = np.asarray(xy_m, dtype=float).reshape(-1, 2)
    if len(xy) == 1:
        xy = np.vstack([xy, xy])
    a, b = xy[:-1], xy[1:]
    chords = _segments(a, b)
    d = np.asarray(shapely.distance(zone.shape, chords), dtype=float)
    if float(np.min(d)) > 0.0:
        k = int(np.argmin(d))
        near = np.asarray(shapely.shortest_line(zone.shape, chords[k]).coords, dtype=float)[1]
        return float(d[k]), k, _fraction(a[k], b[k], near)
    best = (math.inf, 0, 0.0)
    for k in np.flatnonzero(d <= 0.0).tolist():
        c, t = _deepest(zone, a[k], b[k])
        if c < best[0]:
            best = (c, int(k), t)
    return best


def _fraction(a: NDArray[np.float64], b: NDArray[np.float64], p: NDArray[np.float64]) -> float:
    ab = b - a
    den = float(ab @ ab)
    return 0.0 if den == 0.0 else float(np.clip((p - a) @ ab / den, 0.0, 1.0))


def leg_closest_m(zone: PolygonZone, a_m: ArrayLike, b_m: ArrayLike) -> tuple[float, float]:
    """The fraction along the leg ``a``→``b`` of its point nearest the zone (or deepest in it)
    and that point's signed clearance (m)."""
    clr, _, f = polyline_clearance_m(zone, np.array([a_m, b_m], dtype=float))
    return f, clr


def leg_separation(part_xy_m: ArrayLike, a_m: ArrayLike, b_m: ArrayLike
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The best separating line between a convex part and each straight leg ``a``→``b``.

    Returns unit directions u (L, 2) and gaps g (L,) with g = min over the leg of u·x minus
    :func:`support_m` (part, u), the largest such value over all unit u: for a leg clear of the
    part it is their distance, reached by the direction from the part's closest point to the
    leg's. Legs ``a``, ``b`` are (L, 2); a zero-length leg is a point. When the leg touches or
    enters the part (no closest-point direction), the best outward edge normal is used instead
    and g ≤ 0 says by how much no line separates them.
    """
    part = np.asarray(part_xy_m, dtype=float)
    a = np.asarray(a_m, dtype=float).reshape(-1, 2)
    b = np.asarray(b_m, dtype=float).reshape(-1, 2)
    same = np.all(a == b, axis=1)
    legs = np.where(same, shapely.points(a), shapely.linestrings(np.stack([a, b], axis=1)))
    with np.errstate(divide="ignore", invalid="ignore"):  # GEOS on near-degenerate legs
        ends = shapely.get_coordinates(shapely.shortest_line(shapely.Polygon(part), legs))
    step = ends[1::2] - ends[0::2]  # part → leg
    gap = np.linalg.norm(step, axis=1)
    tiny = 1e-9 * max(1.0, float(np.max(np.abs(part))))
    ok = np.isfinite(gap) & (gap > tiny)
    u = np.zeros((len(a), 2))
    u[ok] = step[ok] / gap[ok, None]
    if not np.all(ok):  # counter-clockwise part: outward normal of edge v→w is (w − v) rotated −90°
        edge = np.roll(part, -1, axis=0) - part
        edge = edge[np.linalg.norm(edge, axis=1) > 0.0]  # a repeated vertex has no normal
        normals = np.stack([edge[:, 1], -edge[:, 0]], axis=1)
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        h = support_m(part, normals)  # (E,)
        score = np.minimum(a[~ok] @ normals.T, b[~ok] @ normals.T) - h[None, :]
        best = np.argmax(score, axis=1)
        u[~ok] = normals[best]
        gap[~ok] = score[np.arange(len(best)), best]
    return u, gap


def outward_simplified(vertices_xy_m: ArrayLike, tolerance_m: float,
                       max_vertices: int) -> NDArray[np.float64]:
    """Vertices (P, 2), counter-clockwise, of a simple polygon of at most ``max_vertices``
    (>= 4) holding the polygon ``vertices_xy_m``: coarsened outward only, a zone never shrinks.

    The polygon is grown by a tolerance (mitred) and simplified by it (Douglas-Peucker), and
    the result kept only when it covers the original (checked, not assumed); the tolerance,
    from ``tolerance_m``, grows by half until the vertex count fits. The last resort is the
    smallest rotated rectangle round the polygon.
    """
    poly = orient(shapely.Polygon(np.asarray(vertices_xy_m, dtype=float)), 1.0)
    if len(poly.exterior.coords) - 1 <= max_vertices:
        return np.asarray(poly.exterior.coords, dtype=float)[:-1]
    x0, y0, x1, y1 = poly.bounds
    tol = max(tolerance_m, 1e-6 * math.hypot(x1 - x0, y1 - y0))
    for _ in range(60):
        grown = poly.buffer(tol, join_style="mitre", mitre_limit=2.0)
        out = shapely.simplify(grown, tol, preserve_topology=True)
        if isinstance(out, shapely.Polygon) and not out.is_empty:
            out = orient(shapely.Polygon(out.exterior), 1.0)
            if out.is_valid and out.covers(poly) and len(out.exterior.coords) - 1 <= max_vertices:
                return np.asarray(out.exterior.coords, dtype=float)[:-1]
        tol *= 1.5
    rect = orient(shapely.minimum_rotated_rectangle(poly), 1.0)
    return np.asarray(rect.exterior.coords, dtype=float)[:-1]
