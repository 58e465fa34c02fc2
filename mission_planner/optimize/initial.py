"""A feasible starting point for Algorithm 1 (the paper gives none).

A closed tour through the GNs (shortest visiting order), bent around every NFZ, with a few
hovering slots at each GN and the rest spread evenly along the tour, slot lengths T/N. Every
point keeps outside the expanded radius √(R² + (V T/(2N))²), so the start satisfies the
proposed constraint (6) — and with it the point-only constraint (5) — and every SCA step from it
stays feasible.

Polygon zones are laid out as the zone plus its clearance (mitred, so their outline has the
zone's few corners) and the tour walks round them like round the circles; the tour's slots are
then spread so that every corner of such an outline is a slot position, and each leg runs along
the outline: the whole leg keeps the polygon's clearance, as the proposed rule requires of every
leg (and only the polygons' corners, not the circles' many outline vertices, cost slots).
When the tour is too long to fly in T, it is shrunk towards a safe hub near the
GNs; the last resort is hovering at the hub.
"""

from __future__ import annotations

import itertools

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.ops import nearest_points, unary_union

from mission_planner.optimize.scaled import Scaled
from validator.errors import InputError
from validator.geometry import expanded_radius
from validator.zones import FENCE_MITRE_LIMIT, leg_separation

QUAD_SEGS = 16  # polygon segments per quarter circle
CLEAR_FACTOR = 1.05  # how far outside the expanded radius the tour is laid
POLYGON_LAY = 0.01  # and outside a polygon's clearance: 1 m more (100 m units)


def visiting_order(points: NDArray[np.float64]) -> list[int]:
    """Shortest closed visiting order: exact up to 8 points, else nearest neighbour + 2-opt."""
    k = len(points)
    dist = np.linalg.norm(points[:, None] - points[None, :], axis=-1)

    def length(order: list[int]) -> float:
        return float(sum(dist[order[i - 1], order[i]] for i in range(len(order))))

    if k <= 8:
        best = min(([0, *p] for p in itertools.permutations(range(1, k))), key=length)
        return list(best)
    order = [0]
    while len(order) < k:
        rest = [j for j in range(k) if j not in order]
        order.append(min(rest, key=lambda j: dist[order[-1], j]))
    improved = True
    while improved:
        improved = False
        for i in range(1, k - 1):
            for j in range(i + 1, k):
                cand = order[:i] + order[i : j + 1][::-1] + order[j + 1 :]
                if length(cand) < length(order) - 1e-12:
                    order, improved = cand, True
    return order


def _zones(centres: NDArray[np.float64], radii: NDArray[np.float64]) -> BaseGeometry:
    """Union of the circles as polygons whose edges stay outside the true circles."""
    step = np.pi / (2 * QUAD_SEGS)
    return unary_union(
        [
            Point(c).buffer(r / np.cos(step / 2), quad_segs=QUAD_SEGS)
            for c, r in zip(centres, radii, strict=True)
        ]
    )


def _polygon_zones(sc: Scaled, lay: float) -> BaseGeometry:
    """Union of the polygon zones, each grown by ``lay`` with mitred corners."""
    if not sc.parts:
        return Polygon()
    zones = shapely.union_all([Polygon(p) for p in sc.parts])
    return zones.buffer(lay, join_style="mitre", mitre_limit=FENCE_MITRE_LIMIT)


def _push_out(p: NDArray[np.float64], zones: BaseGeometry) -> NDArray[np.float64]:
    """The point itself if outside ``zones``, else the nearest point just outside them."""
    pt = Point(p)
    if zones.is_empty or not zones.contains(pt):
        return p
    for poly in getattr(zones, "geoms", [zones]):
        if poly.contains(pt):
            edge = np.asarray(nearest_points(poly.exterior, pt)[0].coords[0])
            out = edge - p
            return np.asarray(edge + 1e-6 * out / max(float(np.hypot(*out)), 1e-12), dtype=float)
    return p


