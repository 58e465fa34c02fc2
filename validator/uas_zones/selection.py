"""The zones within reach of a site, out of a country-scale file, and the shapes they become.

A national file holds thousands of zones; a site needs the few near it. :class:`ZoneIndex`
holds a file's zones with a spatial index (shapely's STRtree over each volume's box in
degrees), built once per file; :func:`within_reach` asks it for the boxes meeting the site's
reach and keeps the zones that truly meet it (in the site's local metres). :func:`zone_shapes`
turns the volumes that apply into what the planner takes: circles stay circles, zones that
overlap are merged into one (their union, named ``A+B``; a circle joins as the polygon round
it), and a polygon of more than :data:`MAX_ZONE_VERTICES` is coarsened outward only
(:func:`validator.zones.outward_simplified`): a zone never shrinks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry.polygon import orient

from validator.errors import InputError
from validator.geodesy import LocalFrame
from validator.uas_zones.model import UasZone
from validator.zones import outward_simplified

REACH_MIN_M = 1_000.0  # the reach: this far round the site's home and nodes at least ...
REACH_FRACTION = 0.25  # ... or this share of their spread, for detours round large zones
MAX_ZONE_VERTICES = 64  # above this a zone is coarsened outward (planning cost, fence size)
SIMPLIFY_M = 1.0  # the least outward growth tried when coarsening (m)
CIRCLE_SIDES = 32  # a circle merged with another zone becomes this polygon round it
M_PER_DEG = 111_320.0  # a degree of latitude, rounded up (only for the index's boxes)


@dataclass(frozen=True, eq=False)
class ZoneIndex:
    """A file's zones and an STRtree over their volumes' boxes (lon/lat degrees);
    ``owner[i]`` is the zone of the tree's i-th box."""

    zones: tuple[UasZone, ...]
    tree: shapely.STRtree
    owner: NDArray[np.int64]


def zone_index(zones: list[UasZone]) -> ZoneIndex:
    boxes, owner = [], []
    for i, z in enumerate(zones):
        for v in z.volumes:
            lat, lon = v.lat_lon_deg[:, 0], v.lat_lon_deg[:, 1]
            pad_lat = pad_lon = 0.0
            if v.radius_m is not None:
                pad_lat = 1.01 * v.radius_m / M_PER_DEG
                pad_lon = pad_lat / max(math.cos(math.radians(float(lat[0]))), 1e-6)
            boxes.append((lon.min() - pad_lon, lat.min() - pad_lat,
                          lon.max() + pad_lon, lat.max() + pad_lat))
            owner.append(i)
    b = np.asarray(boxes, dtype=float).reshape(-1, 4)
    tree = shapely.STRtree(shapely.box(b[:, 0], b[:, 1], b[:, 2], b[:, 3]))
    return ZoneIndex(tuple(zones), tree, np.asarray(owner, dtype=np.int64))


def reach_area(points_m: NDArray[np.float64]) -> shapely.Polygon:
    """The site's reach in local metres: round its home and nodes by REACH_MIN_M, or by
    REACH_FRACTION of their spread when that is more."""
    hull = shapely.MultiPoint(np.asarray(points_m, dtype=float)).convex_hull
    x0, y0, x1, y1 = hull.bounds
    reach = max(REACH_MIN_M, REACH_FRACTION * math.hypot(x1 - x0, y1 - y0))
    return hull.buffer(reach, quad_segs=8)


def within_reach(index: ZoneIndex, frame: LocalFrame, area_m: shapely.Polygon) -> list[int]:
    """Indices (file order) of the zones with a volume meeting ``area_m`` (local metres)."""
    lat, lon = frame.to_geodetic(np.asarray(area_m.exterior.coords, dtype=float))
    box = shapely.box(float(np.min(lon)), float(np.min(lat)), float(np.max(lon)),
                      float(np.max(lat)))
    found = sorted(set(index.owner[index.tree.query(box)].tolist()))
    return [i for i in found if any(_meets(index.zones[i], k, frame, area_m)
                                    for k in range(len(index.zones[i].volumes)))]


