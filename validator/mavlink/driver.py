"""Fly a plan on any MAVLink vehicle and record what it reports.

:func:`fly_mission` drives a vehicle whose mission is already uploaded (see
:func:`validator.mavlink.link.upload_to`) the way a pilot would. ArduCopter: GUIDED, arm,
NAV_TAKEOFF, wait for the altitude, AUTO and MISSION_START. PX4: Mission mode, arm, and the
mission's own NAV_TAKEOFF climbs (PX4 starts a mission when armed in Mission mode; its
NAV_TAKEOFF command would read params 5/6 as the takeoff position). Then it records
GLOBAL_POSITION_INT with the current mission item (MISSION_CURRENT), mode, arming and fence
breach status until the mission ends (last item reached, mission complete, or landed and
disarmed: PX4 disarms COM_DISARM_LAND seconds after its land detector fires) or
``time_limit_s`` of vehicle time has passed. Mode numbers are each autopilot's own:
ArduCopter's custom modes, or PX4's main/sub modes.

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
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from validator.dynamics import Profile
from validator.flight import Finding, Flight
from validator.geodesy import from_int_e7
from validator.mavlink.link import Link, LinkError, command_name, fence_problems, upload_to
from validator.mavlink.wire import mavlink, mavutil
from validator.plan_format import Cmd, Plan
from validator.replay import Track, TrackReport, replay, score_track, track_from_geodetic
from validator.site import Site
from validator.track_file import RecordedTrack

TAKEOFF_REACHED_FRACTION = 0.95
LANDING_COMMANDS = (Cmd.NAV_LAND, Cmd.NAV_RETURN_TO_LAUNCH)
DISARM_WAIT_S = 15.0  # vehicle seconds from the last item's completion to the disarm
PX4_MIN_DESCENT_MPS = 0.5  # PX4's landing descent is never slower (MPC_LAND_SPEED 0.7 m/s)
ARM_PATIENCE_S = 60.0  # a fresh ArduPilot/PX4 SITL refuses GUIDED and arming until its EKF is up
READY_PATIENCE_S = 120.0  # wall seconds for a freshly started SITL to pass its pre-arm checks
# PX4 reports its pre-arm bit healthy before the estimator has a position (measured on SIH):
# it sends no GLOBAL_POSITION_INT until then, ~30 vehicle seconds after start.
POSITION_PATIENCE_S = ARM_PATIENCE_S
TELEMETRY_HZ = 20.0
MISSION_CURRENT_HZ = 10.0  # the item changes are the timing signal: MISSION_ITEM_REACHED is not


@dataclass(frozen=True)
class ModeNumbers:
    """HEARTBEAT.custom_mode values of the modes the driver uses, and how to ask for them."""

    hold: int  # a position-holding mode the vehicle can arm and take off in
    auto: int  # mission mode
    px4: bool = False

    def set_mode_params(self, custom_mode: int) -> tuple[float, float, float]:
        """DO_SET_MODE param1..3 for ``custom_mode``."""
        base = float(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
        if self.px4:  # PX4 takes main and sub mode apart
            return base, float((custom_mode >> 16) & 0xFF), float((custom_mode >> 24) & 0xFF)
        return base, float(custom_mode), 0.0


def _px4_mode(main: int, sub: int = 0) -> int:
    return (main << 16) | (sub << 24)


ARDUCOPTER_MODES = ModeNumbers(
    hold=mavutil.mode_mapping_byname(mavlink.MAV_TYPE_QUADROTOR)["GUIDED"],
    auto=mavutil.mode_mapping_byname(mavlink.MAV_TYPE_QUADROTOR)["AUTO"],
)
PX4_MODES = ModeNumbers(
    hold=_px4_mode(mavutil.PX4_CUSTOM_MAIN_MODE_AUTO, mavutil.PX4_CUSTOM_SUB_MODE_AUTO_LOITER),
    auto=_px4_mode(mavutil.PX4_CUSTOM_MAIN_MODE_AUTO, mavutil.PX4_CUSTOM_SUB_MODE_AUTO_MISSION),
    px4=True,
)


def modes_for(link: Link) -> ModeNumbers:
    """The mode numbers of the connected vehicle's autopilot."""
    return PX4_MODES if link.vehicle.is_px4 else ARDUCOPTER_MODES