def _around(
    a: NDArray[np.float64], b: NDArray[np.float64], poly: Polygon
) -> list[NDArray[np.float64]]:
    """Boundary vertices of ``poly`` that replace a chord a→b through it, the shorter way."""
    ring = LineString(poly.exterior.coords)
    hits = LineString([a, b]).intersection(poly.exterior)
    pts = [np.asarray(g.coords[0]) for g in getattr(hits, "geoms", [hits]) if not g.is_empty]
    if len(pts) < 2:
        return []
    pts.sort(key=lambda x: float(np.hypot(*(x - a))))
    s0, s1 = ring.project(Point(pts[0])), ring.project(Point(pts[-1]))
    total = ring.length
    coords = np.asarray(ring.coords)[:-1]
    at = np.array([ring.project(Point(c)) for c in coords])
    fwd = (s1 - s0) % total
    if fwd <= total / 2:
        rel = (at - s0) % total
        chosen = coords[np.argsort(rel)][np.sort(rel) < fwd]
    else:
        rel = (s0 - at) % total
        chosen = coords[np.argsort(rel)][np.sort(rel) < total - fwd]
    return [pts[0], *chosen, pts[-1]]


def _bend(loop: list[NDArray[np.float64]], zones: BaseGeometry) -> list[NDArray[np.float64]]:
    """Closed polyline with every leg that cuts a zone replaced by a walk round its boundary."""
    if zones.is_empty:
        return loop
    polys = list(getattr(zones, "geoms", [zones]))
    out: list[NDArray[np.float64]] = []
    for i, a in enumerate(loop):
        b = loop[(i + 1) % len(loop)]
        out.append(a)
        leg = LineString([a, b])
        crossed = [p for p in polys if leg.crosses(p) or leg.within(p)]
        crossed.sort(key=lambda p: leg.project(p.centroid))
        for poly in crossed:
            out.extend(_around(a, b, poly))
    return out


def _resample(loop: list[NDArray[np.float64]], count: int) -> NDArray[np.float64]:
    """``count`` points evenly spaced by arc length along a closed polyline, from loop[0]."""
    pts = np.array([*loop, loop[0]])
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    cum = np.r_[0.0, np.cumsum(seg)]
    targets = np.arange(count) * cum[-1] / count
    x = np.interp(targets, cum, pts[:, 0])
    y = np.interp(targets, cum, pts[:, 1])
    return np.stack([x, y], axis=1)


def _resample_corners(
    loop: list[NDArray[np.float64]], corner: NDArray[np.bool_], spacing: float
) -> NDArray[np.float64]:
    """Points along a closed polyline from loop[0], at most ``spacing`` apart along it, with every
    vertex marked ``corner`` among them: the stretch between two such vertices is split evenly."""
    pts = np.array([*loop, loop[0]])
    cum = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]
    marks = [0, *(i for i in range(1, len(loop)) if corner[i]), len(loop)]
    out = []
    for a, b in zip(marks[:-1], marks[1:], strict=True):
        length = cum[b] - cum[a]
        count = int(np.ceil(length / spacing)) if length > 0 else 0
        targets = cum[a] + np.arange(count) * length / max(count, 1)
        out.append(np.stack([np.interp(targets, cum, pts[:, 0]),
                             np.interp(targets, cum, pts[:, 1])], axis=1))
    return np.concatenate(out)


def _hub(sc: Scaled, zones: BaseGeometry) -> NDArray[np.float64]:
    """A point outside the zones, as close as possible to the GNs' centroid."""
    centre = sc.gn.mean(axis=0)
    for ring in range(0, 400):
        cands = (
            [centre]
            if ring == 0
            else [
                centre + ring * 0.05 * np.array([np.cos(t), np.sin(t)])
                for t in np.linspace(0, 2 * np.pi, 16, endpoint=False)
            ]
        )
        for p in cands:
            if zones.is_empty or not zones.intersects(Point(p)):
                return np.asarray(p, dtype=float)
    raise InputError(
        f"uav.slots: in {sc.num_slots} slots of {sc.slot_s:g} s (uav.period {sc.period_s:g} s) "
        "a slot's straight leg is so long that the zones, expanded to keep every leg clear, "
        "cover the ground nodes: more slots or a shorter period")


