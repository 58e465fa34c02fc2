"""The mission's geofence: an exclusion circle per circle zone (R + fence margin), an exclusion
polygon per polygon zone (its outline grown by the fence margin) and an optional inclusion area
around everything flown.

A polygon fence's vertices are written as the vehicle will hold them, on MAVLink's int32 1e-7°
grid: rounding moves each vertex by up to :data:`validator.geodesy.E7_ROUNDING_MAX_M` (0.8 cm),
which could cut an edge into the zone plus margin, so the outline is grown by
:data:`ROUNDING_ALLOWANCE_M` more and its containment checked after rounding
(:func:`exclusion_outline`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry.polygon import orient

from validator.autopilot.fence_storage import fits_ardupilot
from validator.geodesy import E7_ROUNDING_MARGIN_M, LocalFrame, round_e7
from validator.plan_format import FenceCircle, FencePolygon
from validator.site import Site
from validator.zones import (
    FENCE_ARC_STEP_DEG,
    PolygonZone,
    fence_outline_m,
    outward_simplified,
)

ROUNDING_ALLOWANCE_M = E7_ROUNDING_MARGIN_M  # the fence grown for MAVLink's 1e-7° rounding


def operating_area(points_m: ArrayLike, kind: str, margin_m: float) -> NDArray[np.float64]:
    """Vertices (V, 2), not closed, of an inclusion zone ``margin_m`` around the points.

    "polygon": the convex hull grown by the margin (mitred corners, bevelled when sharp), so
    the zone stays convex and every leg between points inside it stays inside. "circle": the
    smallest enclosing circle grown by the margin, returned as [[cx, cy], [radius, 0]].
    """
    hull = shapely.MultiPoint(np.asarray(points_m, dtype=float)).convex_hull
    if kind == "circle":
        radius = float(shapely.minimum_bounding_radius(hull))
        centre = shapely.minimum_bounding_circle(hull).centroid
        if radius == 0.0:
            centre = hull.centroid
        return np.array([[centre.x, centre.y], [radius + margin_m, 0.0]])
    # Simplifying a convex polygon keeps a subset of its vertices: still convex, and inside the
    # buffered hull by at most a quarter of the margin, so far fewer fence points suffice.
    area = hull.buffer(margin_m, join_style="mitre", mitre_limit=2.0).simplify(margin_m / 4.0)
    ring = shapely.get_coordinates(shapely.normalize(area).exterior)[:-1]
    return np.asarray(ring, dtype=float)


def _latlon(frame: LocalFrame, xy_m: NDArray[np.float64]) -> tuple[float, float]:
    lat, lon = frame.to_geodetic(xy_m)
    return float(lat), float(lon)


def exclusion_outline(zone: PolygonZone, margin_m: float, frame: LocalFrame,
                      arc_step_deg: float | None = FENCE_ARC_STEP_DEG
                      ) -> list[tuple[float, float]]:
    """(lat, lon) vertices on the 1e-7° grid of an exclusion fence holding every point within
    ``margin_m`` of ``zone``: :func:`validator.zones.fence_outline_m` (corners in chords of
    ``arc_step_deg``), grown by a rounding allowance (doubled until the rounded outline contains
    the zone plus margin)."""
    return _rounded(zone, margin_m, frame,
                    lambda extra: fence_outline_m(zone, margin_m + extra, arc_step_deg))


def coarse_outline(zone: PolygonZone, margin_m: float, frame: LocalFrame, max_vertices: int
                   ) -> list[tuple[float, float]]:
    """(lat, lon) vertices on the 1e-7° grid of an exclusion fence of about ``max_vertices``
    holding ``zone`` plus ``margin_m``: its mitred outline coarsened outward only
    (:func:`validator.zones.outward_simplified`), for a fence storage too small for more."""
    outline = outward_simplified(fence_outline_m(zone, margin_m, None), margin_m / 4.0,
                                 max_vertices)

    def grown(extra: float) -> NDArray[np.float64]:
        out = orient(shapely.Polygon(outline).buffer(extra, join_style="mitre",
                                                     mitre_limit=10.0), 1.0)
        return np.asarray(out.exterior.coords, dtype=float)[:-1]

    return _rounded(zone, margin_m, frame, grown)


def _rounded(zone: PolygonZone, margin_m: float, frame: LocalFrame,
             outline: Callable[[float], NDArray[np.float64]]) -> list[tuple[float, float]]:
    """``outline(extra)`` (local metres) on the 1e-7° grid, ``extra`` doubled from the rounding
    allowance until the rounded outline holds the zone plus margin."""
    extra = ROUNDING_ALLOWANCE_M
    for _ in range(8):
        lat, lon = frame.to_geodetic(outline(extra))
        lat, lon = round_e7(lat), round_e7(lon)
        held = shapely.Polygon(frame.to_local(lat, lon))
        if (held.is_valid and held.contains(zone.shape)
                and float(shapely.distance(held.exterior, zone.shape)) >= margin_m):
            return [(float(a), float(b)) for a, b in zip(lat, lon, strict=True)]
        extra *= 2.0
    raise AssertionError(f"no rounded fence outline of {zone.name} holds its {margin_m} m margin")


@dataclass(frozen=True)
class Geofence:
    """The fence of a mission: ``circles`` and ``polygons`` as the plan stores them, and
    ``area_m`` the inclusion area's local vertices (:func:`operating_area`), None without one."""

    circles: list[FenceCircle]
    polygons: list[FencePolygon]
    area_m: NDArray[np.float64] | None

    @classmethod
    def around(cls, site: Site, margin_m: float, flown_m: ArrayLike, area: str | None,
               area_margin_m: float, ardupilot: bool = True) -> Geofence:
        """An exclusion circle of radius R + ``margin_m`` per circle zone, an exclusion
        polygon holding each polygon zone plus ``margin_m`` (:func:`exclusion_outline`) and,
        when ``area`` is "polygon" or "circle", an inclusion zone ``area_margin_m`` around the
        points ``flown_m``. For ArduPilot the polygons' corners are coarsened as far as its
        fence storage needs (:func:`_exclusion_polygons`)."""
        frame = site.frame
        circles = [
            FenceCircle(*_latlon(frame, c), float(r + margin_m), inclusion=False)
            for c, r in zip(site.nfz_xy_m, site.nfz_radius_m, strict=True)
        ]
        polygons = _exclusion_polygons(site, margin_m, len(circles) + (area == "circle"),
                                       ardupilot)
        vertices_m: NDArray[np.float64] | None = None
        if area is not None:
            vertices_m = operating_area(flown_m, area, area_margin_m)
            if area == "circle":
                circles.append(FenceCircle(*_latlon(frame, vertices_m[0]),
                                           float(vertices_m[1, 0]), inclusion=True))
            else:
                lat, lon = frame.to_geodetic(vertices_m)
                vertices = [(float(a), float(b)) for a, b in zip(lat, lon, strict=True)]
                polygons.append(FencePolygon(vertices, inclusion=True))
        return cls(circles, polygons, vertices_m)


