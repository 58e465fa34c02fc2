"""The field readers ED-269 and ED-318 share: limits, positions, times, schedules, texts.

Published files depart from the standards' models (the Swiss sample writes limits as strings
or null, ``dailyPeriod`` for ``schedule``); what is unambiguous is read as meant, what is not
is refused with one line naming the zone and the field (:class:`~validator.errors.InputError`).
"""

from __future__ import annotations

import math
from datetime import UTC, datetime, time, tzinfo
from typing import TypeGuard

import numpy as np
from numpy.typing import NDArray

from validator.errors import InputError
from validator.uas_zones.model import (
    DAYS,
    FEET_M,
    OPEN_LIMIT,
    REFERENCES,
    RESTRICTIONS,
    DailyPeriod,
    Limit,
)

GROUND = ("SFC", "GND")  # a lower limit written as the surface
UNLIMITED = ("UNL", "UNLIMITED")  # an upper limit written as none


def is_number(v: object) -> TypeGuard[int | float]:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def positive(value: object, field: str) -> float:
    """A finite number > 0 (a radius)."""
    if is_number(value) and math.isfinite(value) and value > 0:
        return float(value)
    raise InputError(f"{field}: expected a number > 0")


def text(d: dict[str, object], key: str, where: str, *, required: bool = False) -> str | None:
    """A string field (None when absent or null, unless ``required``)."""
    v = d.get(key)
    if v is None:
        if required:
            raise InputError(f"{where}.{key}: missing")
        return None
    if not isinstance(v, str) or (required and not v.strip()):
        raise InputError(f"{where}.{key}: expected a non-empty string")
    return v


def restriction(value: object, field: str) -> str:
    """ED-269's spelling; ED-318's REQ_AUTHORIZATION (with a Z) is the same restriction."""
    if isinstance(value, str):
        v = value.strip().upper().replace("REQ_AUTHORIZATION", "REQ_AUTHORISATION")
        if v in RESTRICTIONS:
            return v
    raise InputError(f"{field}: {value!r} is not a restriction ({', '.join(RESTRICTIONS)})")


def conditions(value: object, field: str) -> tuple[str, ...]:
    """restrictionConditions: a string or a list of strings, quoted as published."""
    if value is None:
        return ()
    raw = value if isinstance(value, list) else [value]
    items = [c for c in raw if isinstance(c, str)]
    if len(items) != len(raw):
        raise InputError(f"{field}: expected a string or a list of strings")
    return tuple(c.strip() for c in items if c.strip())


def uom_factor(value: object, field: str) -> float:
    """Metres per unit: M / m or FT / ft."""
    if isinstance(value, str) and value.strip().upper() in ("M", "FT"):
        return FEET_M if value.strip().upper() == "FT" else 1.0
    raise InputError(f"{field}: {value!r} is not a unit of length (M or FT)")


def limit(value: object, reference: object, factor: float | None, field: str, ref_field: str,
          *, lower: bool) -> Limit:
    """A lower or upper limit. Null is the surface (lower) or no ceiling (upper); a number
    written as a string is read as that number; 99999 or more is no ceiling. A reference
    given is checked even beside a null limit: a mistake there says the file is not what we
    think it is."""
    if reference is not None and (not isinstance(reference, str)
                                  or reference.strip().upper() not in REFERENCES):
        raise InputError(f"{ref_field}: {reference!r} is not a vertical reference "
                         f"({', '.join(REFERENCES)})")
    if isinstance(value, str):
        word = value.strip().upper()
        if lower and word in GROUND:
            return Limit(0.0, "AGL")
        if not lower and word in UNLIMITED:
            return Limit(math.inf, "AGL")
        try:
            value = float(word)
        except ValueError:
            raise InputError(f"{field}: {value!r} is not a height (a number, or null)") from None
        if not math.isfinite(value):
            raise InputError(f"{field}: {value!r} is not a finite height")
    if value is None:
        return Limit(0.0, "AGL") if lower else Limit(math.inf, "AGL")
    if not is_number(value):
        raise InputError(f"{field}: {value!r} is not a height (a number, or null)")
    height = float(value)
    if not isinstance(reference, str) or reference.strip().upper() not in REFERENCES:
        raise InputError(f"{ref_field}: {reference!r} is not a vertical reference "
                         f"({', '.join(REFERENCES)})")
    if height >= OPEN_LIMIT:
        return Limit(math.inf, reference.strip().upper())
    if factor is None:
        raise InputError(f"{field}: a height needs its unit (uom M or FT)")
    return Limit(height * factor, reference.strip().upper())


