"""Exported legs kept clear of the zones after MAVLink's rounding: service waypoints nudged
out, transits planned around the zones with the export margin.

The optimiser keeps legs R + buffer away only up to solver tolerance, and MAVLink's int32
1e-7° coordinates move each point by up to ~0.8 cm. Each service leg closer than R + buffer +
``export_margin_m`` (1 cm) to a centre is pushed out by translating its two waypoints away
from that centre by the shortfall, repeated until every leg clears (:func:`nudge_clear`);
shortfalls above ``max_nudge_m`` (5 cm) are not solver noise and are left for the safety gate
to refuse. Transits are planned around R + buffer + the same margin (:func:`safe_transits`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mission_planner.mission.options import MissionOptions, leg_margin_m
from mission_planner.transit import shortest_safe_path
from validator.geometry import segment_point_closest_fraction, segment_point_distance
from validator.site import Site


def nudge_clear(points_m: ArrayLike, centres_m: ArrayLike, radii_m: ArrayLike, *,
                target_margin_m: float, max_nudge_m: float,
                closed: bool = True) -> tuple[NDArray[np.float64], float]:
    """Push a polyline's points out so every leg keeps ``radii + target_margin_m`` from each centre.

    Only legs short of that by at most ``target_margin_m + max_nudge_m`` are moved: both their
    end points are translated away from the centre (along the normal through the leg's closest
    point) by the shortfall, which raises the leg's distance by at least as much; repeated
    until no leg is short. ``closed`` adds the leg from the last point back to the first.
    Returns the points and the largest distance any point moved (m).
    """
    pts = np.array(points_m, dtype=float)
    original = pts.copy()
    centres = np.asarray(centres_m, dtype=float).reshape(-1, 2)
    target = np.asarray(radii_m, dtype=float).reshape(-1) + target_margin_m
    if centres.size == 0 or len(pts) < 2:
        return pts, 0.0
    limit = target_margin_m + max_nudge_m
    for _ in range(100):
        a = pts
        b = np.roll(pts, -1, axis=0) if closed else pts[1:]
        a = a if closed else pts[:-1]
        d = segment_point_distance(a[:, None, :], b[:, None, :], centres[None, :, :])
        short = target[None, :] - d
        fix = (short > 1e-9) & (short <= limit)
        if not np.any(fix):
            break
        move = np.zeros_like(pts)
        for k, m in zip(*np.nonzero(fix), strict=True):
            t = float(segment_point_closest_fraction(a[k], b[k], centres[m]))
            closest = a[k] + t * (b[k] - a[k])
            u = closest - centres[m]
            norm = float(np.hypot(*u))
            u = u / norm if norm > 0 else np.array([1.0, 0.0])
            push = (short[k, m] + 1e-6) * u
            j = (k + 1) % len(pts) if closed else k + 1
            for idx in (k, j):
                if np.dot(move[idx], u) < np.dot(push, u):
                    move[idx] += push - np.dot(move[idx], u) * u
        pts = pts + move
    moved = float(np.max(np.linalg.norm(pts - original, axis=1)))
    return pts, moved


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
            out.append(shortest_safe_path(a, b, centres, radii_for(np.array([a, b])),
                                          arc_step_deg=opt.arc_step_deg))
        except ValueError as err:
            problems.append(f"{name} transit: {err}; flying straight instead")
            out.append(np.array([a, b]))
    return out[0], out[1]
