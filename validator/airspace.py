"""An airspace file a site names with ``airspace:``: plain GeoJSON, ED-269 JSON or ED-318 GeoJSON.

:func:`read_airspace_file` tells the three apart by their content (an ED-269 document lists
zones without a GeoJSON ``type``; an ED-318 FeatureCollection's features carry UAS-zone
properties such as ``zoneAuthority`` or a vertical ``layer``) and reads each file once per
process (a country's file is large). UAS zones are
read by :mod:`validator.uas_zones`; what follows is the plain GeoJSON reader.

A plain FeatureCollection (RFC 7946, WGS84 longitude/latitude) as OpenAIP and national services
publish it: each Polygon feature is a zone, each part of a MultiPolygon a zone of its own
(named ``NAME/1``, ``NAME/2``...), a Point with a ``radius_m`` property a circle. The name is the
feature's ``name`` property (``features[i]`` without one). Holes are refused: a zone with a hole
would let the planner fly into the hole, which published airspace never means. Every mistake is
an :class:`~validator.errors.InputError` naming the file and the feature.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from validator.errors import InputError
from validator.input_files import check_tree, parse_json, read_text
from validator.uas_zones.ed269 import is_ed269, parse_ed269
from validator.uas_zones.ed318 import is_ed318, parse_ed318
from validator.uas_zones.selection import ZoneIndex, zone_index
from validator.zones import MAX_VERTICES

MAX_FEATURES = 1_000  # as many zones as a site may hold


@dataclass(frozen=True)
class AirspaceZone:
    """One zone of an airspace file: a circle (one point and ``radius_m``) or a polygon.

    ``lat_lon_deg`` is (P, 2) WGS84 degrees; ``where`` names the feature for error messages.
    """

    name: str
    where: str
    lat_lon_deg: NDArray[np.float64]
    radius_m: float | None = None


@dataclass(frozen=True)
class AirspaceFile:
    """An airspace file read: its ``format`` ("geojson", "ed269", "ed318") and its zones,
    ``plain`` for plain GeoJSON, ``uas`` (indexed) for ED-269 and ED-318."""

    path: str
    format: str
    plain: tuple[AirspaceZone, ...] = ()
    uas: ZoneIndex | None = None


_READ: dict[tuple[str, str], AirspaceFile] = {}
_READ_KEPT = 8  # files kept read (a site names one or a few)


def read_airspace_file(path: str | Path) -> AirspaceFile:
    """The airspace file ``path``, its format told from its content; parsed once while its
    content is unchanged (kept by path and a hash of the text: hashing is a small part of
    parsing a country's file, and a timestamp can miss a quick rewrite)."""
    text = read_text(path, "airspace")
    key = (str(path), hashlib.blake2b(text.encode("utf-8"), digest_size=16).hexdigest())
    if key not in _READ:
        if len(_READ) >= _READ_KEPT:
            del _READ[next(iter(_READ))]
        _READ[key] = _parse_airspace_file(str(path), text)
    return _READ[key]


def _parse_airspace_file(path: str, text: str) -> AirspaceFile:
    data = parse_json(text, path)
    if is_ed269(data):
        return AirspaceFile(path, "ed269", uas=zone_index(parse_ed269(data, path)))
    if is_ed318(data):
        return AirspaceFile(path, "ed318", uas=zone_index(parse_ed318(data, path)))
    return AirspaceFile(path, "geojson", plain=tuple(parse_airspace(data, path)))


def load_airspace(path: str | Path) -> list[AirspaceZone]:
    """The zones of the GeoJSON airspace file ``path``."""
    path = Path(path)
    return parse_airspace(parse_json(read_text(path, "airspace"), str(path)), str(path))


def parse_airspace(data: object, source: str) -> list[AirspaceZone]:
    """The zones of a parsed GeoJSON FeatureCollection; ``source`` names it in errors."""
    check_tree(data, source)
    if not isinstance(data, dict) or data.get("type") != "FeatureCollection":
        raise InputError(f"{source}: expected a GeoJSON FeatureCollection")
    features = data.get("features")
    if not isinstance(features, list):
        raise InputError(f"{source}: features: expected a list")
    if len(features) > MAX_FEATURES:
        raise InputError(f"{source}: features: {len(features)} features; at most "
                         f"{MAX_FEATURES} zones are supported")
    zones: list[AirspaceZone] = []
    for i, f in enumerate(features):
        zones += _feature(f, f"{source}: features[{i}]", f"features[{i}]")
    return zones


def _feature(f: object, where: str, default_name: str) -> list[AirspaceZone]:
    if not isinstance(f, dict) or f.get("type") != "Feature":
        raise InputError(f"{where}: expected a GeoJSON Feature")
    props = f.get("properties") or {}
    if not isinstance(props, dict):
        raise InputError(f"{where}.properties: expected a mapping")
    name = props.get("name", default_name)
    if not isinstance(name, str) or not name:
        raise InputError(f"{where}.properties.name: expected a non-empty string")
    where = f"{where} ({name})"
    geom = f.get("geometry")
    if not isinstance(geom, dict):
        raise InputError(f"{where}.geometry: expected a geometry")
    kind, coords = geom.get("type"), geom.get("coordinates")
    if kind == "Point":
        radius = props.get("radius_m")
        if isinstance(radius, bool) or not isinstance(radius, (int, float)) \
                or not math.isfinite(radius) or radius <= 0:
            raise InputError(f"{where}.properties.radius_m: a Point zone needs a radius_m > 0 "
                             "(m)")
        return [AirspaceZone(name, where, _positions([coords], f"{where}.geometry.coordinates"),
                             float(radius))]
    if kind == "Polygon":
        return [_polygon(coords, name, where, f"{where}.geometry.coordinates")]
    if kind == "MultiPolygon":
        if not isinstance(coords, list) or not coords:
            raise InputError(f"{where}.geometry.coordinates: expected a list of polygons")
        return [_polygon(p, f"{name}/{k + 1}", f"{where} part {k + 1}",
                         f"{where}.geometry.coordinates[{k}]") for k, p in enumerate(coords)]
    raise InputError(f"{where}.geometry: a {kind} cannot be a zone (Polygon, MultiPolygon, or "
                     "Point with radius_m)")


def _polygon(rings: object, name: str, where: str, field: str) -> AirspaceZone:
    if not isinstance(rings, list) or not rings:
        raise InputError(f"{field}: expected a list of linear rings")
    if len(rings) > 1:
        raise InputError(f"{field}: the polygon has {len(rings) - 1} hole(s); holes are not "
                         "supported (give the zone without them, or as separate zones)")
    ring = rings[0]
    if not isinstance(ring, list):
        raise InputError(f"{field}[0]: expected a list of positions")
    if len(ring) > MAX_VERTICES + 1:
        raise InputError(f"{field}[0]: {len(ring)} positions; at most {MAX_VERTICES} vertices "
                         "are supported")
    return AirspaceZone(name, where, _positions(ring, f"{field}[0]"))


def _positions(points: list[object], field: str) -> NDArray[np.float64]:
    """GeoJSON [lon, lat(, alt)] positions as (P, 2) [lat, lon] degrees."""
    out = np.empty((len(points), 2))
    for j, p in enumerate(points):
        if not isinstance(p, list) or len(p) not in (2, 3) or not all(
                isinstance(c, (int, float)) and not isinstance(c, bool) for c in p):
            raise InputError(f"{field}[{j}]: expected a position [lon, lat]")
        lon, lat = float(p[0]), float(p[1])
        if not (-180.0 <= lon <= 180.0 and -90.0 <= lat <= 90.0):
            raise InputError(f"{field}[{j}]: [{lon:g}, {lat:g}] is not a WGS84 [lon, lat]")
        out[j] = lat, lon
    return out
