"""Fly a plan on any MAVLink vehicle as a pilot would, recording it, and score the flight.

:func:`fly_mission` drives a vehicle whose mission is already uploaded (see
:func:`validator.mavlink.link.upload_to`) the way a pilot would. ArduCopter: GUIDED, arm,
NAV_TAKEOFF, wait for the altitude, AUTO and MISSION_START. PX4: Mission mode, arm, and the
mission's own NAV_TAKEOFF climbs (PX4 starts a mission when armed in Mission mode; its
NAV_TAKEOFF command would read params 5/6 as the takeoff position). Then it records
GLOBAL_POSITION_INT with the current mission item (MISSION_CURRENT), mode, arming and fence
breach status (:mod:`~validator.mavlink.telemetry`) until the mission ends (last item reached,
mission complete, or landed and disarmed: PX4 disarms COM_DISARM_LAND seconds after its land
detector fires) or ``time_limit_s`` of vehicle time has passed. Mode numbers are each
autopilot's own (:mod:`~validator.mavlink.modes`).

:func:`fly_and_score` is ``validate-mission --sitl``: upload with read-back, fly, and score the
recorded track against the site exactly as the replay is scored
(:func:`validator.replay.score_track`). :func:`builtin_vehicle` starts the SITL vehicle for it.

Times are vehicle seconds (``time_boot_ms``), so a sped-up SITL vehicle's track is in its own
simulated time; altitudes metres above home.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from validator.flight import Finding, Flight
from validator.mavlink.connection import DEFAULT_TIMEOUT_S, LinkError, command_name
from validator.mavlink.link import Link, fence_problems, upload_to
from validator.mavlink.link_loss import after_link_loss, gcs_failsafe
from validator.mavlink.modes import (
    ARDUCOPTER_MODES,
    PX4_MODES,
    ModeNumbers,
    mode_name,
    modes_for,
)
from validator.mavlink.telemetry import (
    LinkLost,
    Recorder,
    Telemetry,
    recorded_track,
    telemetry_track,
)
from validator.mavlink.wire import mavlink
from validator.motion.profile import Profile
from validator.plan_format import Cmd, Plan
from validator.replay import TrackReport, replay, score_track
from validator.site import Site
from validator.track_file import RecordedTrack

# names that lived here before modes.py and telemetry.py, for code written against them
__all__ = [
    "ARDUCOPTER_MODES",
    "PX4_MODES",
    "ModeNumbers",
    "SitlResult",
    "Telemetry",
    "builtin_vehicle",
    "default_time_limit_s",
    "fly_and_score",
    "fly_mission",
    "mode_name",
    "modes_for",
    "recorded_track",
    "takeoff_altitude",
    "telemetry_track",
    "wait_until_ready",
]

Watch = Callable[[Recorder], "str | None"]  # what fly_mission asks on every sample

TAKEOFF_REACHED_FRACTION = 0.95
LANDING_COMMANDS = (Cmd.NAV_LAND, Cmd.NAV_RETURN_TO_LAUNCH)
DISARM_WAIT_S = 15.0  # vehicle seconds from the last item's completion to the disarm
PX4_MIN_DESCENT_MPS = 0.5  # PX4's landing descent is never slower (MPC_LAND_SPEED 0.7 m/s)
TAKEN_OFF_M = 1.0  # above home: an armed vehicle this high is climbing from an accepted take-off
ARM_PATIENCE_S = 60.0  # a fresh ArduPilot/PX4 SITL refuses GUIDED and arming until its EKF is up
READY_PATIENCE_S = 120.0  # wall seconds for a freshly started SITL to pass its pre-arm checks
# PX4 reports its pre-arm bit healthy before the estimator has a position (measured on SIH):
# it sends no GLOBAL_POSITION_INT until then, ~30 vehicle seconds after start.
POSITION_PATIENCE_S = ARM_PATIENCE_S
LAND_RECORD_S = 180.0  # vehicle seconds of a LAND after a lost link that are still recorded
TELEMETRY_HZ = 20.0
MISSION_CURRENT_HZ = 10.0  # the item changes are the timing signal: MISSION_ITEM_REACHED is not


def takeoff_altitude(plan: Plan, default_m: float = 10.0) -> float:
    """The altitude (m above home) to take off to: the plan's first NAV_TAKEOFF, else its
    first waypoint, else ``default_m``."""
    for cmd in (Cmd.NAV_TAKEOFF, Cmd.NAV_WAYPOINT):
        for it in plan.items:
            if it.command == cmd and math.isfinite(it.alt_m) and it.alt_m > 0:
                return float(it.alt_m)
    return default_m


def _request_streams(link: Link) -> None:
    """Ask for position at 20 Hz, the current mission item at 10 Hz and fence status at
    2 Hz (PX4: the landed state too, at 2 Hz); vehicles that stream these anyway may refuse,
    which is fine."""
    interval = {
        mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 1e6 / TELEMETRY_HZ,
        mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: 1e6 / MISSION_CURRENT_HZ,
        mavlink.MAVLINK_MSG_ID_FENCE_STATUS: 5e5,
    }
    if link.vehicle.is_px4:
        interval[mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE] = 5e5
    for msg_id, us in interval.items():
        link.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, float(msg_id), us)


def _until_accepted(link: Link, rec: Recorder, command: int, *params: float,
                    patience_s: float | None = None) -> None:
    """Repeat ``command`` once a second until accepted, for ``patience_s`` (default: the
    link's timeout); a refusal is an answer, so waiting on it is not a hang."""
    start = time.monotonic()
    patience = link.timeout_s if patience_s is None else max(patience_s, link.timeout_s)
    while True:
        result = link.command(command, *params)
        if result == mavlink.MAV_RESULT_ACCEPTED:
            return
        if time.monotonic() - start > patience:
            name = mavlink.enums["MAV_RESULT"][result].name
            raise LinkError(f"command {command_name(command)}: vehicle answered {name} for "
                            f"{patience:g} s{_last_said(link)}")
        rec.pump(time.monotonic() + 1.0, lambda: False)


def _last_said(link: Link, count: int = 3) -> str:
    """The vehicle's last ``count`` STATUSTEXTs as " (last: a; b; c)", or "": a refusal's
    reason is there (a pre-arm check, the EKF, a mode the vehicle will not take)."""
    said = list(link.statustexts)[-count:]
    return f" (last: {'; '.join(said)})" if said else ""


def _set_mode(link: Link, rec: Recorder, modes: ModeNumbers, custom_mode: int,
              patience_s: float | None = None) -> None:
    _until_accepted(link, rec, mavlink.MAV_CMD_DO_SET_MODE, *modes.set_mode_params(custom_mode),
                    patience_s=patience_s)


def fly_mission(
    link: Link,
    plan: Plan,
    *,
    time_limit_s: float,
    takeoff_alt_m: float | None = None,
    progress: Callable[[str], None] | None = None,
    watch: Watch | None = None,
) -> Telemetry:
    """Fly the mission the vehicle holds (uploaded from ``plan``) and record it.

    ``time_limit_s`` bounds the mission in vehicle seconds from MISSION_START. ``watch`` is
    called with the recorder as the mission flies (a fault injector,
    :mod:`validator.mavlink.faults`): the reason it returns ends the recording. The vehicle
    flies on through link gaps (the track misses them: :meth:`Telemetry.gaps`). A link silent
    for ``link.timeout_s`` once the vehicle is armed is lost: LAND is commanded for another
    timeout (:func:`~validator.mavlink.link_loss.after_link_loss`) and the recording ends,
    its verdict in :attr:`Telemetry.link_lost` (raised as :class:`LinkError` before the
    mission started). Raises :class:`LinkError` when the vehicle refuses a step, or falls
    silent before arming.
    """
    say = progress or (lambda _text: None)
    modes = modes_for(link)
    rec = Recorder(link)
    alt = takeoff_alt_m if takeoff_alt_m is not None else takeoff_altitude(plan)
    _request_streams(link)
    position_patience_s = POSITION_PATIENCE_S if modes.px4 else link.timeout_s
    if not rec.pump(time.monotonic() + position_patience_s, lambda: bool(rec.rows)):
        raise LinkError(f"the vehicle sent no GLOBAL_POSITION_INT within "
                        f"{position_patience_s:g} s")
    own_failsafe = gcs_failsafe(link)  # read while the link is up: said if it goes down
    takeoff_s = start_s = math.nan
    try:
        if modes.px4:
            takeoff_s = start_s = _start_px4_mission(link, rec, modes, say)
        else:
            takeoff_s, start_s = _start_ardupilot_mission(link, rec, modes, alt, say)
        reason = _record_mission(link, rec, plan, modes, time_limit_s, start_s, watch)
    except LinkError as err:
        if not (isinstance(err, LinkLost) or time.monotonic() - rec.last_heard
                >= link.timeout_s):
            raise  # the vehicle answers: a refusal, not a lost link
        landed, verdict = after_link_loss(link, modes, own_failsafe, say)
        if landed:
            try:  # record the descent too: it is part of the flight
                rec.pump_vehicle_time(LAND_RECORD_S, rec.disarm_recorded())
            except LinkLost:
                pass
        when = (f" {rec.t_s - start_s:.1f} s into the mission"
                if math.isfinite(start_s) and math.isfinite(rec.t_s) else "")
        text = f"link lost{when} ({err}): {verdict}"
        if not math.isfinite(start_s):
            raise LinkError(text) from None
        say(text)
        return rec.telemetry(takeoff_s, start_s, "link lost", link_lost=text)
    say(f"recorded {len(rec.rows)} samples: {reason}")
    return rec.telemetry(takeoff_s, start_s, reason)


def _record_mission(link: Link, rec: Recorder, plan: Plan, modes: ModeNumbers,
                    time_limit_s: float, start_s: float, watch: Watch | None) -> str:
    """Record the mission from ``start_s`` until it ends or ``time_limit_s``; why it ended."""
    nav = [i for i, it in enumerate(plan.items) if 16 <= it.command < 100]
    last_seq = (nav[-1] if nav else len(plan.items) - 1) + (1 if link.vehicle.is_ardupilot else 0)
    flown: dict[str, Any] = {"airborne": False, "watched": None}

    def finished() -> bool:
        if watch is not None and not flown["watched"]:
            flown["watched"] = watch(rec)
        if flown["watched"]:
            return True
        if rec.armed:
            flown["airborne"] = True
        if flown["airborne"] and not rec.armed:
            return True  # landed and disarmed
        if rec.mission_state == mavlink.MISSION_STATE_COMPLETE:
            return True
        return any(seq == last_seq for _, seq in rec.reached)

    if not rec.pump_vehicle_time(time_limit_s, finished, since_s=start_s):
        return f"time limit ({time_limit_s:g} s)"
    if flown["watched"]:
        return str(flown["watched"])
    if modes.px4 and not rec.armed and not rec.airborne:
        # PX4 disarms COM_DISARM_PRFLT seconds after arming when it never takes off
        raise LinkError(f"the vehicle disarmed without taking off{_last_said(link)}")
    if rec.armed and plan.items[nav[-1] if nav else -1].command in LANDING_COMMANDS:
        # the last item lands: ArduCopter reports its completion just before the disarm,
        # PX4 when the descent starts (then MPC_LAND_SPEED, ~0.7 m/s, near the ground)
        wait_s = DISARM_WAIT_S
        if modes.px4 and rec.rows:
            wait_s += max(float(rec.rows[-1][3]), 0.0) / PX4_MIN_DESCENT_MPS
        rec.pump_vehicle_time(wait_s, lambda: not rec.armed)
    return "landed" if not rec.armed else "mission complete"


def _start_ardupilot_mission(link: Link, rec: Recorder, modes: ModeNumbers, alt: float,
                             say: Callable[[str], None]) -> tuple[float, float]:
    """GUIDED, arm, NAV_TAKEOFF to ``alt``, AUTO and MISSION_START; the vehicle times of the
    takeoff and mission start."""
    say("mode hold / arm")
    _set_mode(link, rec, modes, modes.hold, patience_s=ARM_PATIENCE_S)
    say(f"takeoff to {alt:g} m")
    takeoff_s = _arm_and_take_off(link, rec, alt)

    def at_altitude() -> bool:
        return bool(rec.rows) and rec.rows[-1][3] >= TAKEOFF_REACHED_FRACTION * alt

    if not rec.pump_vehicle_time(120.0 + alt / 0.5, at_altitude):
        raise LinkError(f"takeoff: the vehicle did not reach {alt:g} m")
    say("AUTO, MISSION_START")
    start_s = rec.t_s  # AUTO alone starts ArduCopter's mission
    rec.reached.clear()
    _set_mode(link, rec, modes, modes.auto)
    rec.mission_mode = modes.auto
    _until_accepted(link, rec, mavlink.MAV_CMD_MISSION_START, 0, 0)
    return takeoff_s, start_s


def _arm_and_take_off(link: Link, rec: Recorder, alt: float) -> float:
    """Arm, then NAV_TAKEOFF to ``alt`` (above home), arming again whenever the vehicle
    reports itself disarmed: ArduCopter disarms on the ground DISARM_DELAY (10 s) after arming,
    1 s of wall clock at x10, so a lost ACK or a loaded machine can leave the take-off asking a
    disarmed vehicle, which answers FAILED until the patience runs out. The vehicle time of
    the accepted take-off request."""
    start = time.monotonic()
    asked_s: float | None = None  # the first take-off asked of the vehicle since it armed
    while True:
        if not rec.armed:
            _until_accepted(link, rec, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0,
                            patience_s=ARM_PATIENCE_S)
            rec.armed = True  # its ACK says so; a later HEARTBEAT says otherwise if it disarms
            asked_s = None
        takeoff_s = rec.t_s  # before asking: a lost ACK delays the answer, not the climb
        asked_s = takeoff_s if asked_s is None else asked_s
        result = link.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, 0, 0, alt)
        if result == mavlink.MAV_RESULT_ACCEPTED:
            return takeoff_s
        if rec.armed and rec.rows and rec.rows[-1][3] > TAKEN_OFF_M:
            # an earlier take-off was accepted and its ACK lost: ArduCopter refuses another
            # while it climbs (a CI run asked a climbing vehicle for 60 s through the relay)
            return asked_s
        if time.monotonic() - start > ARM_PATIENCE_S:
            name = mavlink.enums["MAV_RESULT"][result].name
            raise LinkError(f"command {command_name(mavlink.MAV_CMD_NAV_TAKEOFF)}: vehicle "
                            f"answered {name} for {ARM_PATIENCE_S:g} s{_last_said(link)}")
        rec.pump(time.monotonic() + 1.0, lambda: not rec.armed)  # a HEARTBEAT updates it


