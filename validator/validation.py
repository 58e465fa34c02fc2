"""One validation of a plan against a site: the audit, the replay, flown tracks, and the report.

:func:`validate_mission` is what ``validate-mission`` does before any flight: it reads the site
and the plan, resolves the flight, audits every leg and fence, checks a vehicle parameter file's
geofence settings and, when asked, replays the flight with a multicopter model. A flight on a
vehicle (:mod:`validator.mavlink`) adds its scored track to the same :class:`Validation`. The
commands only parse arguments and print (:mod:`validator.cli`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from validator.audit import AuditReport, audit
from validator.failsafe import FailsafeReport, audit_failsafes
from validator.flight import Finding, Flight, Severity, resolve_flight
from validator.item_numbers import item_label
from validator.motion.fly import REPLAY_STEP_S, check_step
from validator.motion.limits import site_limits
from validator.motion.profile import Profile, make_profile
from validator.plan_format import Autopilot, Plan, read_plan
from validator.replay import Track, TrackReport, replay, score_replay, score_track
from validator.site import Site, load_site
from validator.track_file import RecordedTrack, read_track
from validator.uas_zones.applicability import AirspaceOptions
from validator.wind import Wind
from validator.wind_track import buffer_share


@dataclass
class Validation:
    """Everything ``validate-mission`` found about one plan on one site.

    ``replay`` is the modelled flight's report (None without ``--replay``); ``sitl`` is the
    place for a report of a flight flown by a (SITL) vehicle, scored with
    :func:`~validator.replay.score_track` exactly like the replay.
    """

    plan_path: str
    site_path: str
    plan: Plan
    site: Site
    flight: Flight
    audit: AuditReport
    profile: Profile | None = None
    dt_s: float = REPLAY_STEP_S
    replay: TrackReport | None = None
    replay_track: Track | None = None  # the modelled flight itself, for a view
    sitl: TrackReport | None = None
    recorded: RecordedTrack | None = None  # what the SITL vehicle sent, for --track
    vehicle_params: dict[str, float] = field(default_factory=dict)
    param_findings: list[Finding] = field(default_factory=list)
    failsafe: FailsafeReport | None = None  # with a parameter file
    force: bool = False  # failsafe path findings are warnings, not violations
    extra: dict[str, Any] = field(default_factory=dict)
    planned_wind: Wind | None = None  # the wind the plan was made for (None: still air)
    flown_wind: Wind | None = None  # the wind it is replayed (and flown in SITL) in

    @property
    def flight_wind(self) -> Wind | None:
        """The layer of ``flown_wind`` at the flight altitude: the air the vehicle flies in
        (what SITL simulates and the buffer's share is judged by); None in still air."""
        return self.site.flight_wind

    @property
    def wind_as_planned(self) -> bool:
        """Whether the flight's wind is the one the plan was made for."""
        return _same_wind(self.planned_wind, self.flown_wind)

    @property
    def failsafe_findings(self) -> list[Finding]:
        """Each failsafe path that enters a zone or its buffer: a violation unless forced; the
        audit's notes; each coast after a GPS loss that does: a warning."""
        return [f for group in self.failsafe_groups() for f in group]

    def failsafe_groups(self) -> tuple[list[Finding], list[Finding], list[Finding]]:
        """:attr:`failsafe_findings` in its three groups: the paths (one per
        :attr:`FailsafeReport.findings`), the notes, the coasts (one per ``position_loss``)."""
        if self.failsafe is None:
            return [], [], []
        severity: Severity = "warning" if self.force else "violation"
        return ([Finding(severity, f.message, f.item) for f in self.failsafe.findings],
                [Finding("note", n) for n in self.failsafe.notes],
                [Finding("warning", f.message, f.item) for f in self.failsafe.position_loss])

    @property
    def violations(self) -> list[Finding]:
        out = list(self.audit.violations)
        out += [f for f in self.failsafe_findings if f.severity == "violation"]
        for rep in (self.replay, self.sitl):
            if rep is not None:
                out += rep.violations
        return out

    @property
    def exit_status(self) -> int:
        return 1 if self.violations else 0

    def as_dict(self) -> dict[str, object]:
        def track(rep: TrackReport | None) -> dict[str, object] | None:
            if rep is None:
                return None
            d = rep.as_dict()
            if rep is self.replay and self.profile is not None:
                d = {"profile": self.profile.name, "params": dict(self.profile.params),
                     "dt_s": self.dt_s, **d}
            return d

        return _json_safe({
            "plan": self.plan_path,
            "site": self.site_path,
            "result": "violation" if self.violations else "clear",
            "exit_status": self.exit_status,
            "violations": [f.as_dict() for f in self.violations],
            "audit": self.audit.as_dict(),
            "vehicle_params": dict(self.vehicle_params),
            "param_findings": [f.as_dict() for f in self.param_findings],
            "failsafe": None if self.failsafe is None else
            {**self.failsafe.as_dict(), "forced": self.force},
            "replay": track(self.replay),
            "sitl": track(self.sitl),
            "wind": {"planned_for": _wind_dict(self.planned_wind),
                     "flown_in": _wind_dict(self.flown_wind),
                     "as_planned": self.wind_as_planned,
                     **buffer_share(self.site.buffer_m, self.flight_wind)},
            **self.extra,
        })


def _json_safe(obj: Any) -> Any:
    """NaN and infinities become null (JSON has none)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    return obj


def _wind_dict(wind: Wind | None) -> dict[str, object] | None:
    return None if wind is None else wind.to_dict()


def _same_wind(a: Wind | None, b: Wind | None) -> bool:
    a = None if a is None or a.calm else a
    b = None if b is None or b.calm else b
    return a == b


def wind_label(wind: Wind | None) -> str:
    """``6 m/s from 270°`` (or ``still air``)."""
    return "still air" if wind is None or wind.calm else wind.label()


def default_profile_name(plan: Plan) -> str:
    """The replay profile matching the plan's firmware: ``px4`` for PX4, else ``arducopter``."""
    return Autopilot.of(plan).profile_name


def validate_mission(
    plan_path: str | Path,
    site_path: str | Path,
    *,
    replay_flight: bool = False,
    profile: str | None = None,
    params: dict[str, float] | None = None,
    dt_s: float = REPLAY_STEP_S,
    vehicle_params: dict[str, float] | None = None,
    flown_track: str | Path | None = None,
    airspace: AirspaceOptions | None = None,
    wind: Wind | None = None,
    force: bool = False,
) -> Validation:
    """Audit ``plan_path`` against ``site_path`` and, with ``replay_flight``, replay it.

    ``profile`` (default: by the plan's firmware) and ``params`` (autopilot names and units)
    choose the flight model; the track is sampled every ``dt_s`` seconds. ``vehicle_params``
    are the parameters the vehicle will hold (a parameter file): those of the flight model
    replay the flight under ``params``' overrides, and a geofence they leave off or unsafe is
    flagged in ``param_findings`` (for a plan with a fence), and every failsafe path they
    leave is audited (:func:`validator.failsafe.audit_failsafes`): one that enters a zone or its
    buffer is a violation, or with ``force`` a warning. ``flown_track`` is a recorded
    flight of the plan (:mod:`validator.track_file`, as ``--track`` writes one): scored into
    ``sitl`` like a flight flown now, and kept in ``recorded``. ``airspace`` says when the plan
    flies and what it is authorised for: the site's UAS zones are decided for [at, at + the
    plan's replayed duration], and a leg in a zone that applies then is a violation (without a
    time every zone is taken as active). ``wind`` is the wind to fly in
    (:mod:`validator.wind`; default: the one the plan was made for, its ``nfzMission.wind``,
    else the site's): a plan replayed in another wind is reported as such
    (:attr:`Validation.wind_as_planned`). Raises :class:`InputError` for bad input, and for a
    wind the vehicle cannot fly against (naming the leg).
    """
    check_step(dt_s, "--dt", REPLAY_STEP_S)
    site = load_site(site_path, airspace)
    plan = read_plan(plan_path)
    flight = resolve_flight(plan, site, str(plan_path))
    if airspace is not None and airspace.at is not None and site.airspace.uas and flight.legs:
        name = profile or default_profile_name(plan)
        prof = make_profile(name, site_limits(site), vehicle_params=vehicle_params)
        duration_s = float(replay(flight, prof, dt_s=dt_s).t_s[-1])
        site = load_site(site_path, replace(airspace, duration_s=duration_s))
        flight = resolve_flight(plan, site, str(plan_path))
    report = audit(plan, site, flight, source=str(plan_path))
    planned = flight.service.wind if flight.service is not None else site.wind
    flown = planned if wind is None else wind
    flown = None if flown is None or flown.calm else flown
    site = site.with_limits(wind=flown)  # the replay's (and a SITL flight's) air
    v = Validation(str(plan_path), str(site_path), plan, site, flight, report, dt_s=dt_s,
                   vehicle_params=dict(vehicle_params or {}), planned_wind=planned,
                   flown_wind=flown, force=force)
    if site.airspace.uas:
        v.extra["airspace"] = site.airspace.report()
    if vehicle_params is not None and (plan.circles or plan.polygons):
        rules = Autopilot.of(plan).fence_rules
        v.param_findings = [Finding("warning", f"parameter file: {p}", None)
                            for p in rules.problems(vehicle_params)]
    if vehicle_params is not None:
        v.failsafe = audit_failsafes(plan, site, flight, vehicle_params)
    if replay_flight or profile is not None or params or vehicle_params:
        name = profile or default_profile_name(plan)
        prof = make_profile(name, site_limits(site), params, vehicle_params=vehicle_params)
        v.profile = prof
        if flight.legs:
            v.replay_track = replay(flight, prof, dt_s=dt_s)
            v.replay = score_replay(v.replay_track, flight, site, plan, prof)
    if flown_track is not None:
        v.recorded = read_track(flown_track)
        track = v.recorded.track(flight, site, source=f"recorded:{Path(flown_track).name}")
        v.sitl = score_track(track, flight, site, plan)
        v.extra["recorded_flight"] = {"file": str(flown_track)}
    return v


def audit_refusal(plan_path: str, site_path: str,
                   params: Mapping[str, float] | None = None) -> str | None:
    """Why the validator rejects the plan before an upload (``upload-mission --site``; one
    line), or None: the audit's violations, the replay's (a zone or fence entered, a flight
    longer than the site's ``uav.endurance``), and with ``params`` (the file ``--params``
    will send, which the replay flies with) every failsafe path they leave that crosses a
    zone or its buffer."""
    v = validate_mission(plan_path, site_path, replay_flight=True,
                         vehicle_params=None if params is None else dict(params))
    problems = v.violations
    if not problems:
        return None
    first = problems[0]
    where = f"{item_label(first.item)}: " if first.item is not None else ""
    return (f"{plan_path} fails the audit against {site_path} ({len(problems)} "
            f"violation(s), first: {where}{first.message})")
