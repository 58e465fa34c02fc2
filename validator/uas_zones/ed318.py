"""EUROCAE ED-318 GeoJSON: a FeatureCollection of UAS zones -> :class:`UasZone` s.

Field names as InterUSS's ``uas_standards.eurocae_ed318`` models them (version 4.4): each
Feature's ``properties`` are a ``UASZone`` (also accepted nested under ``"UASZone"``), its
``geometry`` a GeoJSON Polygon, MultiPolygon, Point with a Circle ``extent`` (radius in
metres), or a GeometryCollection of those, each carrying its vertical ``layer`` (or the
properties' ``verticalLayer``). The restriction is the zone's ``type``; ``USPACE`` airspace is
read as REQ_AUTHORISATION (a flight there needs a U-space service's authorisation).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from validator.errors import InputError
from validator.uas_zones import fields as fd
from validator.uas_zones.ed269 import MAX_ZONES
from validator.uas_zones.model import Limit, Period, UasZone, Volume

ED318_KEYS = ("zoneAuthority", "UASZone", "verticalLayer", "limitedApplicability")


def is_ed318(data: object) -> bool:
    """Whether a GeoJSON FeatureCollection holds ED-318 zones (not plain airspace)."""
    if not isinstance(data, dict) or data.get("type") != "FeatureCollection":
        return False
    features = data.get("features")
    return isinstance(features, list) and any(
        isinstance(f, dict) and isinstance(f.get("properties"), dict)
        and (any(k in f["properties"] for k in ED318_KEYS)
             or (isinstance(f.get("geometry"), dict) and "layer" in f["geometry"]))
        for f in features)


def parse_ed318(data: object, source: str) -> list[UasZone]:
    """The zones of a parsed ED-318 FeatureCollection; ``source`` names it in errors."""
    features = data.get("features") if isinstance(data, dict) else None
    if not isinstance(features, list):
        raise InputError(f"{source}: features: expected a list")
    if len(features) > MAX_ZONES:
        raise InputError(f"{source}: features: {len(features)} zones; at most {MAX_ZONES} "
                         "are supported")
    return [_feature(f, f"{source}: features[{i}]") for i, f in enumerate(features)]


def _feature(f: object, where: str) -> UasZone:
    if not isinstance(f, dict) or f.get("type") != "Feature":
        raise InputError(f"{where}: expected a GeoJSON Feature")
    props = f.get("properties")
    if not isinstance(props, dict):
        raise InputError(f"{where}.properties: expected a UASZone (an object)")
    if isinstance(props.get("UASZone"), dict):
        props = {**props, **props["UASZone"]}
    ident = fd.text(props, "identifier", f"{where}.properties", required=True)
    assert ident is not None
    where = f"{where} ({ident})"
    notes: list[str] = []
    kind = props.get("type")
    if kind == "USPACE":
        notes.append("USPACE airspace read as REQ_AUTHORISATION")
        kind = "REQ_AUTHORISATION"
    return UasZone(
        identifier=ident,
        name=_name(props.get("name"), f"{where}.properties.name") or ident,
        restriction=fd.restriction(kind, f"{where}.properties.type"),
        volumes=_volumes(f.get("geometry"), props.get("verticalLayer"), f"{where}.geometry"),
        where=where,
        conditions=fd.conditions(props.get("restrictionConditions"),
                                 f"{where}.properties.restrictionConditions"),
        periods=_periods(props.get("limitedApplicability"),
                         f"{where}.properties.limitedApplicability", notes),
        notes=tuple(notes),
    )


def _name(value: object, field: str) -> str | None:
    """A TextShort list ([{text, lang}]): the English text, else the first; or a string."""
    if value is None or isinstance(value, str):
        return value
    items = value if isinstance(value, list) else [value]
    texts = [(t.get("lang"), t.get("text")) for t in items if isinstance(t, dict)]
    texts = [(lang, s) for lang, s in texts if isinstance(s, str) and s]
    if len(texts) != len(items):
        raise InputError(f"{field}: expected texts [{{text, lang}}]")
    return next((s for lang, s in texts if lang == "en"), texts[0][1] if texts else None)


def _periods(value: object, field: str, notes: list[str]) -> tuple[Period, ...]:
    if value is None:
        return ()
    items = value if isinstance(value, list) else [value]
    out = []
    for i, p in enumerate(items):
        f = f"{field}[{i}]"
        if not isinstance(p, dict):
            raise InputError(f"{f}: expected a time period (an object)")
        start = fd.instant(p.get("startDateTime"), f"{f}.startDateTime")
        end = fd.instant(p.get("endDateTime"), f"{f}.endDateTime")
        if start is not None and end is not None and end < start:
            raise InputError(f"{f}.endDateTime: before startDateTime")
        out.append(Period(start, end, fd.schedule(p.get("schedule"), f"{f}.schedule", notes)))
    return tuple(out)


def _volumes(geom: object, layer: object, field: str) -> tuple[Volume, ...]:
    if not isinstance(geom, dict):
        raise InputError(f"{field}: expected a geometry")
    layer = geom.get("layer", layer)
    kind, coords = geom.get("type"), geom.get("coordinates")
    if kind == "GeometryCollection":
        members = geom.get("geometries")
        if not isinstance(members, list) or not members:
            raise InputError(f"{field}.geometries: expected a list of geometries")
        return tuple(v for k, g in enumerate(members)
                     for v in _volumes(g, layer, f"{field}.geometries[{k}]"))
    lower, upper = _layer(layer, f"{field}.layer")
    if kind == "Polygon":
        return (Volume(lower, upper, _ring(coords, f"{field}.coordinates")),)
    if kind == "MultiPolygon":
        if not isinstance(coords, list) or not coords:
            raise InputError(f"{field}.coordinates: expected a list of polygons")
        return tuple(Volume(lower, upper, _ring(p, f"{field}.coordinates[{k}]"))
                     for k, p in enumerate(coords))
    if kind == "Point":
        extent = geom.get("extent")
        if not isinstance(extent, dict) or extent.get("subType") != "Circle":
            raise InputError(f"{field}.extent: a Point zone needs a Circle extent (radius, m)")
        radius = fd.positive(extent.get("radius"), f"{field}.extent.radius")
        return (Volume(lower, upper, fd.positions([coords], f"{field}.coordinates"), radius),)
    raise InputError(f"{field}.type: a {kind} cannot be a zone (Polygon, MultiPolygon, "
                     "Point with a Circle extent, GeometryCollection)")


def _ring(rings: object, field: str) -> NDArray[np.float64]:
    if not isinstance(rings, list) or not rings:
        raise InputError(f"{field}: expected a list of linear rings")
    ring = fd.positions(rings[0], f"{field}[0]")  # holes dropped: the zone only grows
    if len({tuple(p) for p in ring.tolist()}) < 3:
        raise InputError(f"{field}[0]: a polygon needs at least 3 distinct positions")
    return ring


def _layer(layer: object, field: str) -> tuple[Limit, Limit]:
    if not isinstance(layer, dict):
        raise InputError(f"{field}: expected a vertical layer (upper, lower, their "
                         "references, uom)")
    factor = fd.uom_factor(layer.get("uom"), f"{field}.uom")
    lower = fd.limit(layer.get("lower"), layer.get("lowerReference"), factor,
                     f"{field}.lower", f"{field}.lowerReference", lower=True)
    upper = fd.limit(layer.get("upper"), layer.get("upperReference"), factor,
                     f"{field}.upper", f"{field}.upperReference", lower=False)
    if lower.reference == upper.reference and lower.value_m > upper.value_m:
        raise InputError(f"{field}.lower: above upper")
    return lower, upper