def _start_px4_mission(link: Link, rec: Recorder, modes: ModeNumbers,
                       say: Callable[[str], None]) -> float:
    """Mission mode, then arm: PX4 starts the mission on arming in Mission mode, its own
    NAV_TAKEOFF climbing. Arming is refused (STATUSTEXT "Arming denied") until the estimator
    is ready, so it is repeated. The vehicle time of the arming request."""
    say("Mission mode / arm: the mission's NAV_TAKEOFF climbs")
    _set_mode(link, rec, modes, modes.auto, patience_s=ARM_PATIENCE_S)
    start_s = rec.t_s  # before asking: a lost ACK delays the answer, not the climb
    _until_accepted(link, rec, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0,
                    patience_s=ARM_PATIENCE_S)
    rec.reached.clear()
    rec.mission_mode = modes.auto
    return start_s


@dataclass
class SitlResult:
    """What :func:`fly_and_score` measured: the scored track, the raw telemetry and how the
    upload went; ``ardupilot`` tells how the telemetry numbers mission items."""

    report: TrackReport
    telemetry: Telemetry
    upload_summary: str
    vehicle: str
    ardupilot: bool = False

    def recorded(self) -> RecordedTrack:
        return recorded_track(self.telemetry, ardupilot=self.ardupilot)


