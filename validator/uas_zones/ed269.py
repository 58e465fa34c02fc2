"""EUROCAE ED-269 JSON: a list of ``UASZoneVersion`` objects -> :class:`UasZone` s.

Field names as InterUSS's ``uas_standards.eurocae_ed269`` models them (version 4.4). Read as
the published files write them: the zones under ``features`` (InterUSS, Luxembourg), under
``UASZoneList`` (the Swiss sample) or as a bare list; ``schedule`` or ``dailyPeriod`` (an
empty one: all day); fields beyond the model (``zoneId``...) ignored; limits as numbers, as
numeric strings or null (the surface below, no ceiling above); positions [lon, lat] (the
model's comment says lat, lng; the files and GeoJSON do not); a polygon's holes dropped (the
zone only grows). A value that could mean two things is refused (:mod:`.fields`).
"""

from __future__ import annotations

import numpy as np

from validator.errors import InputError
from validator.uas_zones import fields as fd
from validator.uas_zones.model import Period, UasZone, Volume

MAX_ZONES = 100_000  # per file: a national file holds ~1,200 (Switzerland)


def is_ed269(data: object) -> bool:
    """Whether a parsed document is ED-269 (not GeoJSON): a zone list without a "type", or a
    bare list of zones (as some national feeds serve it)."""
    if isinstance(data, list):
        return bool(data) and all(isinstance(z, dict) and "geometry" in z
                                  and "identifier" in z for z in data)
    return isinstance(data, dict) and (
        "UASZoneList" in data
        or (isinstance(data.get("features"), list) and data.get("type") != "FeatureCollection"))


def parse_ed269(data: object, source: str) -> list[UasZone]:
    """The zones of a parsed ED-269 document; ``source`` names it in errors."""
    if isinstance(data, list):
        data = {"features": data}
    if not isinstance(data, dict):
        raise InputError(f"{source}: expected an ED-269 document (an object)")
    if "UASZoneList" in data and "features" in data:
        raise InputError(f"{source}: both UASZoneList and features: which zones are meant?")
    key = "UASZoneList" if "UASZoneList" in data else "features"
    raw = data.get(key)
    if not isinstance(raw, list):
        raise InputError(f"{source}: {key}: expected a list of zones")
    if len(raw) > MAX_ZONES:
        raise InputError(f"{source}: {key}: {len(raw)} zones; at most {MAX_ZONES} are supported")
    zones = [_zone(z, f"{source}: {key}[{i}]") for i, z in enumerate(raw)]
    return zones


def _zone(z: object, where: str) -> UasZone:
    if not isinstance(z, dict):
        raise InputError(f"{where}: expected a zone (an object)")
    ident = fd.text(z, "identifier", where, required=True)
    assert ident is not None
    where = f"{where} ({ident})"
    notes: list[str] = []
    geometry = z.get("geometry")
    if not isinstance(geometry, list) or not geometry:
        raise InputError(f"{where}.geometry: expected a list of airspace volumes")
    return UasZone(
        identifier=ident,
        name=fd.text(z, "name", where) or ident,
        restriction=fd.restriction(z.get("restriction"), f"{where}.restriction"),
        volumes=tuple(_volume(v, f"{where}.geometry[{k}]", notes)
                      for k, v in enumerate(geometry)),
        where=where,
        conditions=fd.conditions(z.get("restrictionConditions"),
                                 f"{where}.restrictionConditions"),
        periods=_applicability(z.get("applicability"), f"{where}.applicability", notes),
        notes=tuple(notes),
    )


def _applicability(value: object, field: str, notes: list[str]) -> tuple[Period, ...]:
    """The zone's periods; () when permanent (also when none is given: the safe reading)."""
    if value is None:
        return ()
    items = value if isinstance(value, list) else [value]
    periods = []
    for i, p in enumerate(items):
        f = f"{field}[{i}]"
        if not isinstance(p, dict):
            raise InputError(f"{f}: expected a time period (an object)")
        if "schedule" in p and "dailyPeriod" in p:
            raise InputError(f"{f}: both schedule and dailyPeriod: which is meant?")
        key = "dailyPeriod" if "dailyPeriod" in p else "schedule"
        daily = p.get(key)
        if isinstance(daily, dict):
            daily = [daily]
        permanent = p.get("permanent")
        if permanent not in (None, "YES", "NO"):
            raise InputError(f"{f}.permanent: {permanent!r} is not YES or NO")
        start = fd.instant(p.get("startDateTime"), f"{f}.startDateTime")
        end = fd.instant(p.get("endDateTime"), f"{f}.endDateTime")
        sched = fd.schedule(daily, f"{f}.{key}", notes)
        if permanent == "YES":
            if start is not None or end is not None or sched:
                raise InputError(f"{f}: permanent YES with a start, end or schedule: which "
                                 "is meant?")
            return ()
        if start is not None and end is not None and end < start:
            raise InputError(f"{f}.endDateTime: before startDateTime")
        periods.append(Period(start, end, sched))
    return tuple(periods)


def _volume(v: object, field: str, notes: list[str]) -> Volume:
    if not isinstance(v, dict):
        raise InputError(f"{field}: expected an airspace volume (an object)")
    factor = (fd.uom_factor(v["uomDimensions"], f"{field}.uomDimensions")
              if v.get("uomDimensions") is not None else None)
    lower = fd.limit(v.get("lowerLimit"), v.get("lowerVerticalReference"), factor,
                     f"{field}.lowerLimit", f"{field}.lowerVerticalReference", lower=True)
    upper = fd.limit(v.get("upperLimit"), v.get("upperVerticalReference"), factor,
                     f"{field}.upperLimit", f"{field}.upperVerticalReference", lower=False)
    if lower.reference == upper.reference and lower.value_m > upper.value_m:
        raise InputError(f"{field}.lowerLimit: above upperLimit")
    hp = v.get("horizontalProjection")
    f = f"{field}.horizontalProjection"
    if not isinstance(hp, dict):
        raise InputError(f"{f}: expected a Circle or a Polygon")
    if hp.get("type") == "Circle":
        radius = fd.positive(hp.get("radius"), f"{f}.radius")
        if factor is None:
            raise InputError(f"{field}.uomDimensions: the circle's radius needs its unit")
        centre = fd.positions([hp.get("center")], f"{f}.center")
        return Volume(lower, upper, centre, radius * factor)
    if hp.get("type") == "Polygon":
        rings = hp.get("coordinates")
        if not isinstance(rings, list) or not rings:
            raise InputError(f"{f}.coordinates: expected a list of linear rings")
        if len(rings) > 1:
            notes.append(f"{f}: {len(rings) - 1} hole(s) filled (the zone only grows)")
        ring = fd.positions(rings[0], f"{f}.coordinates[0]")
        if len(np.unique(ring, axis=0)) < 3:
            raise InputError(f"{f}.coordinates[0]: a polygon needs at least 3 distinct "
                             "positions")
        return Volume(lower, upper, ring)
    raise InputError(f"{f}.type: {hp.get('type')!r} is not Circle or Polygon")
