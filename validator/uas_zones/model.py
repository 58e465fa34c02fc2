"""One UAS geographical zone as published, in the units the planner needs.

ED-269 and ED-318 say the same things in two spellings; both readers produce a
:class:`UasZone`: an identifier (what ``--authorised`` names), a restriction in ED-269's
spelling, the conditions quoted as published, one or more :class:`Volume` (a circle or a
polygon in WGS84 degrees, between two :class:`Limit`), and the :class:`Period` s when it is
active (none: permanent). Heights are metres (feet converted exactly, 0.3048); an open
ceiling, written as null or as a sentinel of 99999 or more, is ``math.inf``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime, time, timedelta, tzinfo

import numpy as np
from numpy.typing import NDArray

FEET_M = 0.3048
OPEN_LIMIT = 99_999.0  # published files write "no ceiling" as 99999 (m or ft) or more
RESTRICTIONS = ("PROHIBITED", "REQ_AUTHORISATION", "CONDITIONAL", "NO_RESTRICTION")
REFERENCES = ("AGL", "AMSL", "WGS84")
DAYS = ("MON", "TUE", "WED", "THU", "FRI", "SAT", "SUN")


@dataclass(frozen=True)
class Limit:
    """A lower or upper limit: ``value_m`` metres (``math.inf`` open) above ``reference``."""

    value_m: float
    reference: str  # AGL, AMSL or WGS84 (the ellipsoid)

    def text(self) -> str:
        return "unlimited" if math.isinf(self.value_m) else f"{self.value_m:g} m {self.reference}"


@dataclass(frozen=True, eq=False)
class Volume:
    """One airspace volume: a circle (``lat_lon_deg`` its centre, ``radius_m``) or a polygon
    (``lat_lon_deg`` its outer ring, (P, 2) degrees), from ``lower`` to ``upper``."""

    lower: Limit
    upper: Limit
    lat_lon_deg: NDArray[np.float64]
    radius_m: float | None = None


@dataclass(frozen=True)
class DailyPeriod:
    """Active on ``days`` (0 = Monday) from ``start`` to ``end`` in ``tz``; an end at or before
    the start runs past midnight into the next day."""

    days: frozenset[int]
    start: time
    end: time
    tz: tzinfo

    def intervals(self, t0: datetime, t1: datetime) -> list[tuple[datetime, datetime]]:
        """The stretches of this schedule that begin on the days around [t0, t1]."""
        out = []
        day = t0.astimezone(self.tz).date() - timedelta(days=1)
        last = t1.astimezone(self.tz).date()
        while day <= last:
            if day.weekday() in self.days:
                a = datetime.combine(day, self.start, self.tz)
                b = datetime.combine(day, self.end, self.tz)
                if b <= a:
                    b += timedelta(days=1)
                out.append((a, b))
            day += timedelta(days=1)
        return out


@dataclass(frozen=True)
class Period:
    """Active from ``start`` to ``end`` (None: unbounded), on the ``schedule`` (empty: all
    day)."""

    start: datetime | None = None
    end: datetime | None = None
    schedule: tuple[DailyPeriod, ...] = ()

    def active_during(self, t0: datetime, t1: datetime) -> bool:
        """Whether the zone is active at any instant of [t0, t1] (aware datetimes)."""
        lo = t0 if self.start is None else max(t0, self.start)
        hi = t1 if self.end is None else min(t1, self.end)
        if hi < lo:
            return False
        if not self.schedule:
            return True
        return any(a <= hi and lo <= b for d in self.schedule for a, b in d.intervals(lo, hi))


@dataclass(frozen=True)
class UasZone:
    """A zone as published. ``periods`` empty means permanent; ``where`` names it in errors;
    ``notes`` say what the reader assumed (e.g. a sunrise taken as midnight)."""

    identifier: str
    name: str
    restriction: str
    volumes: tuple[Volume, ...]
    where: str
    conditions: tuple[str, ...] = ()
    periods: tuple[Period, ...] = ()
    notes: tuple[str, ...] = field(default=())

    def active_during(self, t0: datetime, t1: datetime) -> bool:
        return not self.periods or any(p.active_during(t0, t1) for p in self.periods)