def default_time_limit_s(flight: Flight, profile: Profile) -> float:
    """Twice the replayed mission time plus two minutes (vehicle seconds)."""
    if not flight.legs:
        return 120.0
    return 2.0 * float(replay(flight, profile, dt_s=0.5).t_s[-1]) + 120.0


def wait_until_ready(link: Link, patience_s: float = READY_PATIENCE_S) -> None:
    """Wait until the vehicle says its pre-arm checks pass (the PREARM_CHECK bit of
    SYS_STATUS's sensor health, which ArduPilot and PX4 both set; PX4 never sets it in the
    "present" field): a freshly started SITL answers heartbeats long before its estimator has
    a position, and refuses missions, modes and arming until then. A vehicle that sends no
    SYS_STATUS at all is taken as ready."""
    link.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
                 float(mavlink.MAVLINK_MSG_ID_SYS_STATUS), 5e5)
    rec = Recorder(link)
    try:
        if not rec.pump(time.monotonic() + link.timeout_s, lambda: rec.sys_status_seen):
            return  # no SYS_STATUS: nothing to wait for
        if not rec.pump(time.monotonic() + patience_s, lambda: rec.prearm_ok):
            why = [t for t in link.statustexts if "PreArm" in t or "Preflight" in t]
            raise LinkError(f"the vehicle did not pass its pre-arm checks within "
                            f"{patience_s:g} s" + (f" (last: {why[-1]})" if why else ""))
    finally:
        link.listeners.remove(rec.take)


