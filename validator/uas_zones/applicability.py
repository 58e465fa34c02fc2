"""Whether a UAS zone applies to a flight: restriction, time window, height band, authorisation.

The flight band is the column from the ground to the site's flight altitude plus its safety
buffer (metres above the ground): the vehicle takes off, lands and climbs through it, and holds
its altitude only to within the buffer. AMSL limits become heights above the site's ground
through the origin's ``alt`` (ground elevation AMSL: the site is taken as flat); WGS84
(ellipsoid) limits need a geoid the site does not give, so such a volume is taken as applying.
The time window is [at, at + the mission's duration]: a zone active at any instant of it
applies, also one that becomes active while the vehicle flies. Without a time (no ``--at``)
every zone is taken as active. Checked in this order, the first that holds says why a zone is
not taken: NO_RESTRICTION ("no restriction"), not active ("inactive"), every volume above the
band ("above the ceiling") or below the ground ("below the floor"), REQ_AUTHORISATION or
CONDITIONAL named by ``--authorised`` ("authorised"). PROHIBITED is always taken.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from typing import Any

from validator.errors import InputError
from validator.uas_zones.model import Limit, UasZone

LIFTABLE = ("REQ_AUTHORISATION", "CONDITIONAL")  # what --authorised may lift


@dataclass(frozen=True)
class AirspaceOptions:
    """When the mission flies (``at``, aware; None: every zone taken as active) and for how
    long (``duration_s``), the zones it holds authorisations for (identifiers), and the safety
    buffer it keeps when not the site's (``buffer_m``, as ``plan-mission --buffer-m``)."""

    at: datetime | None = None
    duration_s: float = 0.0
    authorised: frozenset[str] = frozenset()
    buffer_m: float | None = None

    def buffer_or(self, site_buffer_m: float) -> float:
        return site_buffer_m if self.buffer_m is None else self.buffer_m

    def __post_init__(self) -> None:
        if self.at is not None and self.at.tzinfo is None:
            raise InputError(f"--at: {self.at.isoformat()} has no time zone (add Z or +hh:mm)")
        if not (self.duration_s >= 0.0 and math.isfinite(self.duration_s)):
            raise InputError(f"duration: {self.duration_s} s is not a duration")

    @property
    def window(self) -> tuple[datetime, datetime] | None:
        if self.at is None:
            return None
        return self.at, self.at + timedelta(seconds=self.duration_s)


def parse_at(text: str) -> datetime:
    """``--at``: an ISO-8601 date and time with its time zone."""
    try:
        at = datetime.fromisoformat(text)
    except ValueError:
        raise InputError(f"--at: {text!r} is not an ISO-8601 date and time") from None
    if at.tzinfo is None:
        raise InputError(f"--at: {text!r} has no time zone (add Z or +hh:mm)")
    try:
        # The zones are decided, in UTC, until the flight ends: up to a day later (the
        # longest mission, validator.flight.model.MAX_MISSION_S).
        at.astimezone(UTC) + timedelta(days=1)
    except OverflowError:
        raise InputError(f"--at: {text!r} is outside the calendar for a flight of up to a "
                         f"day (0001-01-01 to 9999-12-30 UTC)") from None
    return at


@dataclass(frozen=True)
class Band:
    """The flight's heights: from the ground to ``ceiling_agl_m`` above it; the ground is
    ``ground_amsl_m`` above mean sea level."""

    ceiling_agl_m: float
    ground_amsl_m: float

    def agl_m(self, limit: Limit) -> float | None:
        """A limit as height above the site's ground (None: WGS84, not known)."""
        if limit.reference == "AGL" or math.isinf(limit.value_m):
            return limit.value_m
        if limit.reference == "AMSL":
            return limit.value_m - self.ground_amsl_m
        return None


@dataclass(frozen=True)
class ZoneDecision:
    """One zone's verdict: ``taken`` (avoided and fenced) or ``why`` not; ``volumes`` the
    indices of its volumes that apply."""

    zone: UasZone
    taken: bool
    why: str
    volumes: tuple[int, ...] = ()
    notes: tuple[str, ...] = field(default=())

    def as_dict(self) -> dict[str, Any]:
        z = self.zone
        return {
            "zone": z.identifier, "name": z.name, "restriction": z.restriction,
            "taken": self.taken, "why": self.why,
            "limits": [f"{v.lower.text()} to {v.upper.text()}" for v in z.volumes],
            "conditions": list(z.conditions), "notes": list(z.notes + self.notes),
        }


def decide(zone: UasZone, band: Band, options: AirspaceOptions) -> ZoneDecision:
    """Whether ``zone`` applies to a flight in ``band`` under ``options`` (module doc)."""
    if zone.restriction == "NO_RESTRICTION":
        return ZoneDecision(zone, False, "no restriction")
    notes: list[str] = []
    window = options.window
    if window is not None and not zone.active_during(*window):
        return ZoneDecision(zone, False, "inactive")
    if window is None and zone.periods:
        notes.append("no --at given: taken as active")
    taken, above, below = [], 0, 0
    for k, v in enumerate(zone.volumes):
        lower, upper = band.agl_m(v.lower), band.agl_m(v.upper)
        if lower is None or upper is None:
            notes.append(f"volume {k}: WGS84 heights taken as applying")
        if lower is not None and lower > band.ceiling_agl_m:
            above += 1
        elif upper is not None and upper < 0.0:
            below += 1
        else:
            taken.append(k)
    if not taken:
        why = ("above the ceiling" if above and not below else
               "below the floor" if below and not above else "above the ceiling or below the floor")
        return ZoneDecision(zone, False, why, (), tuple(notes))
    if zone.restriction in LIFTABLE and zone.identifier in options.authorised:
        return ZoneDecision(zone, False, "authorised", (), tuple(notes))
    why = {"PROHIBITED": "prohibited", "REQ_AUTHORISATION": "requires authorisation",
           "CONDITIONAL": "conditional"}[zone.restriction]
    if zone.conditions:
        why += ": " + " / ".join(f'"{c}"' for c in zone.conditions)
    return ZoneDecision(zone, True, why, tuple(taken), tuple(notes))


def check_authorised(zones: list[UasZone], authorised: frozenset[str]) -> None:
    """Refuse an ``--authorised`` identifier that no zone has, or that names a zone no
    authorisation lifts (PROHIBITED, NO_RESTRICTION)."""
    by_id = {z.identifier: z for z in zones}
    for ident in sorted(authorised):
        z = by_id.get(ident)
        if z is None:
            raise InputError(f"--authorised {ident}: no zone of the airspace file(s) has this "
                             "identifier")
        if z.restriction not in LIFTABLE:
            raise InputError(f"--authorised {ident}: {z.where} is {z.restriction}; only "
                             f"{' and '.join(LIFTABLE)} zones can be authorised")