# Corner chords (deg) tried in turn until the fence fits ArduCopter's storage: the finest stands
# off the zone ~1.06 margins, 45° ~1.2, 90° ~1.4, mitred (None) up to 1.8. A coarser corner
# is still judged by the safety gate's replay against the fence, so it costs margin, never safety.
ARC_STEPS_DEG: tuple[float | None, ...] = (FENCE_ARC_STEP_DEG, 45.0, 90.0, None)


def _exclusion_polygons(site: Site, margin_m: float, circles: int,
                        ardupilot: bool) -> list[FencePolygon]:
    """An exclusion polygon per polygon zone, with the finest corners whose fence (beside
    ``circles`` circles and the return point) ArduCopter can store; when even mitred corners do
    not fit (many or large zones, as published airspace brings), the largest outlines are
    coarsened outward, a vertex at a time, until the fence fits (:func:`coarse_outline`); the
    coarsest when none does (the gate then says so). An inclusion polygon
    (``--operating-area polygon``) is not counted here: when it tips the fence over, the gate
    refuses the mission."""
    fences: list[FencePolygon] = []
    for step in ARC_STEPS_DEG:
        fences = [FencePolygon(exclusion_outline(z, margin_m, site.frame, step), inclusion=False)
                  for z in site.polygon_zones]
        if not ardupilot or fits_ardupilot([len(p.vertices_deg) for p in fences], circles, True):
            return fences
    caps = [len(p.vertices_deg) for p in fences]
    while not fits_ardupilot(caps, circles, True) and max(caps, default=0) > 4:
        caps[int(np.argmax(caps))] -= 1
    return [FencePolygon(coarse_outline(z, margin_m, site.frame, cap), inclusion=False)
            if cap < len(p.vertices_deg) else p
            for z, p, cap in zip(site.polygon_zones, fences, caps, strict=True)]
