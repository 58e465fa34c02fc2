"""What a vehicle reports while it flies, recorded: the :class:`Recorder` the driver runs and
the :class:`Telemetry` it yields, as a track to score or a track file to keep.

Times are vehicle seconds (``time_boot_ms``), so a sped-up SITL vehicle's track is in its own
simulated time; altitudes metres above home.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from validator.flight import Flight
from validator.geodesy import from_int_e7
from validator.mavlink.connection import Connection, LinkError
from validator.mavlink.modes import mode_name
from validator.mavlink.wire import mavlink
from validator.replay import Track
from validator.site import Site
from validator.track_file import RecordedTrack

# Vehicle seconds without a position report that make a gap in the recorded track: telemetry
# comes at 20 Hz, so even a link losing a third of its packets leaves nothing this long.
LINK_GAP_S = 1.0
# How long a recording that ends at the disarm waits for a position report after it (wall s)
DISARM_GRACE_S = 1.0
# Messages that carry the vehicle's clock (time_boot_ms). Position reports alone do not keep
# time: PX4 stops GLOBAL_POSITION_INT once its estimate has no position (a GPS loss), and the
# failsafe's mode change and messages after it must not all carry the last report's time.
CLOCK_MESSAGES = frozenset({"GLOBAL_POSITION_INT", "ATTITUDE", "SYSTEM_TIME"})


def vehicle_time_s(m: Any) -> float | None:
    """The vehicle time (s since boot) a message carries, None if it carries none."""
    return m.time_boot_ms / 1000.0 if m.get_type() in CLOCK_MESSAGES else None


class LinkLost(LinkError):
    """The vehicle fell silent for the link's whole timeout during a flight; ``t_s`` is the
    vehicle time of its last report."""

    def __init__(self, message: str, t_s: float) -> None:
        super().__init__(message)
        self.t_s = t_s


def track_gaps(t_s: NDArray[np.float64], min_gap_s: float = LINK_GAP_S
               ) -> list[tuple[float, float]]:
    """(start, length) in vehicle seconds of each stretch longer than ``min_gap_s`` between
    two consecutive position reports: what a recorded track misses."""
    t = np.asarray(t_s, dtype=float)
    t = t[np.isfinite(t)]
    if t.size < 2:
        return []
    dt = np.diff(t)
    return [(float(t[i]), float(dt[i])) for i in np.flatnonzero(dt > min_gap_s)]


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
    NAV_TAKEOFF and MISSION_START were asked for; ``end_reason`` why recording stopped;
    ``link_lost`` the verdict when the link went down for good (empty when it did not).
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
    link_lost: str = ""

    @property
    def samples(self) -> int:
        return int(self.t_s.size)

    def gaps(self, min_gap_s: float = LINK_GAP_S) -> list[tuple[float, float]]:
        """The gaps in the track from the takeoff on (:func:`track_gaps`)."""
        return track_gaps(self.t_s[self.t_s >= self.flight_start_s], min_gap_s)

    @property
    def flight_start_s(self) -> float:
        """The vehicle time a recorded track's clock starts at: the takeoff request, else the
        mission start, else 0 (the replay's clock starts at the takeoff)."""
        if math.isfinite(self.takeoff_start_s):
            return self.takeoff_start_s
        return self.mission_start_s if math.isfinite(self.mission_start_s) else 0.0


class Recorder:
    """Accumulates telemetry rows while the driver waits for things: it listens to every
    message the link reads, whatever the driver is waiting for."""

    def __init__(self, link: Connection) -> None:
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
                raise LinkLost(f"the vehicle stopped reporting for {self.link.timeout_s:g} s "
                               "during the flight", self.t_s)
            self.link.recv((), min(until, now + 0.05))  # messages reach take() as listener

    def pump_vehicle_time(self, limit_s: float, stop: Callable[[], bool],
                          since_s: float | None = None) -> bool:
        """Record until ``stop()`` or until ``limit_s`` vehicle seconds have passed (since
        ``since_s``, or now)."""
        t0 = self.t_s if since_s is None else since_s

        def done() -> bool:
            if stop():
                return True
            return math.isfinite(t0) and math.isfinite(self.t_s) and self.t_s - t0 >= limit_s

        self.pump(math.inf, done)
        return bool(stop())

    def disarm_recorded(self, grace_s: float = DISARM_GRACE_S) -> Callable[[], bool]:
        """A stop for :meth:`pump`: the vehicle has disarmed and a position report since is
        recorded (so the track ends on a sample marked disarmed), or ``grace_s`` wall seconds
        have passed since the disarm without one. Stopping on the disarm HEARTBEAT alone ends
        the track on the sample before it, still marked armed."""
        disarmed_at: float | None = None

        def done() -> bool:
            nonlocal disarmed_at
            if self.armed:
                return False
            if self.rows and not self.rows[-1][8]:
                return True
            if disarmed_at is None:
                disarmed_at = time.monotonic()
            return time.monotonic() - disarmed_at >= grace_s

        return done

    def take(self, m: Any) -> None:
        """Fold one pymavlink message into the state (fields are its attributes); the link
        calls this for every message it reads from the vehicle."""
        self.last_heard = time.monotonic()
        kind = m.get_type()
        clock_s = vehicle_time_s(m)
        if clock_s is not None and not self.t_s >= clock_s:
            self.t_s = clock_s  # later only: one overtaken on the link does not turn it back
        if kind == "GLOBAL_POSITION_INT":
            t_s = m.time_boot_ms / 1000.0
            if self.rows and t_s <= self.rows[-1][0]:
                return  # a duplicate, or overtaken on the link: its time is already past
            self.home_amsl_m = (m.alt - m.relative_alt) / 1000.0
            self.rows.append((t_s, float(from_int_e7(m.lat)), float(from_int_e7(m.lon)),
                              m.relative_alt / 1000.0,
                              m.vx / 100.0, m.vy / 100.0, m.vz / 100.0,
                              self.seq, self.armed, self.breach))
        elif kind in ("HEARTBEAT", "CURRENT_MODE"):
            # CURRENT_MODE, when asked for, comes as the mode changes: a 1 Hz heartbeat is up
            # to a second late (PX4 SIH GPS losses: the failsafe seen 1-2 s after it fired)
            if kind == "HEARTBEAT":
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
                  end_reason: str, link_lost: str = "") -> Telemetry:
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
            link_lost=link_lost,
        )