def positions(ring: object, field: str) -> NDArray[np.float64]:
    """[lon, lat(, alt)] positions, as GeoJSON and the published files write them, as (P, 2)
    [lat, lon] degrees."""
    if not isinstance(ring, list) or not ring:
        raise InputError(f"{field}: expected a list of positions [lon, lat]")
    for j, p in enumerate(ring):
        if not isinstance(p, list) or len(p) not in (2, 3) or not all(map(is_number, p)):
            raise InputError(f"{field}[{j}]: expected a position [lon, lat]")
    xy = np.array([p[:2] for p in ring], dtype=float)
    bad = (np.abs(xy[:, 0]) > 180.0) | (np.abs(xy[:, 1]) > 90.0)
    if np.any(bad):
        j = int(np.argmax(bad))
        raise InputError(f"{field}[{j}]: [{xy[j, 0]:g}, {xy[j, 1]:g}] is not a WGS84 "
                         "[lon, lat]")
    return np.ascontiguousarray(xy[:, ::-1])


def instant(value: object, field: str) -> datetime | None:
    """An ISO-8601 date and time with its time zone (None when null)."""
    if value is None:
        return None
    try:
        t = datetime.fromisoformat(value) if isinstance(value, str) else None
    except ValueError:
        t = None
    if t is None:
        raise InputError(f"{field}: {value!r} is not an ISO-8601 date and time")
    if t.tzinfo is None:
        raise InputError(f"{field}: {value!r} has no time zone (Z or +hh:mm): ambiguous")
    return t


def clock(value: object, field: str, *, end: bool) -> tuple[time, tzinfo]:
    """A time of day with its zone ("08:00Z", "08:00:00.00+01:00"); 24:00 ends the day."""
    if isinstance(value, str) and value.strip().startswith("24:00") and end:
        return clock("23:59:59.999999" + value.strip()[5:].lstrip(":0."), field, end=False)
    try:
        t = time.fromisoformat(value.strip()) if isinstance(value, str) else None
    except ValueError:
        t = None
    if t is None:
        raise InputError(f"{field}: {value!r} is not a time of day (hh:mm[:ss] and its zone)")
    if t.tzinfo is None:
        raise InputError(f"{field}: {value!r} has no time zone (Z or +hh:mm): ambiguous")
    return t.replace(tzinfo=None), t.tzinfo


def days(value: object, field: str) -> frozenset[int]:
    items = value if isinstance(value, list) else [value]
    out: set[int] = set()
    for d in items:
        if d == "ANY":
            return frozenset(range(7))
        if d not in DAYS:
            raise InputError(f"{field}: {d!r} is not a day ({', '.join(DAYS)} or ANY)")
        out.add(DAYS.index(d))
    if not out:
        raise InputError(f"{field}: no day given")
    return frozenset(out)


def schedule(value: object, field: str, notes: list[str]) -> tuple[DailyPeriod, ...]:
    """A schedule: daily periods. ED-318's sunrise and sunset events (startEvent, endEvent)
    are taken as the day's start and end: the zone is then active for longer, never less."""
    if value is None or value == []:
        return ()
    if not isinstance(value, list):
        raise InputError(f"{field}: expected a list of daily periods")
    out = []
    for i, d in enumerate(value):
        f = f"{field}[{i}]"
        if not isinstance(d, dict):
            raise InputError(f"{f}: expected a daily period")
        if all(d.get(k) in (None, []) for k in ("day", "startTime", "endTime", "startEvent",
                                                 "endEvent")):
            # an empty placeholder, as the public Swiss ED-269 sample writes beside
            # permanent YES: it says nothing, so it restricts nothing
            notes.append(f"{f}: an empty daily period (no day, no times), ignored")
            continue
        start, end = d.get("startTime"), d.get("endTime")
        a = b = None
        if start is not None or d.get("startEvent") is None:
            a, tz_a = clock(start, f"{f}.startTime", end=False)
        if end is not None or d.get("endEvent") is None:
            b, tz_b = clock(end, f"{f}.endTime", end=True)
        if a is None:
            notes.append(f"{f}.startEvent {d['startEvent']} taken as the day's start")
            a, tz_a = time(0), tz_b if b is not None else UTC
        if b is None:
            notes.append(f"{f}.endEvent {d['endEvent']} taken as the day's end")
            b, tz_b = time(23, 59, 59, 999999), tz_a
        if tz_a.utcoffset(None) != tz_b.utcoffset(None):
            raise InputError(f"{f}: startTime and endTime are in different time zones")
        out.append(DailyPeriod(days(d.get("day"), f"{f}.day"), a, b, tz_a))
    return tuple(out)
