"""Shortest safe transit between two points around no-fly zones: circles, and polygons.

Positions are metres in the site's local east/north frame. A path is a polyline (P, 2) whose
straight legs each keep at least ``radius`` from every circle centre.

The shortest path around disjoint discs is made of tangent segments and circle arcs, so we
search a visibility graph whose nodes are tangent points (from the two end points to each
circle, and the bitangents between circles) and whose edges are the unblocked tangent segments
plus the arcs between neighbouring tangent points on each circle. An autopilot flies straight
lines, so each arc in the answer is then replaced by chords of the circumscribed polygon: every
chord touches the circle at its midpoint and never enters it, and the chords before and after
an arc continue the tangent lines, so no corner is cut into the zone.

Among polygon zones (:func:`shortest_path_around_polygons`) the obstacles are polygons already
grown by the clearance, and circles join them as circumscribed polygons (the same chords): the
shortest path bends only at obstacle vertices, so the visibility graph of the vertices holds it.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from validator.geometry import segment_point_distance

T = TypeVar("T")

DEFAULT_ARC_STEP_DEG = 10.0  # a chord vertex sticks out r·(1/cos(5°) − 1) ≈ 0.4 % of r
_TOUCH_TOL_M = 1e-7  # float slack for a segment that is tangent to a circle by construction


@dataclass(frozen=True)
class _Node:
    xy: tuple[float, float]
    circle: int  # -1 for the start and goal
    angle: float  # polar angle (rad) on the circle, 0 for start and goal


def _clear(a: NDArray[np.float64], b: NDArray[np.float64], centres: NDArray[np.float64],
           radii: NDArray[np.float64]) -> bool:
    if radii.size == 0:
        return True
    d = segment_point_distance(a[None, :], b[None, :], centres)
    return bool(np.all(d >= radii - _TOUCH_TOL_M))


def _point_tangent_angles(p: NDArray[np.float64], c: NDArray[np.float64], r: float) -> list[float]:
    """Polar angles (rad, about ``c``) of the tangent points from ``p`` to circle (c, r)."""
    v = p - c
    dist = float(np.hypot(v[0], v[1]))
    base = math.atan2(v[1], v[0])
    alpha = math.acos(min(1.0, r / dist))
    return [base + alpha, base - alpha] if alpha > 0 else [base]


def _bitangents(ci: NDArray[np.float64], ri: float, cj: NDArray[np.float64],
                rj: float) -> list[tuple[float, float]]:
    """(angle on i, angle on j) of every common tangent segment of two circles."""
    v = cj - ci
    d = float(np.hypot(v[0], v[1]))
    base = math.atan2(v[1], v[0])
    out: list[tuple[float, float]] = []
    if d > abs(ri - rj):  # outer tangents: same normal at both ends
        a = math.acos((ri - rj) / d)
        out += [(base + a, base + a), (base - a, base - a)]
    if d > ri + rj:  # inner tangents: opposite normals
        a = math.acos((ri + rj) / d)
        out += [(base + a, base + a + math.pi), (base - a, base - a + math.pi)]
    return out


def _on_circle(c: NDArray[np.float64], r: float, angle: float) -> tuple[float, float]:
    return (float(c[0] + r * math.cos(angle)), float(c[1] + r * math.sin(angle)))


def _arc_clear(i: int, a0: float, sweep: float, centres: NDArray[np.float64],
               radii: NDArray[np.float64], step_rad: float) -> bool:
    """Whether the chord polygon of the arc on circle ``i`` stays out of every other circle."""
    pts = _arc_chords(centres[i], float(radii[i]), a0, sweep, step_rad)
    start = np.array(_on_circle(centres[i], float(radii[i]), a0))
    end = np.array(_on_circle(centres[i], float(radii[i]), a0 + sweep))
    poly = np.vstack([start, pts, end]) if len(pts) else np.vstack([start, end])
    others = np.arange(len(radii)) != i
    if not np.any(others):
        return True
    d = segment_point_distance(poly[:-1, None, :], poly[1:, None, :], centres[None, others, :])
    return bool(np.all(d >= radii[None, others] - _TOUCH_TOL_M))


def _arc_chords(c: NDArray[np.float64], r: float, a0: float, sweep: float,
                step_rad: float) -> NDArray[np.float64]:
    """Vertices of the circumscribed chords replacing the arc from angle ``a0`` by ``sweep``.

    The arc is cut into k equal pieces of angle φ ≤ ``step_rad``; vertex i sits at angle
    a0 + φ/2 + iφ and radius r / cos(φ/2), so each chord is tangent to the circle (distance r
    from ``c``) and the first and last chords lie on the tangent lines at the arc's ends.
    """
    if abs(sweep) < 1e-12:
        return np.zeros((0, 2))
    k = max(1, math.ceil(abs(sweep) / step_rad))
    phi = sweep / k
    rv = r / math.cos(phi / 2.0)
    angles = a0 + phi / 2.0 + phi * np.arange(k)
    return np.stack([c[0] + rv * np.cos(angles), c[1] + rv * np.sin(angles)], axis=1)


def drop_collinear(path_m: ArrayLike, tol_m: float = 1e-9) -> NDArray[np.float64]:
    """The polyline without interior points that lie on the straight line of their neighbours
    (within ``tol_m``) and without repeated points."""
    path = np.asarray(path_m, dtype=float)
    keep = [path[0]]
    for k in range(1, len(path) - 1):
        a, b, c = keep[-1], path[k], path[k + 1]
        if np.hypot(*(b - a)) <= tol_m:
            continue
        if segment_point_distance(a, c, b) <= tol_m:
            continue
        keep.append(b)
    if len(path) > 1:
        if np.hypot(*(path[-1] - keep[-1])) > tol_m or len(keep) == 1:
            keep.append(path[-1])
        else:
            keep[-1] = path[-1]
    return np.array(keep, dtype=float)


def path_length_m(path_m: ArrayLike) -> float:
    """Length (m) of a polyline."""
    path = np.asarray(path_m, dtype=float)
    return float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))) if len(path) > 1 else 0.0


def shortest_safe_path(
    start_m: ArrayLike,
    goal_m: ArrayLike,
    centres_m: ArrayLike,
    radii_m: ArrayLike,
    *,
    arc_step_deg: float = DEFAULT_ARC_STEP_DEG,
) -> NDArray[np.float64]:
    """Shortest polyline (P, 2) from ``start_m`` to ``goal_m`` keeping out of every circle.

    ``centres_m`` (M, 2) and ``radii_m`` (M,) are the zones to avoid, already including any
    buffer and margin; each straight leg of the answer keeps at least the radius from each
    centre. Arcs are flown as chords at most ``arc_step_deg`` apart (see the module doc), so
    the answer is at most a fraction 1/cos(step/2) − 1 longer than the true shortest path.
    Both ends must lie outside (or on) every circle. Raises ``ValueError`` if an end point is
    inside a circle or no path exists (the goal is walled in by overlapping circles).
    """
    start = np.asarray(start_m, dtype=float).reshape(2)
    goal = np.asarray(goal_m, dtype=float).reshape(2)
    centres = np.asarray(centres_m, dtype=float).reshape(-1, 2)
    radii = np.asarray(radii_m, dtype=float).reshape(-1)
    if not arc_step_deg > 0:
        raise ValueError(f"arc_step_deg must be > 0, got {arc_step_deg}")
    for name, p in (("start", start), ("goal", goal)):
        d = np.linalg.norm(centres - p, axis=1)
        inside = np.flatnonzero(d < radii - _TOUCH_TOL_M)
        if inside.size:
            m = int(inside[0])
            raise ValueError(
                f"{name} point lies inside circle {m} ({d[m]:.3f} m from its centre, "
                f"radius {radii[m]:.3f} m)"
            )
    if _clear(start, goal, centres, radii):
        return np.array([start, goal])

    step = math.radians(arc_step_deg)
    nodes: list[_Node] = [_Node((float(start[0]), float(start[1])), -1, 0.0),
                          _Node((float(goal[0]), float(goal[1])), -1, 0.0)]
    edges: dict[int, list[tuple[int, float, tuple[float, float] | None]]] = {}

    def add_node(circle: int, angle: float) -> int:
        nodes.append(_Node(_on_circle(centres[circle], float(radii[circle]), angle), circle, angle))
        return len(nodes) - 1

    def add_edge(u: int, v: int, cost: float, arc: tuple[float, float] | None = None) -> None:
        edges.setdefault(u, []).append((v, cost, arc))

    def try_segment(u: int, v: int) -> None:
        a, b = np.array(nodes[u].xy), np.array(nodes[v].xy)
        if _clear(a, b, centres, radii):
            length = float(np.hypot(*(b - a)))
            add_edge(u, v, length)
            add_edge(v, u, length)

    for m in range(len(radii)):
        for end in (0, 1):
            for ang in _point_tangent_angles(np.array(nodes[end].xy), centres[m], float(radii[m])):
                try_segment(end, add_node(m, ang))
        for j in range(m + 1, len(radii)):
            for ai, aj in _bitangents(centres[m], float(radii[m]), centres[j], float(radii[j])):
                try_segment(add_node(m, ai), add_node(j, aj))

    # Arcs between angularly neighbouring tangent points of each circle, both ways round.
    for m in range(len(radii)):
        on_m = sorted((nodes[k].angle % (2 * math.pi), k) for k in range(2, len(nodes))
                      if nodes[k].circle == m)
        if len(on_m) < 2:
            continue
        for idx, (a0, u) in enumerate(on_m):
            a1, v = on_m[(idx + 1) % len(on_m)]
            sweep = (a1 - a0) % (2 * math.pi)
            if sweep < 1e-12 or not _arc_clear(m, a0, sweep, centres, radii, step):
                continue
            cost = float(radii[m]) * sweep
            add_edge(u, v, cost, (a0, sweep))
            add_edge(v, u, cost, (a1, -sweep))

    prev = _shortest_path(edges)
    if prev is None:
        raise ValueError("no safe path between the points: the circles wall one of them in")

    pieces: list[NDArray[np.float64]] = [np.array([nodes[1].xy])]
    v = 1
    while v != 0:
        u, arc = prev[v]
        if arc is not None:
            chords = _arc_chords(centres[nodes[u].circle], float(radii[nodes[u].circle]),
                                 arc[0], arc[1], step)
            pieces.append(chords)
        pieces.append(np.array([nodes[u].xy]))
        v = u
    return drop_collinear(np.vstack(pieces[::-1]))


def circle_sides(arc_step_deg: float = DEFAULT_ARC_STEP_DEG) -> int:
    """How many chords of at most ``arc_step_deg`` go round a circle."""
    return max(3, math.ceil(360.0 / arc_step_deg))


def circumscribed_polygon(centre_m: ArrayLike, radius_m: float, k: int) -> NDArray[np.float64]:
    """Vertices (k, 2), counter-clockwise, of a regular k-gon whose every edge touches the
    circle (centre, radius): a path outside it keeps at least the radius from the centre."""
    phi = 2.0 * math.pi / k
    angles = phi * np.arange(k)
    rv = float(radius_m) / math.cos(phi / 2.0)
    c = np.asarray(centre_m, dtype=float)
    return np.stack([c[0] + rv * np.cos(angles), c[1] + rv * np.sin(angles)], axis=1)


def shortest_path_around_polygons(start_m: ArrayLike, goal_m: ArrayLike,
                                  obstacles_m: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """Shortest polyline (P, 2) from ``start_m`` to ``goal_m`` that never enters the interior
    of any obstacle polygon (vertices (V, 2) each; it may run along their edges).

    The shortest such path bends only at obstacle vertices, so Dijkstra on the visibility graph
    of the end points and every vertex finds it. Raises ``ValueError`` if an end point lies
    inside an obstacle or none exists.
    """
    start = np.asarray(start_m, dtype=float).reshape(2)
    goal = np.asarray(goal_m, dtype=float).reshape(2)
    shapes = [shapely.Polygon(o) for o in obstacles_m]
    for name, p in (("start", start), ("goal", goal)):
        for j, s in enumerate(shapes):
            if s.contains(shapely.Point(p)):
                raise ValueError(f"{name} point lies inside obstacle {j}")
    nodes = np.vstack([start, goal, *obstacles_m]) if obstacles_m else np.array([start, goal])
    n = len(nodes)
    iu, ju = np.triu_indices(n, 1)
    pairs = np.stack([nodes[iu], nodes[ju]], axis=1)
    long = np.hypot(*(pairs[:, 1] - pairs[:, 0]).T) > 0.0
    iu, ju, pairs = iu[long], ju[long], pairs[long]
    segs = shapely.linestrings(pairs)
    free = np.ones(len(segs), dtype=bool)
    for s in shapes:
        shapely.prepare(s)
        # a segment is blocked when it meets the obstacle's interior (its edges are free)
        free &= ~np.asarray(shapely.relate_pattern(segs, s, "T********"), dtype=bool)
    edges: dict[int, list[tuple[int, float, None]]] = {}
    for u, v, (a, b) in zip(iu[free].tolist(), ju[free].tolist(), pairs[free], strict=True):
        length = float(np.hypot(*(b - a)))
        edges.setdefault(u, []).append((v, length, None))
        edges.setdefault(v, []).append((u, length, None))
    prev = _shortest_path(edges)
    if prev is None:
        raise ValueError("no safe path between the points: the zones wall one of them in")
    order = [1]
    while order[-1] != 0:
        order.append(prev[order[-1]][0])
    return drop_collinear(nodes[order[::-1]])


def _shortest_path(edges: Mapping[int, list[tuple[int, float, T]]]
                   ) -> dict[int, tuple[int, T]] | None:
    """Dijkstra from node 0 to node 1 over ``edges`` (node -> [(next, length m, payload)]):
    for each node reached, the node it was reached from and the payload of that edge; None
    when node 1 cannot be reached."""
    dist = {0: 0.0}
    prev: dict[int, tuple[int, T]] = {}
    heap = [(0.0, 0)]
    while heap:
        du, u = heapq.heappop(heap)
        if u == 1:
            break
        if du > dist.get(u, math.inf):
            continue
        for v, cost, payload in edges.get(u, []):
            if du + cost < dist.get(v, math.inf) - 1e-12:
                dist[v] = du + cost
                prev[v] = (u, payload)
                heapq.heappush(heap, (du + cost, v))
    return prev if 1 in dist else None