@dataclass
class Telemetry:
    """What the vehicle reported, one row per GLOBAL_POSITION_INT.

    ``t_s`` vehicle seconds since boot; ``lat_deg``/``lon_deg``; ``rel_alt_m`` above home;
    ``vel_mps`` (n, 3) north, east, down; ``mission_seq`` the vehicle's current mission item
    (its own numbering: ArduPilot counts home as 0; from MISSION_CURRENT, the timing signal);
    ``armed``; ``fence_breach``. ``reached`` lists (t_s, seq) of MISSION_ITEM_REACHED, a hint
    only (ArduCopter sends one per loop, so an item followed by a DO command or the final LAND
    is never reported); ``mode_changes`` (t_s, mode name) each time the vehicle left the
    mission mode on its own (a fence breach action, a failsafe); ``messages`` (t_s, text) what
    the vehicle said (STATUSTEXT); ``takeoff_start_s`` and ``mission_start_s`` when
    NAV_TAKEOFF and MISSION_START were asked for; ``end_reason`` why recording stopped.
    """

    t_s: NDArray[np.float64]
    lat_deg: NDArray[np.float64]
    lon_deg: NDArray[np.float64]
    rel_alt_m: NDArray[np.float64]
    vel_mps: NDArray[np.float64]
    mission_seq: NDArray[np.int64]
    armed: NDArray[np.bool_]
    fence_breach: NDArray[np.bool_]
    reached: list[tuple[float, int]] = field(default_factory=list)
    mode_changes: list[tuple[float, str]] = field(default_factory=list)
    messages: list[tuple[float, str]] = field(default_factory=list)
    mission_start_s: float = math.nan
    takeoff_start_s: float = math.nan
    end_reason: str = ""

    @property
    def samples(self) -> int:
        return int(self.t_s.size)


