"""The validator's front door: the calls a notebook or script makes to judge a plan.

Load a site and a plan, then audit the plan (exact clearance of every straight leg and the
geofence), replay it with a model of its autopilot, fly it on a vehicle (the built-in model,
an autopilot's SITL binary, or any MAVLink vehicle at a URL), or score a flight recorded
earlier. Every call takes and returns typed objects; bad input raises
:class:`~validator.errors.InputError` (a one-line message naming the file and field), a
failed link :class:`~validator.mavlink.connection.LinkError`. Units: metres, seconds, m/s,
degrees; rates in bps/Hz.

    from validator import api
    site = api.load_site("samples/realistic.yaml")
    plan = api.read_plan("mission.plan")
    print(api.audit_plan(plan, site).violations)
    print(api.replay_plan(plan, site).report.cycle)

The commands (``validate-mission``) parse arguments and print around the same modules.
pymavlink is imported only by :func:`fly_plan`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from validator.audit import AuditReport, audit
from validator.errors import InputError
from validator.flight import Flight, resolve_flight
from validator.mavlink.connection import DEFAULT_TIMEOUT_S
from validator.mavlink.vehicles import VehicleChoice, VehicleKind, choose_vehicle, start_vehicle
from validator.motion.fly import REPLAY_STEP_S, check_step
from validator.motion.limits import site_limits
from validator.motion.profile import Profile, ProfileName, make_profile
from validator.plan_format import Autopilot, Plan, read_plan
from validator.replay import Track, TrackReport, replay, score_replay, score_track
from validator.site import Site
from validator.site import load_site as _load_site
from validator.track_file import RecordedTrack, read_track, write_track
from validator.uas_zones.applicability import AirspaceOptions
from validator.wind import Wind, parse_wind_arg

if TYPE_CHECKING:
    from validator.mavlink.faults import FaultReport
    from validator.mavlink.sitl_check import FaultKind
    from validator.mavlink.telemetry import Telemetry

__all__ = ["Flown", "Replayed", "VehicleChoice", "Wind", "audit_plan", "choose_vehicle",
           "flight_profile", "fly_plan", "load_site", "read_plan", "replay_plan",
           "score_recorded", "write_track"]



def load_site(
    path: str | Path,
    *,
    at: datetime | None = None,
    duration_s: float = 0.0,
    authorised: Iterable[str] = (),
    buffer_m: float | None = None,
    wind: Wind | str | None = None,
) -> Site:
    """Read, validate and resolve a site YAML file.

    ``at`` (time-zone aware) is when the mission starts and ``duration_s`` how long it flies:
    the UAS zones of the site's ``airspace:`` (ED-269, ED-318) that apply in that window are
    kept, less those in ``authorised`` (zone identifiers); without ``at`` every zone is
    taken as active. ``buffer_m`` replaces the site's safety buffer (m). ``wind``, the day's
    forecast as plan-mission's ``--wind`` takes it (a :class:`~validator.wind.Wind`, or
    ``"7@300"``: m/s and the degrees it blows from, ``"6@135,1.5"`` with turbulence, ``"0"``
    for still air), replaces the site's ``wind:``; the site's wind is the air every call
    below plans, replays and flies in.
    """
    options = AirspaceOptions(at, duration_s=duration_s, authorised=frozenset(authorised),
                              buffer_m=buffer_m)
    site = _load_site(path, options)
    if isinstance(wind, str):
        wind = parse_wind_arg(wind, "wind")
    site = site.with_forecast(wind)
    return site if buffer_m is None else site.with_buffer(buffer_m)


def _flight(plan: Plan, site: Site, source: str) -> Flight:
    return resolve_flight(plan, site, source)


def audit_plan(plan: Plan, site: Site, *, source: str = "plan") -> AuditReport:
    """The exact audit of ``plan`` on ``site``: every straight leg's clearance from every zone
    and its buffer, the geofence, the items (``.violations``, ``.findings``, ``.nfz``).
    ``source`` names the plan in messages."""
    return audit(plan, site, _flight(plan, site, source), source=source)


@dataclass(frozen=True)
class Replayed:
    """A modelled flight: the ``profile`` flown (name and parameters in the autopilot's
    units), the resolved ``flight``, the sampled ``track`` and its ``report`` (clearances,
    cycle timing, throughput; scored like a real flight)."""

    profile: Profile
    flight: Flight
    track: Track
    report: TrackReport


def flight_profile(plan: Plan, site: Site, profile: ProfileName | None = None,
                   params: Mapping[str, float] | None = None) -> Profile:
    """The flight model of ``plan``'s autopilot (``profile``: "arducopter", "px4" or "ideal";
    default by the plan's firmware) at the site's limits and ``params`` (autopilot names and
    units, e.g. the parameter file the vehicle flies with)."""
    name = profile or Autopilot.of(plan).profile_name
    return make_profile(name, site_limits(site), vehicle_params=params)


def replay_plan(
    plan: Plan,
    site: Site,
    *,
    profile: ProfileName | None = None,
    params: Mapping[str, float] | None = None,
    dt_s: float = REPLAY_STEP_S,
    source: str = "plan",
) -> Replayed:
    """Fly ``plan`` with the validator's model of its autopilot (:func:`flight_profile`) in the
    site's wind, sampled every ``dt_s`` seconds, and score the track against ``site``. What
    if the wind is other than planned: ``site.with_forecast(Wind(9, 300))``."""
    check_step(dt_s, "dt_s", REPLAY_STEP_S)
    flight = _flight(plan, site, source)
    prof = flight_profile(plan, site, profile, params)
    track = replay(flight, prof, dt_s=dt_s)
    return Replayed(prof, flight, track, score_replay(track, flight, site, plan, prof))


@dataclass(frozen=True)
class Flown:
    """A flight on a vehicle: its scored ``report`` (as a replay's), the ``recorded`` track
    (to write with :func:`validator.track_file.write_track` and score again later), the raw
    ``telemetry``, which ``vehicle`` answered ("ArduPilot system 1"), its ``kind``, how the
    ``upload`` went, the parameters set on it before the flight, and a note on the air it
    flew in when that is not the site's wind (an external vehicle, PX4's SIH); with a
    ``fault``, the flight after it (its violations are in ``report.findings`` too)."""

    report: TrackReport
    recorded: RecordedTrack
    telemetry: Telemetry
    vehicle: str
    kind: VehicleKind
    upload: str
    params_set: dict[str, float] = field(default_factory=dict)
    wind_note: str | None = None
    fault: FaultReport | None = None


def fly_plan(
    plan: Plan,
    site: Site,
    vehicle: VehicleChoice | None = None,
    *,
    params: Mapping[str, float] | None = None,
    profile: ProfileName | None = None,
    time_limit_s: float | None = None,
    timeout_s: float = DEFAULT_TIMEOUT_S,
    progress: Callable[[str], None] | None = None,
    source: str = "plan",
    fault: FaultKind | None = None,
) -> Flown:
    """Upload ``plan`` to a vehicle, fly it as a pilot would and score the flight.

    ``vehicle`` is :func:`choose_vehicle`'s choice (default: ``$ARDUPILOT_SITL`` or
    ``$PX4_SITL`` if set, else the built-in model vehicle, which flies ``profile`` at
    ``params`` like :func:`replay_plan`). ``params`` (autopilot names and units: a parameter
    file's values) are set on the vehicle and read back before the mission, with what a
    sped-up SITL needs (validate-mission's: its link timeout, and ArduPilot SITL's wind, the
    site's at the flight altitude; PX4's SIH has none, ``Flown.wind_note`` says so).
    ``time_limit_s`` bounds the mission in vehicle seconds (default: twice the replayed
    mission plus two minutes); ``timeout_s`` is how long the vehicle may stay silent.
    ``fault`` ("rc-loss", "gcs-loss", "battery-low", "gps-loss"; an autopilot only) is
    injected as validate-mission's ``--fault`` does it: where the failsafe ``params`` leave
    would do the most harm (:mod:`validator.mavlink.faults`); a zone entered after it, or an
    end neither landed nor holding, is a violation of the flight.
    """
    from validator.mavlink.driver import default_time_limit_s, fly_and_score  # pymavlink
    from validator.mavlink.faults import FaultInjector, fault_watch, score_fault, with_fault
    from validator.mavlink.sitl_check import flight_params

    flight = _flight(plan, site, source)
    if not flight.legs:
        raise InputError(f"{source}: nothing to fly (no navigation items)")
    choice = vehicle or choose_vehicle(plan)
    prof = flight_profile(plan, site, profile, params)
    limit = time_limit_s or default_time_limit_s(flight, prof)
    injector: list[FaultInjector] = []  # the fault's, once the link is open
    watch = fault_watch(fault, plan, site, flight, params, injector, field="fault",
                        autopilot=choice.kind != "builtin") if fault else None
    sent, wind_note = flight_params(choice, params or {}, site.flight_wind)
    with start_vehicle(choice, plan, prof) as running:
        result = fly_and_score(plan, site, flight, running.url, time_limit_s=limit,
                               timeout_s=timeout_s, sysid=choice.sysid, params=sent or None,
                               progress=progress, wait_ready=running.wait_ready,
                               signing_key=choice.signing_key, watch=watch)
    report, after = result.report, None
    if injector:
        after = score_fault(injector[0], result.telemetry, site, flight,
                            result.telemetry.end_reason)
        report = with_fault(report, after)
    return Flown(report, result.recorded(), result.telemetry, result.vehicle,
                 choice.kind, result.upload_summary, sent, wind_note, after)


def score_recorded(plan: Plan, site: Site, track: str | Path | RecordedTrack, *,
                   source: str = "plan") -> TrackReport:
    """Score a flight of ``plan`` recorded earlier (a track file as ``validate-mission
    --track`` writes it, ``.gz`` too, or a :class:`RecordedTrack`) exactly like a flight
    flown now."""
    recorded = track if isinstance(track, RecordedTrack) else read_track(track)
    name = "track" if isinstance(track, RecordedTrack) else Path(track).name
    flight = _flight(plan, site, source)
    flown = recorded.track(flight, site, source=f"recorded:{name}")
    return score_track(flown, flight, site, plan)
