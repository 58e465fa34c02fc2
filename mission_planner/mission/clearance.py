"""Exported legs kept clear of the zones after MAVLink's rounding: service waypoints nudged
out, transits planned around the zones with the export margin.

The optimiser keeps legs R + buffer away only up to solver tolerance, and MAVLink's int32
1e-7° coordinates move each point by up to :data:`validator.geodesy.E7_ROUNDING_MAX_M` (0.8 cm).
Each service leg closer than R + buffer + ``export_margin_m``
(:data:`validator.geodesy.E7_ROUNDING_MARGIN_M`, 1 cm) to a centre is pushed out by
translating its two waypoints away from that centre by the shortfall, repeated until every
leg clears (:func:`nudge_clear`);
shortfalls above ``max_nudge_m`` (5 cm) are not solver noise and are left for the safety gate
to refuse. Transits are planned around R + buffer + the same margin (:func:`safe_transits`).
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from mission_planner.mission.options import MissionOptions, leg_margin_m
from mission_planner.transit import (
    circle_sides,
    circumscribed_polygon,
    shortest_path_around_polygons,
    shortest_safe_path,
)
from validator.geometry import segment_point_closest_fraction, segment_point_distance
from validator.site import Site
from validator.zones import FENCE_ARC_STEP_DEG, PolygonZone, fence_outline_m


def nudge_clear(points_m: ArrayLike, centres_m: ArrayLike, radii_m: ArrayLike, *,
                target_margin_m: float, max_nudge_m: float, closed: bool = True,
                zones: tuple[PolygonZone, ...] = (),
                zone_clearance_m: float = 0.0) -> tuple[NDArray[np.float64], float]:
    """Push a polyline's points out so every leg keeps ``radii + target_margin_m`` from each
    centre, and ``zone_clearance_m + target_margin_m`` from each polygon of ``zones``.

    Only legs short of that by at most ``target_margin_m + max_nudge_m`` are moved: both their
    end points are translated away from the zone (along the normal through the leg's closest
    point: from the centre, or from the polygon's nearest point) by the shortfall, which raises
    the leg's distance from a circle or a convex part by at least as much; repeated until no
    leg is short. ``closed`` adds the leg from the last point back to the first. Returns the
    points and the largest distance any point moved (m).
    """
    pts = np.array(points_m, dtype=float)
    original = pts.copy()
    centres = np.asarray(centres_m, dtype=float).reshape(-1, 2)
    target = np.asarray(radii_m, dtype=float).reshape(-1) + target_margin_m
    if (centres.size == 0 and not zones) or len(pts) < 2:
        return pts, 0.0
    limit = target_margin_m + max_nudge_m
    for _ in range(100):
        a = pts
        b = np.roll(pts, -1, axis=0) if closed else pts[1:]
        a = a if closed else pts[:-1]
        pushes = _circle_pushes(a, b, centres, target, limit)
        pushes += _polygon_pushes(a, b, zones, zone_clearance_m + target_margin_m, limit)
        if not pushes:
            break
        move = np.zeros_like(pts)
        for k, push in pushes:
            u = push / float(np.hypot(*push))
            j = (k + 1) % len(pts) if closed else k + 1
            for idx in (k, j):
                if np.dot(move[idx], u) < np.dot(push, u):
                    move[idx] += push - np.dot(move[idx], u) * u
        pts = pts + move
    moved = float(np.max(np.linalg.norm(pts - original, axis=1)))
    return pts, moved


Push = tuple[int, NDArray[np.float64]]  # a leg and the vector its two end points move by


def _circle_pushes(a: NDArray[np.float64], b: NDArray[np.float64], centres: NDArray[np.float64],
                   target: NDArray[np.float64], limit: float) -> list[Push]:
    """(leg, push) for each leg a shortfall of at most ``limit`` short of a circle's target."""
    if not centres.size:
        return []
    d = segment_point_distance(a[:, None, :], b[:, None, :], centres[None, :, :])
    short = target[None, :] - d
    out = []
    for k, m in zip(*np.nonzero((short > 1e-9) & (short <= limit)), strict=True):
        t = float(segment_point_closest_fraction(a[k], b[k], centres[m]))
        u = a[k] + t * (b[k] - a[k]) - centres[m]
        norm = float(np.hypot(*u))
        u = u / norm if norm > 0 else np.array([1.0, 0.0])
        out.append((int(k), (short[k, m] + 1e-6) * u))
    return out


def _polygon_pushes(a: NDArray[np.float64], b: NDArray[np.float64],
                    zones: tuple[PolygonZone, ...], target_m: float,
                    limit: float) -> list[Push]:
    """(leg, push) for each leg short of a polygon zone's target by at most ``limit``; a leg
    inside a zone has no outward normal and is left to the safety gate."""
    out = []
    for zone in zones:
        for k in range(len(a)):
            leg = (shapely.LineString([a[k], b[k]]) if np.any(a[k] != b[k])
                   else shapely.Point(a[k]))
            d = float(shapely.distance(zone.shape, leg))
            short = target_m - d
            if d <= 0.0 or not 1e-9 < short <= limit:
                continue
            near, far = np.asarray(shapely.shortest_line(zone.shape, leg).coords, dtype=float)
            out.append((k, (short + 1e-6) * (far - near) / d))
    return out


def safe_transits(site: Site, home: NDArray[np.float64], start: NDArray[np.float64],
              end: NDArray[np.float64], opt: MissionOptions,
              problems: list[str]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Outbound (home → start) and return (end → home) transits around R + buffer + margin.

    A zone's radius is shrunk to the distance of an end point that lies closer than that, so
    the search can start there; the safety check judges whether that is still clear enough.
    """
    centres = site.nfz_xy_m
    ends = np.array([home, start, end])

    def radii_for(pair: NDArray[np.float64]) -> NDArray[np.float64]:
        r = site.planning_radius_m + leg_margin_m(site, opt)
        if centres.size == 0:
            return r
        d = np.min(np.linalg.norm(pair[:, None, :] - centres[None, :, :], axis=2), axis=0)
        return np.minimum(r, d * (1 - 1e-12))

    out = []
    for a, b, name in ((ends[0], ends[1], "outbound"), (ends[2], ends[0], "return")):
        try:
            if site.polygon_zones:
                out.append(_transit_round_polygons(site, a, b, radii_for(np.array([a, b])),
                                                   leg_margin_m(site, opt), opt.arc_step_deg))
            else:
                out.append(shortest_safe_path(a, b, centres, radii_for(np.array([a, b])),
                                              arc_step_deg=opt.arc_step_deg))
        except ValueError as err:
            problems.append(f"{name} transit: {err}; flying straight instead")
            out.append(np.array([a, b]))
    return out[0], out[1]


def _transit_round_polygons(site: Site, a: NDArray[np.float64], b: NDArray[np.float64],
                            radii_m: NDArray[np.float64], margin_m: float,
                            arc_step_deg: float) -> NDArray[np.float64]:
    """The shortest transit a → b outside every polygon zone grown by buffer + ``margin_m``
    (its mitred outline, :func:`~validator.zones.fence_outline_m`) and every circle of
    ``radii_m`` (as circumscribed chords). A zone closer than that to an end point is grown
    less, until the end point lies outside it, so the search can start there (the safety
    gate judges the result, as for circles)."""
    k = circle_sides(arc_step_deg)
    obstacles = []
    for c, r in zip(site.nfz_xy_m, radii_m, strict=True):
        d = float(min(np.hypot(*(a - c)), np.hypot(*(b - c))))
        r_fit = min(float(r), d * math.cos(math.pi / k) * (1 - 1e-9))
        obstacles.append(circumscribed_polygon(c, r_fit, k))
    ends = shapely.MultiPoint([a, b])
    for zone in site.polygon_zones:
        obstacles.append(_largest_outline_clear_of(zone, site.buffer_m + margin_m, ends))
    return shortest_path_around_polygons(a, b, obstacles)


TRANSIT_FINE_ARC_STEP_DEG = 10.0  # corners rounded this finely where an end point sits near one


def _largest_outline_clear_of(zone: PolygonZone, grow_m: float,
                              ends: shapely.MultiPoint) -> NDArray[np.float64]:
    """``zone``'s outline grown by ``grow_m``, or, where an end point lies within that, by the
    most that leaves the end points outside (to 1 mm): grown any less, a transit near an end
    point would cut into the buffer the end point itself still keeps.

    The outline's corners are chords standing off the rounded margin (up to 3.5 % at the
    fence's 30°); an end point the planner kept just beyond the buffer round a corner lies
    inside them, and shrinking the whole outline until it does not let the transit's last
    chord round that corner cut the buffer (harbour in 8 m/s from 45°: 3.33 m from the
    breakwater against a 3.43 m buffer). So such an outline is first rounded with 10° chords
    (0.4 % off: two 0.6 m legs there, where 3° chords made six of 0.2 m), and only then grown
    less."""
    for step in (FENCE_ARC_STEP_DEG, TRANSIT_FINE_ARC_STEP_DEG):
        outline = fence_outline_m(zone, grow_m, step)
        if not shapely.Polygon(outline).intersects(ends):
            return outline

    def clear(g: float) -> bool:
        return not shapely.Polygon(
            fence_outline_m(zone, g, TRANSIT_FINE_ARC_STEP_DEG)).intersects(ends)

    if not clear(0.0):
        raise ValueError(f"an end point lies inside {zone.name}")
    lo, hi = 0.0, grow_m
    while hi - lo > 1e-3:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if clear(mid) else (lo, mid)
    return fence_outline_m(zone, lo, TRANSIT_FINE_ARC_STEP_DEG)
