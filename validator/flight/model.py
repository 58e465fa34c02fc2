"""What a resolved plan is: the straight :class:`Leg` s the vehicle flies, the :class:`Home` in
force on each, the service cycle among them (:class:`CycleSpan`), what could not be resolved
(:class:`Finding`), all in one :class:`Flight`.

Positions are metres east/north of the site origin, altitudes metres above home; items are
0-based indices of the ``.plan``'s ``mission.items``; text names them by number
(:mod:`validator.item_numbers`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from validator.flight.service import ServicePlan
from validator.item_numbers import item_label, item_number
from validator.plan_format import Autopilot

LegKind = Literal["takeoff", "waypoint", "loiter", "rtl", "land"]
Severity = Literal["violation", "warning", "note"]
SAME_HOME_M = 0.5  # a DO_JUMP loop passing one DO_SET_HOME again sets one home unless it moved


@dataclass(frozen=True)
class Finding:
    """Something the validator reports about a plan. ``item`` is a 0-based item index or None;
    :meth:`as_dict` gives its number (:func:`validator.item_numbers.item_number`)."""

    severity: Severity
    message: str
    item: int | None = None

    def as_dict(self) -> dict[str, object]:
        return {"severity": self.severity,
                "item": None if self.item is None else item_number(self.item),
                "message": self.message}


@dataclass(frozen=True)
class Home:
    """Where a return (RTL, Return) lands: the plan's home, or where a mission's DO_SET_HOME
    (item ``set_by_item``) moved it (:mod:`validator.flight.home`). ``alt_m`` is its altitude
    above the plan's home: altitudes above home are reported against it."""

    xy_m: NDArray[np.float64]
    set_by_item: int | None = None  # None: the plan's own home
    alt_m: float = 0.0

    @property
    def label(self) -> str:
        return ("home" if self.set_by_item is None
                else f"home set by item {item_number(self.set_by_item)}")


@dataclass(frozen=True)
class Leg:
    """One straight leg the vehicle flies toward mission item ``item`` (its destination).

    Positions are metres east/north of the site origin, altitudes metres above home.
    ``first_item`` is the first item executed as part of this leg (e.g. the DO_CHANGE_SPEED
    that precedes the waypoint), so items ``first_item..item`` belong to it. ``speed_mps`` is
    the commanded horizontal speed in force (None: the autopilot's default). The vehicle stays
    ``hold_s`` seconds at the destination. ``pass_through`` is True when the autopilot may
    blend this leg into the next one (no hold, and the next leg is another waypoint leg).
    ``home`` is the home in force while the leg is flown (None: the flight's own home).
    """

    item: int
    first_item: int
    kind: LegKind
    start_xy_m: NDArray[np.float64]
    end_xy_m: NDArray[np.float64]
    start_alt_m: float
    end_alt_m: float
    speed_mps: float | None
    hold_s: float = 0.0
    loiter_radius_m: float = 0.0
    pass_through: bool = False
    home: Home | None = None

    @property
    def length_m(self) -> float:
        """Horizontal length (m)."""
        return float(np.hypot(*(self.end_xy_m - self.start_xy_m)))

    @property
    def label(self) -> str:
        return f"{item_label(self.item)} ({self.kind})"


@dataclass(frozen=True)
class CycleSpan:
    """Which legs form the service cycles, and how the cycle time is measured.

    The cycles start when the vehicle reaches the destination of ``start_leg`` (its hold
    counts; ``start_at_arrival``) or when ``start_leg`` begins, and end when ``end_leg``'s item
    completes (after its hold). ``source`` says where the span came from: ``"metadata"``,
    ``"jump"`` (a DO_JUMP loop) or ``"waypoints"`` (first to last waypoint after takeoff).
    """

    start_leg: int
    start_at_arrival: bool
    end_leg: int
    cycles: int
    source: str

    def start_s(
        self,
        start_s: NDArray[np.float64],
        reached_s: NDArray[np.float64],
        done_s: NDArray[np.float64],
    ) -> float:
        """When the first cycle starts (s; NaN if it never did), from the same leg times as
        :meth:`window_s`."""
        if self.start_at_arrival:
            return float(reached_s[self.start_leg])
        return float(done_s[self.start_leg - 1] if self.start_leg > 0 else start_s[0])

    def window_s(
        self,
        start_s: NDArray[np.float64],
        reached_s: NDArray[np.float64],
        done_s: NDArray[np.float64],
    ) -> tuple[float, float] | None:
        """When the cycles start and end (s), from each leg's start, arrival and completion
        times (a :class:`~validator.replay.Track`'s, or the ideal timing's); None when either
        never happened or the span is empty."""
        start = self.start_s(start_s, reached_s, done_s)
        end = done_s[self.end_leg]
        if math.isnan(start) or math.isnan(end) or end <= start:
            return None
        return float(start), float(end)


@dataclass(frozen=True)
class Flight:
    """A plan resolved into legs (conventions: :mod:`validator.flight.resolve`); ``home_xy_m``
    is the plan's home, where it takes off (:meth:`home_of`: the home in force on a leg);
    ``source`` names the plan's file in errors about it."""

    legs: tuple[Leg, ...]
    home_xy_m: NDArray[np.float64]
    firmware_type: int
    findings: tuple[Finding, ...]
    cycle: CycleSpan | None
    service: ServicePlan | None
    fence_disabled_at: tuple[int, ...] = field(default=())
    source: str = "plan"

    @property
    def path_xy_m(self) -> NDArray[np.float64]:
        """The flown polyline (len(legs)+1, 2): the start of the first leg, then every leg end."""
        if not self.legs:
            return self.home_xy_m.reshape(1, 2).copy()
        pts = [self.legs[0].start_xy_m] + [leg.end_xy_m for leg in self.legs]
        return np.asarray(pts, dtype=float)

    def home_of(self, leg: int) -> Home:
        """The home in force on leg ``leg``: a return from it lands there (or at a rally point
        chosen against it); the plan's home until a DO_SET_HOME moves it."""
        return self.legs[leg].home or Home(self.home_xy_m)

    def homes_set(self) -> tuple[tuple[int, Home, tuple[int, ...]], ...]:
        """Each home a mission's DO_SET_HOME puts in force, in flight order: (the DO_SET_HOME's
        item, the home, the legs it is in force on, indices into :attr:`legs`): where returns
        from those legs fly (:meth:`home_of`). A DO_SET_HOME the autopilot would not take puts
        none in force, nor does one with no leg after it; one a DO_JUMP loop passes again is
        one home unless it moved :data:`SAME_HOME_M` or more."""
        out: list[tuple[int, Home, list[int]]] = []
        for k, leg in enumerate(self.legs):
            home = leg.home
            if home is None or home.set_by_item is None:
                continue
            at = next((i for i, (by, h, _) in enumerate(out) if by == home.set_by_item
                       and np.hypot(*(h.xy_m - home.xy_m)) < SAME_HOME_M), None)
            if at is None:
                out.append((home.set_by_item, home, []))
                at = len(out) - 1
            out[at][2].append(k)
        return tuple((by, home, tuple(legs)) for by, home, legs in out)

    @property
    def is_ardupilot(self) -> bool:
        return self.firmware_type == Autopilot.ARDUPILOTMEGA