def fly_and_score(
    plan: Plan,
    site: Site,
    flight: Flight,
    url: str,
    *,
    time_limit_s: float,
    timeout_s: float = DEFAULT_TIMEOUT_S,
    sysid: int | None = None,
    params: Mapping[str, float] | None = None,
    progress: Callable[[str], None] | None = None,
    wait_ready: bool = False,
    signing_key: bytes | None = None,
    watch: Callable[[Link], Watch] | None = None,
) -> SitlResult:
    """Upload ``plan`` to the vehicle at ``url`` (``params`` set after the lists, everything
    verified by read-back), fly it and score the recorded track with :func:`score_track`.

    ``wait_ready`` first waits for a freshly started vehicle to pass its pre-arm checks;
    ``signing_key`` signs the link (:mod:`validator.mavlink.signing`); ``watch`` makes the
    :func:`fly_mission` watcher for the open link (a fault injector). A
    fence the vehicle holds switched off (or with a breach action that can cross another
    zone), and every time the vehicle left the mission mode on its own, are findings of the
    report."""
    say = progress or (lambda _text: None)
    with Link(url, timeout_s=timeout_s, target_system=sysid, signing_key=signing_key) as link:
        if wait_ready:
            say("waiting for the vehicle's pre-arm checks")
            wait_until_ready(link)
        up = upload_to(link, plan, params, require_fence=False)
        say(up.summary())
        fence = fence_problems(link, plan)
        telemetry = fly_mission(link, plan, time_limit_s=time_limit_s, progress=progress,
                                watch=None if watch is None else watch(link))
        vehicle = f"{link.vehicle.autopilot_name} system {link.vehicle.system_id}"
        ardupilot = link.vehicle.is_ardupilot
    if telemetry.samples < 2:
        raise LinkError("the vehicle sent no position during the flight")
    track = telemetry_track(telemetry, flight, site, ardupilot=ardupilot,
                            source=f"sitl:{url}")
    report = score_track(track, flight, site, plan)
    extra = [Finding("warning", f"geofence on the vehicle: {p}", None) for p in fence]
    extra += [Finding("warning", f"the vehicle left the mission for {mode} at t = {t:.1f} s "
                                 f"({t - telemetry.mission_start_s:.1f} s into it)", None)
              for t, mode in telemetry.mode_changes]
    extra += link_findings(telemetry)
    if telemetry.end_reason.startswith("time limit"):
        extra.append(Finding("warning", f"the flight was cut at the {telemetry.end_reason}",
                             None))
    if extra:
        report = dataclasses.replace(report, findings=(*report.findings, *extra))
    return SitlResult(report, telemetry, up.summary(), vehicle, ardupilot)