def volume_shape(zone: UasZone, k: int, frame: LocalFrame) -> shapely.Geometry:
    """Volume k's footprint in local metres: a Point (a circle's centre) or a Polygon; an
    ambiguous polygon (one that crosses itself) is refused, naming the zone."""
    v = zone.volumes[k]
    xy = frame.to_local(v.lat_lon_deg[:, 0], v.lat_lon_deg[:, 1]).reshape(-1, 2)
    if v.radius_m is not None:
        return shapely.Point(xy[0])
    poly = shapely.Polygon(xy)
    if not poly.is_valid or poly.area <= 0.0:
        raise InputError(f"{zone.where}: volume {k}: the polygon is not simple "
                         f"({shapely.is_valid_reason(poly)}): which area is meant?")
    return orient(poly, 1.0)


def _meets(zone: UasZone, k: int, frame: LocalFrame, area: shapely.Polygon) -> bool:
    shape = volume_shape(zone, k, frame)
    radius = zone.volumes[k].radius_m
    if radius is not None:
        return bool(shapely.distance(area, shape) < radius)
    return bool(shapely.intersects(area, shape))


@dataclass(frozen=True, eq=False)
class ZoneShape:
    """A zone as the site takes it: a circle (``centre_m``, ``radius_m``) or a polygon
    (``vertices_m``), local metres; ``where`` names its source in errors."""

    name: str
    where: str
    centre_m: NDArray[np.float64] | None = None
    radius_m: float = 0.0
    vertices_m: NDArray[np.float64] | None = None

    def geometry(self) -> shapely.Polygon:
        """The zone as a polygon (a circle as the polygon round it)."""
        if self.vertices_m is not None:
            return shapely.Polygon(self.vertices_m)
        assert self.centre_m is not None
        r = self.radius_m / math.cos(math.pi / CIRCLE_SIDES)
        t = 2.0 * math.pi * np.arange(CIRCLE_SIDES) / CIRCLE_SIDES
        return shapely.Polygon(self.centre_m + r * np.column_stack([np.cos(t), np.sin(t)]))


def _overlap(a: ZoneShape, b: ZoneShape) -> bool:
    """Shared interior, as the site's own check judges it (touching is allowed)."""
    if a.vertices_m is None and b.vertices_m is None:
        assert a.centre_m is not None and b.centre_m is not None
        return bool(np.linalg.norm(a.centre_m - b.centre_m) < a.radius_m + b.radius_m)
    if a.vertices_m is not None and b.vertices_m is not None:
        return bool(shapely.intersection(a.geometry(), b.geometry()).area > 0.0)
    poly, circle = (a, b) if a.vertices_m is not None else (b, a)
    return bool(shapely.distance(poly.geometry(), shapely.Point(circle.centre_m))
                < circle.radius_m)


def merged(shapes: list[ZoneShape]) -> list[ZoneShape]:
    """Overlapping shapes merged into their union (holes filled), in a fixed order; each
    polygon coarsened outward to at most MAX_ZONE_VERTICES vertices."""
    n = len(shapes)
    group = list(range(n))

    def root(i: int) -> int:
        while group[i] != i:
            i = group[i]
        return i

    for j in range(n):
        for i in range(j):
            if root(i) != root(j) and _overlap(shapes[i], shapes[j]):
                group[max(root(i), root(j))] = min(root(i), root(j))
    out = []
    for r in sorted({root(i) for i in range(n)}):
        members = [shapes[i] for i in range(n) if root(i) == r]
        if len(members) == 1 and members[0].vertices_m is None:
            out.append(members[0])
            continue
        union = shapely.union_all([m.geometry() for m in members])
        if not isinstance(union, shapely.Polygon):  # overlapping shapes make one polygon
            union = union.convex_hull
        verts = np.asarray(orient(shapely.Polygon(union.exterior), 1.0).exterior.coords)[:-1]
        if len(verts) > MAX_ZONE_VERTICES:
            verts = outward_simplified(verts, SIMPLIFY_M, MAX_ZONE_VERTICES)
        name = "+".join(m.name for m in members)
        where = members[0].where if len(members) == 1 else \
            f"{members[0].where} merged with {', '.join(m.name for m in members[1:])}"
        out.append(ZoneShape(name, where, vertices_m=verts))
    return out
