"""What a mission view shows (:class:`ViewInputs`): a plan on its site, the flights that flew
it, and the layers other checks know about when they ran (failsafe paths, wind).

Every layer past the plan and the site is optional, so a feature adds its layer by filling
one field, and the view draws only what it is given. Positions are metres east/north of the
site origin, times seconds from the takeoff, speeds m/s; a wind is :class:`validator.wind.Wind`
(the direction it blows FROM, degrees true).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from validator.failsafe import FailsafeCheck, FailsafeReport, PathFinding
from validator.flight import Flight
from validator.item_numbers import item_label
from validator.plan_format import Plan
from validator.replay import Track
from validator.site import Site
from validator.validation import Validation
from validator.wind import Wind

STILL_AIR = Wind(0.0, 0.0)


@dataclass(frozen=True)
class TrackLayer:
    """A flight in time: the model's replay or a flown track (SITL, a recorded flight).
    ``name`` is its legend entry, e.g. ``"replay (arducopter)"``."""

    name: str
    track: Track


@dataclass(frozen=True)
class FailsafePath:
    """A path the vehicle would fly on a failsafe (an RTL from some point, a fence breach
    return), as a failsafe audit checked it: ``xy_m`` (P, 2) is a ``line``, the outline of
    the ``region`` a family of paths sweeps, or the mission's own path it ``retrace``s;
    ``ok`` False when it enters a zone or its buffer."""

    name: str
    xy_m: NDArray[np.float64]
    ok: bool = True
    note: str = ""
    kind: Literal["line", "region", "retrace"] = "line"


@dataclass(frozen=True)
class FaultMark:
    """A fault injected in flight (``validate-mission --fault``) and the flight after it:
    where it was injected (``xy_m``), the track after it (``after_xy_m``, a point a second),
    whether that entered a zone, and what the autopilot did (``note``, for the hover)."""

    kind: str
    xy_m: NDArray[np.float64]
    after_xy_m: NDArray[np.float64]
    entered_zone: bool
    note: str


def fault_mark(fault: Mapping[str, Any]) -> FaultMark | None:
    """The view of a fault flight's report (:meth:`validator.mavlink.faults.FaultReport.as_dict`,
    the report's ``fault`` section); None when the fault was never injected."""
    from validator.mavlink.faults import fault_lines  # pymavlink, only for a fault flight

    if fault.get("injected_xy_m") is None:
        return None
    said = fault_lines(fault)
    after = np.asarray(fault["track_xy_m"], dtype=float).reshape(-1, 2)
    return FaultMark(fault["kind"], np.asarray(fault["injected_xy_m"], dtype=float), after,
                     bool(fault["entered_zone"]), "<br>".join(said))


@dataclass(frozen=True)
class ViewInputs:
    """Everything one view draws. ``flight`` is the plan resolved on the site
    (:func:`validator.flight.resolve_flight`); ``tracks`` are drawn in order and the first one
    leads the time slider's node and rate read-outs. ``wind`` is the air the tracks fly in
    and the plan was made for; ``planned_wind`` the one the plan was made for when that is
    another (:data:`STILL_AIR` for still air, as ``wind`` may be); ``fault`` a fault injected
    in the flown track's flight."""

    plan: Plan
    site: Site
    flight: Flight
    tracks: tuple[TrackLayer, ...] = ()
    failsafe_paths: tuple[FailsafePath, ...] = ()
    wind: Wind | None = None
    planned_wind: Wind | None = None
    title: str = ""
    fault: FaultMark | None = None


def _flown_by(checks: list[FailsafeCheck]) -> str:
    return "<br>".join(f"{c.trigger}: {c.param} {c.value:g} ({c.action}, {c.source})"
                       for c in checks)


def failsafe_paths(report: FailsafeReport, flight: Flight) -> tuple[FailsafePath, ...]:
    """The paths of a failsafe audit (:func:`validator.failsafe.audit_failsafes`) a map can
    show: for the actions flying a straight return (RTL), the region of every such return
    and, per zone it enters, the deepest return; when none enters one, the return coming
    closest to a zone. For SmartRTL (and PX4's mission-path Return) the mission's own path.
    Land, Brake and Hold stay where the vehicle is: nothing to draw."""
    flown: dict[str, list[FailsafeCheck]] = {}
    for c in report.checks:
        for kind in c.paths:
            flown.setdefault(kind, []).append(c)
    out: list[FailsafePath] = []
    if "rtl" in flown:
        who = _flown_by(flown["rtl"])
        bad = [f for f in report.findings if f.path == "rtl"]
        out += [FailsafePath("straight returns (RTL) from the mission", ring, not bad,
                             f"the region of every straight return, flown by<br>{who}", "region")
                for ring in report.return_region_xy_m]
        deepest: dict[str, PathFinding] = {}
        for f in bad:
            if f.zone not in deepest or f.clearance_m < deepest[f.zone].clearance_m:
                deepest[f.zone] = f
        for f in deepest.values():
            depth = (f"{-f.clearance_m:.2f} m deep into {f.zone}" if f.clearance_m < 0 else
                     f"{f.clearance_m:.2f} m from {f.zone}, inside its {f.buffer_m:g} m buffer")
            out.append(FailsafePath(
                f"RTL to {f.destination} from the leg {item_label(f.from_item)} -> "
                f"{item_label(f.item)}",
                np.array([f.start_xy_m, f.destination_xy_m]), False, depth))
        w = report.worst_return
        if not bad and w is not None:
            out.append(FailsafePath(
                f"the straight return closest to a zone: from {item_label(w.item)} to "
                f"{w.destination}",
                np.array([w.xy_m, w.destination_xy_m]), True,
                f"{w.clearance_m:.2f} m from {w.zone}"))
    retrace = flown.get("smartrtl", []) + flown.get("mission_path", [])
    if retrace and flight.legs:
        notes = [n for n in report.notes if "SmartRTL" in n or "SRTL" in n]
        out.append(FailsafePath("retraced path (SmartRTL)", flight.path_xy_m, True,
                                "<br>".join([f"retraces the mission, flown by<br>"
                                             f"{_flown_by(retrace)}", *notes]), "retrace"))
    return tuple(out)


def validation_inputs(v: Validation, title: str = "") -> ViewInputs:
    """A :class:`~validator.validation.Validation`'s view: its plan and site, its replay and
    the flown track of its flight (SITL or a recorded one), when it has them; the failsafe
    paths its parameter file leaves; the wind it is flown in, and the plan's when another;
    the fault injected in its flight (``--fault``)."""
    tracks = []
    if v.replay_track is not None and v.profile is not None:
        tracks.append(TrackLayer(f"replay ({v.profile.name})", v.replay_track))
    if v.recorded is not None:
        who = v.extra.get("sitl_flight", {}).get("kind", "recorded")
        if "recorded_flight" in v.extra:
            who = f"recorded, {Path(v.extra['recorded_flight']['file']).name}"
        tracks.append(TrackLayer(f"flown ({who})", v.recorded.track(v.flight, v.site)))
    paths = failsafe_paths(v.failsafe, v.flight) if v.failsafe is not None else ()
    wind, planned = v.flown_wind, None
    if not v.wind_as_planned:
        wind, planned = v.flown_wind or STILL_AIR, v.planned_wind or STILL_AIR
    fault = fault_mark(v.extra["fault"]) if "fault" in v.extra else None
    return ViewInputs(v.plan, v.site, v.flight, tuple(tracks), paths, wind, planned,
                      title=title or f"{v.site.name}: {Path(v.plan_path).name}", fault=fault)
