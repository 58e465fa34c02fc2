"""Where a PX4 vehicle may fly through a waypoint: the swing region of a pass-through corner.

PX4 v1.15.4 does not round a corner it flies through inside NAV_ACC_RAD as the ``px4`` replay
does (:mod:`validator.motion.px4_mission`). On SIH flights of our plans
(``tests/data/px4-corners``: 12-60° turns) it passed within 0.1-0.4 m of the waypoint,
switched to the next one there and swung 0.6-1.3 m *outside* the turn before it settled on
the next leg (its L1 crossing point, ``PositionSmoothing::_getL1Point``); within
:data:`SWING_NEAR_M` of the waypoint every flown corner stayed within NAV_ACC_RAD of the two
legs, on either side, but one: a 16° turn, flown twice 1.54-1.56 m outside (NAV_ACC_RAD 1.5).
So a corner's swing region is the two legs within :data:`SWING_NEAR_M` of its waypoint,
widened by NAV_ACC_RAD plus :data:`SWING_MARGIN_M`, and a corner keeps a zone's buffer when its
swing region does (:func:`swing_clearance_m`).

The planner flies a PX4 plan through a corner only where this holds
(:mod:`mission_planner.optimize.corners`), and the validator's replay of a PX4 plan reports
every pass-through corner whose swing region reaches into a zone or its buffer
(:func:`swing_findings`). Positions are metres east/north of the site origin.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from validator.flight import Finding, Flight
from validator.geometry import leg_clearances
from validator.item_numbers import item_label
from validator.site import Site
from validator.zones import PolygonZone, polyline_clearance_m

SWING_NEAR_M = 15.0  # the stretch of each leg the swing is bounded on (as measured on SIH)
# beyond NAV_ACC_RAD: two flights of one plan swung 1.54 and 1.56 m outside a 16° turn (NAV_ACC_RAD
# 1.5), and SIH wandered up to 1.84 m off a transit's legs
SWING_MARGIN_M = 0.5


def swing_polyline(before_m: ArrayLike, corner_m: ArrayLike, after_m: ArrayLike,
                   near_m: float = SWING_NEAR_M) -> NDArray[np.float64]:
    """(3, 2) the two legs ``before_m`` → ``corner_m`` → ``after_m`` within ``near_m`` of the
    corner (each cut at its far end, or at ``near_m``)."""
    a, c, b = (np.asarray(p, dtype=float)[:2] for p in (before_m, corner_m, after_m))

    def toward(p: NDArray[np.float64]) -> NDArray[np.float64]:
        d = p - c
        n = float(np.hypot(*d))
        return p if n <= near_m else c + d * (near_m / n)

    return np.vstack([toward(a), c, toward(b)])


def zone_swing_clearances_m(
    before_m: ArrayLike, corner_m: ArrayLike, after_m: ArrayLike, acceptance_m: float,
    centres_m: ArrayLike, radii_m: ArrayLike, polygons: tuple[PolygonZone, ...] = (),
) -> NDArray[np.float64]:
    """(M + P,) least clearance (m, negative inside) of the corner's swing region from each
    circle (beyond ``radii_m``) and then each polygon (beyond its edge)."""
    pts = swing_polyline(before_m, corner_m, after_m)
    radii = np.asarray(radii_m, dtype=float).reshape(-1)
    circles = (np.min(leg_clearances(pts, centres_m, radii), axis=0) if radii.size
               else np.zeros(0))
    poly = np.array([polyline_clearance_m(z, pts)[0] for z in polygons])
    return (np.concatenate([np.asarray(circles, dtype=float).reshape(-1), poly])
            - swing_width_m(acceptance_m))


def swing_width_m(acceptance_m: float) -> float:
    """How far (m) off its legs PX4 may swing round a corner with NAV_ACC_RAD
    ``acceptance_m``: that plus :data:`SWING_MARGIN_M`."""
    return acceptance_m + SWING_MARGIN_M


def swing_clearance_m(
    before_m: ArrayLike, corner_m: ArrayLike, after_m: ArrayLike, acceptance_m: float,
    centres_m: ArrayLike, radii_m: ArrayLike, polygons: tuple[PolygonZone, ...] = (),
    polygon_clear_m: float = 0.0,
) -> float:
    """Least clearance (m) of the swing region of the corner at ``corner_m`` (NAV_ACC_RAD
    ``acceptance_m``) from the circles beyond ``radii_m`` and the polygons beyond
    ``polygon_clear_m``: negative where PX4 may come closer than that; +inf with no zones."""
    c = zone_swing_clearances_m(before_m, corner_m, after_m, acceptance_m, centres_m, radii_m,
                                polygons)
    n_circles = np.asarray(radii_m).size
    c[n_circles:] -= polygon_clear_m
    return float(np.min(c)) if c.size else float("inf")


def swing_keeps_buffer(before_m: ArrayLike, corner_m: ArrayLike, after_m: ArrayLike,
                       acceptance_m: float, site: Site) -> bool:
    """Whether PX4 may fly through the corner at ``corner_m`` (NAV_ACC_RAD ``acceptance_m``)
    with its swing region outside every zone's safety buffer: where it may not,
    :func:`swing_findings` lists the corner, and a plan stops there instead."""
    return swing_clearance_m(before_m, corner_m, after_m, acceptance_m, site.nfz_xy_m,
                             site.planning_radius_m, site.polygon_zones, site.buffer_m) >= 0.0


def swing_findings(flight: Flight, site: Site, acceptance_m: float,
                   tolerance_m: float) -> list[Finding]:
    """Every waypoint of ``flight`` a PX4 vehicle flies through whose swing region (NAV_ACC_RAD
    ``acceptance_m``) enters a zone (a violation) or its safety buffer (a warning)."""
    out: list[Finding] = []
    legs = flight.legs
    for k, leg in enumerate(legs[:-1]):
        nxt = legs[k + 1]
        if not leg.pass_through or leg.kind != "waypoint" or leg.length_m <= 0:
            continue
        if nxt.kind != "waypoint" or nxt.length_m <= 0:
            continue
        clr = zone_swing_clearances_m(leg.start_xy_m, leg.end_xy_m, nxt.end_xy_m, acceptance_m,
                                      site.nfz_xy_m, site.nfz_radius_m, site.polygon_zones)
        m = int(np.argmin(clr)) if clr.size else -1
        if m < 0 or clr[m] >= site.buffer_m - tolerance_m:
            continue
        name = site.zone_names[m]
        where = (f"PX4 flies through {item_label(leg.item)} (no hold) and may swing "
                 f"{swing_width_m(acceptance_m):g} m off its legs (NAV_ACC_RAD "
                 f"{acceptance_m:g} m + {SWING_MARGIN_M:g})")
        if clr[m] < -tolerance_m:
            out.append(Finding("violation", f"{where}: into {name} by {-clr[m]:.2f} m",
                               leg.item))
        else:
            out.append(Finding("warning", f"{where}: {clr[m]:.2f} m from {name}, inside its "
                               f"{site.buffer_m:g} m safety buffer", leg.item))
    return out