def _feasible(sc: Scaled, q: NDArray[np.float64], delta: float, radii: NDArray[np.float64]) -> bool:
    legs = np.linalg.norm(q - np.roll(q, 1, axis=0), axis=1)
    if np.any(legs > sc.speed * delta * (1 - 1e-9)):
        return False
    if np.any(sc.air_excess(q - np.roll(q, 1, axis=0), np.full(len(q), delta))
              > -1e-9 * sc.speed * delta):
        return False
    prev = np.roll(q, 1, axis=0)
    for part in sc.parts:  # every leg, whole, keeps the clearance
        if np.any(leg_separation(part, prev, q)[1] < sc.clearance):
            return False
    if sc.num_nfzs == 0:
        return True
    d = np.linalg.norm(q[:, None, :] - sc.nfz[None, :, :], axis=-1)
    return bool(np.all(d >= radii[None, :]))


def initial_tour(sc: Scaled) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Positions of slots 1..N (N, 2) and slot lengths δ̃ (N,) satisfying (1)–(6)."""
    n = sc.num_slots
    delta = np.ones(n)
    r_exp = expanded_radius(sc.radius, sc.speed) if sc.num_nfzs else np.zeros(0)
    lay = r_exp * CLEAR_FACTOR
    zones = _zones(sc.nfz, lay)
    polygons = _polygon_zones(sc, sc.clearance * CLEAR_FACTOR + POLYGON_LAY)
    if not polygons.is_empty:
        zones = unary_union([zones, polygons])
    hub = _hub(sc, zones)
    order = visiting_order(sc.gn) if sc.num_gns > 1 else [0]
    # In wind a leg of any heading fits its slot at the speed the headwind leaves.
    speed = sc.speed if sc.wind is None else sc.speed - float(np.hypot(*sc.wind))
    for shrink in (1.0, 0.75, 0.5, 0.3, 0.15):
        stops = [_push_out(hub + shrink * (sc.gn[j] - hub), zones) for j in order]
        loop = _bend(stops, zones)
        if polygons.is_empty:
            pts = np.array([*loop, loop[0]])
            length = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
            travel = int(np.ceil(1.15 * length / speed)) if length > 0 else 0
            moving = _resample(loop, travel) if 0 < travel <= n else np.zeros((0, 2))
        else:
            outline = polygons.boundary
            corner = shapely.distance(outline, shapely.points(np.array(loop))) < 1e-9
            moving = _resample_corners(loop, corner, speed / 1.15)
            travel = len(moving)
        if travel > n:
            continue
        hover = n - travel
        per_stop = np.full(len(stops), hover // len(stops))
        per_stop[: hover % len(stops)] += 1
        q = _build(moving, stops, per_stop)
        q = np.array([_push_out(p, zones) for p in q])
        if _feasible(sc, q, 1.0, r_exp):
            return q, delta
    return np.tile(hub, (n, 1)), delta


def _build(
    moving: NDArray[np.float64],
    stops: list[NDArray[np.float64]],
    per_stop: NDArray[np.int64],
) -> NDArray[np.float64]:
    """The travel points ``moving`` (along the loop), with ``per_stop[i]`` extra copies at each
    stop."""
    travel = len(moving)
    out: list[NDArray[np.float64]] = []
    # Give each stop's hover copies to the travel point nearest it.
    nearest = [int(np.argmin(np.linalg.norm(moving - s, axis=1))) if travel else -1 for s in stops]
    for i in range(travel):
        out.append(moving[i])
        for j, idx in enumerate(nearest):
            if idx == i:
                out.extend([moving[i]] * int(per_stop[j]))
    if not travel:
        for j, s in enumerate(stops):
            out.extend([s] * int(per_stop[j]))
    # Rotate so the cycle starts right after the first GN's hover.
    return np.roll(np.array(out), -1, axis=0)
