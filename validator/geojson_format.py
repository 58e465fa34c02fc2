"""A plan and its site as one GeoJSON FeatureCollection (RFC 7946: [lon, lat] degrees WGS84).

Features, each with a ``kind`` property: ``flown_path`` (LineString through every positional
mission item, home to home), ``service_trajectory`` (the planner's closed cycle from the
plan's ``nfzMission`` data, when present), ``waypoint`` (Point per positional item, with its
item number as QGroundControl shows it, index + 1 (:mod:`validator.item_numbers`), command and
hold), ``ground_node``, ``home`` (the plan's), ``home_set`` (Point per home a DO_SET_HOME puts
in force, where returns after that ``item`` (its number) fly: :meth:`Flight.homes_set`, with
its altitude above sea level and above the plan's home), ``nfz`` (the published zone),
``nfz_buffered`` (zone plus safety buffer; circles, then polygon zones), ``fence_exclusion`` /
``fence_inclusion`` (circles and polygons of the geofence; an exclusion polygon holding polygon
zones names them in ``zones``) and ``rally``. GeoJSON has no circles, so a circle is a Polygon
of ``CIRCLE_VERTICES`` points on it, with ``center`` and ``radius_m`` in its properties.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike
from shapely.geometry.polygon import orient

from validator.fence_geometry import local_fence
from validator.fileio import write_atomic
from validator.flight import Flight, resolve_flight
from validator.geodesy import LocalFrame
from validator.item_numbers import item_number
from validator.plan_format import EXTRA_KEY, Cmd, Plan
from validator.site import Site

CIRCLE_VERTICES = 72
_POSITION_COMMANDS = (Cmd.NAV_TAKEOFF, Cmd.NAV_WAYPOINT, Cmd.NAV_LAND, Cmd.NAV_LOITER_TIME,
                      Cmd.NAV_LOITER_TURNS, Cmd.NAV_LOITER_UNLIM)


def _lonlat(frame: LocalFrame, xy_m: ArrayLike) -> list[list[float]]:
    lat, lon = frame.to_geodetic(np.asarray(xy_m, dtype=float).reshape(-1, 2))
    return [[float(a), float(b)] for a, b in zip(lon, lat, strict=True)]


def _feature(geometry: dict[str, object], **props: object) -> dict[str, object]:
    return {"type": "Feature", "geometry": geometry, "properties": props}


def _circle(frame: LocalFrame, centre_m: ArrayLike, radius_m: float,
            **props: object) -> dict[str, object]:
    c = np.asarray(centre_m, dtype=float)
    ang = np.linspace(0.0, 2.0 * np.pi, CIRCLE_VERTICES, endpoint=False)
    ring = _lonlat(frame, np.c_[c[0] + radius_m * np.cos(ang), c[1] + radius_m * np.sin(ang)])
    ring.append(ring[0])
    centre = _lonlat(frame, c)[0]
    return _feature({"type": "Polygon", "coordinates": [ring]}, center=centre,
                    radius_m=float(radius_m), **props)


def _polygon(frame: LocalFrame, vertices_m: ArrayLike, **props: object) -> dict[str, object]:
    ring = _lonlat(frame, vertices_m)
    ring.append(ring[0])
    return _feature({"type": "Polygon", "coordinates": [ring]}, **props)


def plan_geojson(plan: Plan, site: Site, flight: Flight | None = None) -> dict[str, object]:
    """The FeatureCollection of ``plan`` flown at ``site`` (see the module doc); ``flight`` is
    ``plan`` resolved, resolved here if not given (without the planner's metadata, which the
    homes do not depend on: a trajectory alone is drawn, not checked)."""
    frame = site.frame
    flight = flight or resolve_flight(dataclasses.replace(plan, extra=None), site)
    feats: list[dict[str, object]] = []
    nav = [(i, it) for i, it in enumerate(plan.items) if it.command in _POSITION_COMMANDS]
    path = [[it.lon_deg, it.lat_deg] for _, it in nav]
    if len(path) >= 2:
        feats.append(_feature({"type": "LineString", "coordinates": path}, kind="flown_path"))
    extra = plan.extra or {}
    trajectory = extra.get("trajectory_m")
    if isinstance(trajectory, list) and len(trajectory) >= 2:
        feats.append(_feature({"type": "LineString",
                               "coordinates": _lonlat(frame, trajectory)},
                              kind="service_trajectory", scheme=extra.get("scheme"),
                              schedule=extra.get("schedule"), delta_s=extra.get("delta_s")))
    for i, it in nav:
        feats.append(_feature({"type": "Point", "coordinates": [it.lon_deg, it.lat_deg]},
                              kind="waypoint", item=item_number(i), command=int(it.command),
                              altitude_m=it.alt_m,
                              hold_s=it.params[0] if it.command == Cmd.NAV_WAYPOINT else None))
    for name, xy in zip(site.gn_names, site.gn_xy_m, strict=True):
        feats.append(_feature({"type": "Point", "coordinates": _lonlat(frame, xy)[0]},
                              kind="ground_node", name=name))
    feats.append(_feature({"type": "Point", "coordinates": _lonlat(frame, site.home_xy_m)[0]},
                          kind="home"))
    for item, home, _ in flight.homes_set():
        feats.append(_feature({"type": "Point", "coordinates": _lonlat(frame, home.xy_m)[0]},
                              kind="home_set", item=item_number(item), name=home.label,
                              altitude_amsl_m=plan.home_alt_m + home.alt_m,
                              altitude_above_plan_home_m=home.alt_m))
    for name, xy, r in zip(site.nfz_names, site.nfz_xy_m, site.nfz_radius_m, strict=True):
        feats.append(_circle(frame, xy, float(r), kind="nfz", name=name))
        if site.buffer_m > 0:
            feats.append(_circle(frame, xy, float(r + site.buffer_m), kind="nfz_buffered",
                                 name=name, buffer_m=site.buffer_m))
    for zone in site.polygon_zones:
        feats.append(_polygon(frame, zone.vertices_xy_m, kind="nfz", name=zone.name))
        if site.buffer_m > 0:
            grown = orient(zone.shape.buffer(site.buffer_m, quad_segs=CIRCLE_VERTICES // 4), 1.0)
            feats.append(_polygon(frame, np.asarray(grown.exterior.coords)[:-1],
                                  kind="nfz_buffered", name=zone.name, buffer_m=site.buffer_m))
    fence = local_fence(plan, frame)
    for centre, radius, inclusion in fence.circles:
        feats.append(_circle(frame, centre, radius,
                             kind="fence_inclusion" if inclusion else "fence_exclusion"))
    for p, (shape, _) in zip(plan.polygons, fence.polygons, strict=True):
        ring = [[lon, lat] for lat, lon in p.vertices_deg]
        ring.append(ring[0])
        held = [z.name for z in site.polygon_zones
                if not p.inclusion and shape.is_valid and shape.contains(z.shape)]
        feats.append(_feature({"type": "Polygon", "coordinates": [ring]},
                              kind="fence_inclusion" if p.inclusion else "fence_exclusion",
                              **({"zones": held} if held else {})))
    for lat, lon, alt in plan.rally:
        feats.append(_feature({"type": "Point", "coordinates": [lon, lat]}, kind="rally",
                              altitude_m=alt))
    return {"type": "FeatureCollection",
            "properties": {"site": site.name, "source": EXTRA_KEY if extra else None},
            "features": feats}


def dumps_geojson(data: dict[str, object]) -> str:
    """GeoJSON text with full double precision."""
    return json.dumps(data, indent=1, allow_nan=False) + "\n"


def write_geojson(plan: Plan, site: Site, path: str | Path) -> None:
    """Write :func:`plan_geojson` of ``plan`` to ``path`` atomically."""
    write_atomic(path, dumps_geojson(plan_geojson(plan, site)))