def link_findings(telemetry: Telemetry) -> list[Finding]:
    """What a bad link took from the recorded flight: the gaps in its track (a warning: the
    vehicle flew on, the track runs straight from the last report before a gap to the first
    after it), and a link lost for good (a violation: the flight was not followed to its
    end)."""
    out: list[Finding] = []
    gaps = telemetry.gaps()
    if gaps:
        start, longest = max(gaps, key=lambda g: g[1])
        into = start - telemetry.flight_start_s
        out.append(Finding("warning", (
            f"the link dropped {len(gaps)} time(s) in flight: the track misses "
            f"{sum(g[1] for g in gaps):.1f} s (longest {longest:.1f} s, {into:.1f} s after the "
            "takeoff) and is scored there as a straight line between the reports either side"),
            None))
    if telemetry.link_lost:
        out.append(Finding("violation", f"{telemetry.link_lost}; the flight was not followed "
                                        "to its end", None))
    return out


@contextmanager
def builtin_vehicle(
    plan: Plan,
    *,
    profile: Profile,
    speedup: float,
    loss: float = 0.0,
    seed: int = 0,
) -> Iterator[str]:
    """Run the SITL vehicle at ``plan``'s home on a free loopback port for the duration of a
    ``with`` block; yields the connection string to reach it. Its flight model is
    ``profile`` with all its parameters, so it flies as the replay does."""
    from validator.mavlink.sim import SitlVehicle, VehicleConfig

    config = VehicleConfig(
        home=(plan.home_lat_deg, plan.home_lon_deg, plan.home_alt_m),
        speedup=speedup,
        loss=loss,
        seed=seed,
        profile=profile.name,
        params=dict(profile.params),
        max_speed_mps=float(profile.si("VEHICLE_SPEED_MAX")),
    )
    vehicle = SitlVehicle("udpin:127.0.0.1:0", config).start()
    try:
        yield f"udpout:127.0.0.1:{vehicle.address[1]}"
    finally:
        vehicle.stop()