class _Recorder:
    """Accumulates telemetry rows while the driver waits for things."""

    def __init__(self, link: Link) -> None:
        self.link = link
        self.rows: list[tuple[Any, ...]] = []
        self.seq = -1
        self.armed = False
        self.custom_mode: int | None = None
        self.breach = False
        self.mission_state = 0
        self.reached: list[tuple[float, int]] = []
        self.mission_mode: int | None = None  # set once the mission runs: leaving it is news
        self.mode_changes: list[tuple[float, str]] = []
        self.messages: list[tuple[float, str]] = []
        self.prearm_ok = False
        self.sys_status_seen = False
        self.landed_state = mavlink.MAV_LANDED_STATE_UNDEFINED
        self.airborne = False  # the vehicle said it was in the air (EXTENDED_SYS_STATE)
        self.t_s = math.nan
        self.home_amsl_m = math.nan
        self.last_heard = time.monotonic()
        link.listeners.append(self.take)

    def pump(self, until: float, stop: Callable[[], bool]) -> bool:
        """Record until ``stop()`` holds (True) or ``until`` (monotonic) passes (False);
        :class:`LinkError` when the vehicle stays silent for the link's timeout."""
        while True:
            if stop():
                return True
            now = time.monotonic()
            if now >= until:
                return False
            if now - self.last_heard > self.link.timeout_s:
                raise LinkError(f"the vehicle stopped reporting for {self.link.timeout_s:g} s "
                                "during the flight")
            self.link.recv((), min(until, now + 0.05))  # messages reach take() as listener

    def take(self, m: Any) -> None:
        """Fold one pymavlink message into the state (fields are its attributes); the link
        calls this for every message it reads from the vehicle."""
        self.last_heard = time.monotonic()
        kind = m.get_type()
        if kind == "GLOBAL_POSITION_INT":
            self.t_s = m.time_boot_ms / 1000.0
            self.home_amsl_m = (m.alt - m.relative_alt) / 1000.0
            self.rows.append((self.t_s, float(from_int_e7(m.lat)), float(from_int_e7(m.lon)),
                              m.relative_alt / 1000.0,
                              m.vx / 100.0, m.vy / 100.0, m.vz / 100.0,
                              self.seq, self.armed, self.breach))
        elif kind == "HEARTBEAT":
            self.armed = bool(m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            mode = int(m.custom_mode)
            if (self.mission_mode is not None and mode != self.custom_mode
                    and mode != self.mission_mode and self.armed):
                self.mode_changes.append((self.t_s, mode_name(self.link, mode)))
            self.custom_mode = mode
        elif kind == "SYS_STATUS":
            self.sys_status_seen = True
            self.prearm_ok = bool(m.onboard_control_sensors_health
                                  & mavlink.MAV_SYS_STATUS_PREARM_CHECK)
        elif kind == "MISSION_CURRENT":
            self.seq = int(m.seq)
            self.mission_state = int(getattr(m, "mission_state", 0))
        elif kind == "MISSION_ITEM_REACHED":
            self.reached.append((self.t_s, int(m.seq)))
        elif kind == "FENCE_STATUS":
            self.breach = bool(m.breach_status)
        elif kind == "STATUSTEXT":
            self.messages.append((self.t_s, str(m.text)))
        elif kind == "EXTENDED_SYS_STATE":
            self.landed_state = int(m.landed_state)
            if self.landed_state in (mavlink.MAV_LANDED_STATE_IN_AIR,
                                     mavlink.MAV_LANDED_STATE_TAKEOFF):
                self.airborne = True

    def telemetry(self, takeoff_start_s: float, mission_start_s: float,
                  end_reason: str) -> Telemetry:
        rows = self.rows or [(math.nan,) * 7 + (-1, False, False)]
        cols = list(zip(*rows, strict=True))
        return Telemetry(
            t_s=np.asarray(cols[0], dtype=float),
            lat_deg=np.asarray(cols[1], dtype=float),
            lon_deg=np.asarray(cols[2], dtype=float),
            rel_alt_m=np.asarray(cols[3], dtype=float),
            vel_mps=np.column_stack([cols[4], cols[5], cols[6]]).astype(float),
            mission_seq=np.asarray(cols[7], dtype=np.int64),
            armed=np.asarray(cols[8], dtype=bool),
            fence_breach=np.asarray(cols[9], dtype=bool),
            reached=list(self.reached),
            mode_changes=list(self.mode_changes),
            messages=list(self.messages),
            mission_start_s=mission_start_s,
            takeoff_start_s=takeoff_start_s,
            end_reason=end_reason,
        )


def takeoff_altitude(plan: Plan, default_m: float = 10.0) -> float:
    """The altitude (m above home) to take off to: the plan's first NAV_TAKEOFF, else its
    first waypoint, else ``default_m``."""
    for cmd in (Cmd.NAV_TAKEOFF, Cmd.NAV_WAYPOINT):
        for it in plan.items:
            if it.command == cmd and math.isfinite(it.alt_m) and it.alt_m > 0:
                return float(it.alt_m)
    return default_m


def mode_name(link: Link, custom_mode: int) -> str:
    """The vehicle's name for ``custom_mode`` (ArduCopter's or PX4's), or its number."""
    if link.vehicle.is_px4:
        px4 = {_px4_mode(main, sub): name for name, (_, main, sub) in mavutil.px4_map.items()}
        return str(px4.get(custom_mode, custom_mode))
    names = mavutil.mode_mapping_bynumber(mavlink.MAV_TYPE_QUADROTOR) or {}
    return str(names.get(custom_mode, custom_mode))


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


def _until_accepted(link: Link, rec: _Recorder, command: int, *params: float,
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
                            f"{patience:g} s")
        rec.pump(time.monotonic() + 1.0, lambda: False)


def _set_mode(link: Link, rec: _Recorder, modes: ModeNumbers, custom_mode: int,
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
) -> Telemetry:
    """Fly the mission the vehicle holds (uploaded from ``plan``) and record it.

    ``time_limit_s`` bounds the mission in vehicle seconds from MISSION_START. Raises
    :class:`LinkError` when the vehicle refuses a step or falls silent for ``link.timeout_s``.
    """
    say = progress or (lambda _text: None)
    modes = modes_for(link)
    rec = _Recorder(link)
    alt = takeoff_alt_m if takeoff_alt_m is not None else takeoff_altitude(plan)
    _request_streams(link)
    position_patience_s = POSITION_PATIENCE_S if modes.px4 else link.timeout_s
    if not rec.pump(time.monotonic() + position_patience_s, lambda: bool(rec.rows)):
        raise LinkError(f"the vehicle sent no GLOBAL_POSITION_INT within "
                        f"{position_patience_s:g} s")
    if modes.px4:
        takeoff_s = start_s = _start_px4_mission(link, rec, modes, say)
    else:
        takeoff_s, start_s = _start_ardupilot_mission(link, rec, modes, alt, say)
    nav = [i for i, it in enumerate(plan.items) if 16 <= it.command < 100]
    last_seq = (nav[-1] if nav else len(plan.items) - 1) + (1 if link.vehicle.is_ardupilot else 0)
    flown = {"airborne": False}

    def finished() -> bool:
        if rec.armed:
            flown["airborne"] = True
        if flown["airborne"] and not rec.armed:
            return True  # landed and disarmed
        if rec.mission_state == mavlink.MISSION_STATE_COMPLETE:
            return True
        return any(seq == last_seq for _, seq in rec.reached)

    if _pump_vehicle_time(rec, time_limit_s, finished, since_s=start_s):
        if modes.px4 and not rec.armed and not rec.airborne:
            # PX4 disarms COM_DISARM_PRFLT seconds after arming when it never takes off
            said = [t for t in link.statustexts][-3:]
            raise LinkError("the vehicle disarmed without taking off"
                            + (f" (last: {'; '.join(said)})" if said else ""))
        if rec.armed and plan.items[nav[-1] if nav else -1].command in LANDING_COMMANDS:
            # the last item lands: ArduCopter reports its completion just before the disarm,
            # PX4 when the descent starts (then MPC_LAND_SPEED, ~0.7 m/s, near the ground)
            wait_s = DISARM_WAIT_S
            if modes.px4 and rec.rows:
                wait_s += max(float(rec.rows[-1][3]), 0.0) / PX4_MIN_DESCENT_MPS
            _pump_vehicle_time(rec, wait_s, lambda: not rec.armed)
        reason = "landed" if not rec.armed else "mission complete"
    else:
        reason = f"time limit ({time_limit_s:g} s)"
    say(f"recorded {len(rec.rows)} samples: {reason}")
    return rec.telemetry(takeoff_s, start_s, reason)


def _start_ardupilot_mission(link: Link, rec: _Recorder, modes: ModeNumbers, alt: float,
                             say: Callable[[str], None]) -> tuple[float, float]:
    """GUIDED, arm, NAV_TAKEOFF to ``alt``, AUTO and MISSION_START; the vehicle times of the
    takeoff and mission start."""
    say("mode hold / arm")
    _set_mode(link, rec, modes, modes.hold, patience_s=ARM_PATIENCE_S)
    _until_accepted(link, rec, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0,
                    patience_s=ARM_PATIENCE_S)
    say(f"takeoff to {alt:g} m")
    takeoff_s = rec.t_s  # before asking: a lost ACK delays the answer, not the climb
    # ArduPilot reads NAV_TAKEOFF's param7 above home
    _until_accepted(link, rec, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, 0, 0, alt)

    def at_altitude() -> bool:
        return bool(rec.rows) and rec.rows[-1][3] >= TAKEOFF_REACHED_FRACTION * alt

    if not _pump_vehicle_time(rec, 120.0 + alt / 0.5, at_altitude):
        raise LinkError(f"takeoff: the vehicle did not reach {alt:g} m")
    say("AUTO, MISSION_START")
    start_s = rec.t_s  # AUTO alone starts ArduCopter's mission
    rec.reached.clear()
    _set_mode(link, rec, modes, modes.auto)
    rec.mission_mode = modes.auto
    _until_accepted(link, rec, mavlink.MAV_CMD_MISSION_START, 0, 0)
    return takeoff_s, start_s


def _start_px4_mission(link: Link, rec: _Recorder, modes: ModeNumbers,
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


def _pump_vehicle_time(rec: _Recorder, limit_s: float, stop: Callable[[], bool],
                       since_s: float | None = None) -> bool:
    """Record until ``stop()`` or until ``limit_s`` vehicle seconds have passed."""
    t0 = rec.t_s if since_s is None else since_s

    def done() -> bool:
        if stop():
            return True
        return math.isfinite(t0) and math.isfinite(rec.t_s) and rec.t_s - t0 >= limit_s

    rec.pump(math.inf, done)
    return bool(stop())


def telemetry_track(telemetry: Telemetry, flight: Flight, site: Site, *, ardupilot: bool,
                    source: str) -> Track:
    """The recorded flight from NAV_TAKEOFF on as a :class:`Track` aligned with ``flight``,
    its clock starting at the takeoff like the replay's. The climb flown in GUIDED before
    MISSION_START counts as the mission's takeoff item when the mission starts with one;
    ArduPilot's seq numbers become plan item indices."""
    t0 = telemetry.takeoff_start_s
    if not math.isfinite(t0):
        t0 = telemetry.mission_start_s if math.isfinite(telemetry.mission_start_s) else 0.0
    keep = telemetry.t_s >= t0
    t = telemetry.t_s[keep]
    seq = telemetry.mission_seq[keep] - (1 if ardupilot else 0)
    if flight.legs and flight.legs[0].kind == "takeoff":
        # until the vehicle reports an item past the takeoff, it is flying the takeoff
        past = np.flatnonzero(seq > flight.legs[0].item)
        seq[: past[0] if past.size else seq.size] = flight.legs[0].item
    return track_from_geodetic(
        flight, site, t - t0, telemetry.lat_deg[keep], telemetry.lon_deg[keep], seq,
        alt_m=telemetry.rel_alt_m[keep], source=source,
    )


def recorded_track(telemetry: Telemetry, *, ardupilot: bool) -> RecordedTrack:
    """The telemetry as a :class:`~validator.track_file.RecordedTrack`: times from the start
    of the takeoff (as :func:`telemetry_track`), mission items as ``.plan`` indices."""
    t0 = telemetry.takeoff_start_s
    if not math.isfinite(t0):
        t0 = telemetry.mission_start_s if math.isfinite(telemetry.mission_start_s) else 0.0
    seq = telemetry.mission_seq - (1 if ardupilot else 0)
    return RecordedTrack(telemetry.t_s - t0, telemetry.lat_deg, telemetry.lon_deg,
                         telemetry.rel_alt_m, telemetry.vel_mps,
                         np.where(telemetry.mission_seq < 0, -1, seq).astype(np.int64),
                         telemetry.armed, telemetry.fence_breach)


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
    rec = _Recorder(link)
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
    timeout_s: float = 10.0,
    sysid: int | None = None,
    params: Mapping[str, float] | None = None,
    progress: Callable[[str], None] | None = None,
    wait_ready: bool = False,
    signing_key: bytes | None = None,
) -> SitlResult:
    """Upload ``plan`` to the vehicle at ``url`` (``params`` set after the lists, everything
    verified by read-back), fly it and score the recorded track with :func:`score_track`.

    ``wait_ready`` first waits for a freshly started vehicle to pass its pre-arm checks;
    ``signing_key`` signs the link (:mod:`validator.mavlink.signing`). A
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
        telemetry = fly_mission(link, plan, time_limit_s=time_limit_s, progress=progress)
        vehicle = f"{link.vehicle.autopilot_name} system {link.vehicle.system_id}"
        ardupilot = link.vehicle.is_ardupilot
    if telemetry.samples < 2:
        raise LinkError("the vehicle sent no position during the flight")
    track = telemetry_track(telemetry, flight, site, ardupilot=ardupilot,
                            source=f"sitl:{url}")
    report = score_track(track, flight, site, plan)
    extra = [Finding("warning", f"geofence on the vehicle: {p}", None) for p in fence]
    extra += [Finding("warning", f"the vehicle left the mission for {mode} at "
                                 f"{t - telemetry.mission_start_s:.1f} s into it", None)
              for t, mode in telemetry.mode_changes]
    if telemetry.end_reason.startswith("time limit"):
        extra.append(Finding("warning", f"the flight was cut at the {telemetry.end_reason}",
                             None))
    if extra:
        report = dataclasses.replace(report, findings=(*report.findings, *extra))
    return SitlResult(report, telemetry, up.summary(), vehicle, ardupilot)


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