def telemetry_track(telemetry: Telemetry, flight: Flight, site: Site, *, ardupilot: bool,
                    source: str) -> Track:
    """The recorded flight from NAV_TAKEOFF on as a :class:`Track` aligned with ``flight``,
    its clock starting at the takeoff like the replay's: :func:`recorded_track`'s, scored as a
    track file of it is (:meth:`~validator.track_file.RecordedTrack.track`: the climb before
    MISSION_START is the takeoff item; items are timed up to the first time the vehicle left
    the mission mode on its own, ``mode_changes``: a failsafe's return is no cycle flown)."""
    return recorded_track(telemetry, ardupilot=ardupilot).track(flight, site, source)


def recorded_track(telemetry: Telemetry, *, ardupilot: bool) -> RecordedTrack:
    """The telemetry as a :class:`~validator.track_file.RecordedTrack`: times from the start
    of the takeoff, mission items as ``.plan`` indices (ArduPilot's home, 0, is -1), and
    ``left_mission`` from the first of ``mode_changes``."""
    # ArduPilot's seq is the item number (home 0), PX4's the index: validator.item_numbers
    seq = telemetry.mission_seq - (1 if ardupilot else 0)
    left = min((s for s, _ in telemetry.mode_changes), default=math.inf)
    return RecordedTrack(telemetry.t_s - telemetry.flight_start_s, telemetry.lat_deg,
                         telemetry.lon_deg, telemetry.rel_alt_m, telemetry.vel_mps,
                         np.where(telemetry.mission_seq < 0, -1, seq).astype(np.int64),
                         telemetry.armed, telemetry.fence_breach, telemetry.t_s >= left)
