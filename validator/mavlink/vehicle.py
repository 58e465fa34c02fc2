"""A software-in-the-loop multicopter that speaks MAVLink 2 as an ArduCopter does.

:class:`SitlVehicle` listens on a pymavlink connection string (normally ``udpin:HOST:PORT``)
and behaves like ArduCopter 4.x towards a ground station:

- HEARTBEAT as MAV_AUTOPILOT_ARDUPILOTMEGA / MAV_TYPE_QUADROTOR with ArduCopter's custom mode
  numbers (STABILIZE 0, AUTO 3, GUIDED 4, LOITER 5, RTL 6, LAND 9, BRAKE 17);
- the vehicle side of the mission protocol for mission, fence and rally lists, done by
  MAVSDK's ``MissionRawServer`` through a ``raw://`` connection: this class owns the socket and
  hands MAVSDK the mission-protocol packets only, so MAVSDK's generic heartbeat and our
  ArduCopter telemetry do not fight over one port, and ``loss`` applies to MAVSDK's packets too;
- arming (COMPONENT_ARM_DISARM), modes (DO_SET_MODE, SET_MODE), NAV_TAKEOFF in GUIDED,
  MISSION_START, MISSION_SET_CURRENT, RTL and LAND, parameters (PARAM_*), REQUEST_MESSAGE for
  HOME_POSITION and AUTOPILOT_VERSION;
- flying the uploaded mission in AUTO along the validator's replay of it (the same dynamics
  model; see :mod:`validator.mavlink.autoflight`), GLOBAL_POSITION_INT at ``telemetry_hz``
  (simulated seconds), MISSION_CURRENT, MISSION_ITEM_REACHED, EXTENDED_SYS_STATE and
  FENCE_STATUS (breach of any uploaded fence circle or polygon).

Time is simulated: ``speedup`` simulated seconds pass per wall second, and every timestamp the
vehicle sends (``time_boot_ms``) is simulated time. ``loss`` drops that fraction of packets at
random in each direction (seeded). With ``signing_key`` it signs everything it sends (MAVSDK's
answers re-signed as a second stream) and ignores every packet not signed with that key, as
ArduPilot does on a signed port (:mod:`validator.mavlink.signing`). Differences from
ArduCopter, on purpose: the fence is on and report-only by default (``FENCE_ENABLE`` 1,
``FENCE_ACTION`` 0; set ``FENCE_ACTION`` 1 for RTL, 2 for LAND, 4 for BRAKE); outside AUTO the
vehicle moves by a plain speed- and acceleration-limited point follower.
"""

from __future__ import annotations

import logging
import math
import queue
import random
import select
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any

import numpy as np
from numpy.typing import NDArray

from validator.errors import InputError
from validator.fence_geometry import local_fence
from validator.geodesy import LocalFrame, to_int_e7
from validator.mavlink.autoflight import AutoTrack, build_auto_track, vehicle_profile, vehicle_site
from validator.mavlink.signing import sign_and_verify
from validator.mavlink.wire import (
    MissionType,
    WireItem,
    WireLists,
    mavlink,
    mavutil,
    wire_to_plan,
)
from validator.plan_format import Plan

log = logging.getLogger(__name__)

MAVLINK_PACKET_TYPES_FOR_MAVSDK = frozenset({
    "MISSION_COUNT", "MISSION_ITEM_INT", "MISSION_ITEM", "MISSION_REQUEST_LIST",
    "MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK", "MISSION_CLEAR_ALL", "HEARTBEAT",
})
MAVSDK_PACKET_TYPES_TO_GCS = frozenset({
    "MISSION_COUNT", "MISSION_ITEM_INT", "MISSION_ITEM", "MISSION_REQUEST_INT",
    "MISSION_REQUEST", "MISSION_ACK",
})
FORCE_DISARM_MAGIC = 21196
MISSION_CURRENT_PERIOD_S = 0.2  # simulated seconds; HEARTBEAT and the rest once a second


class CopterMode(IntEnum):
    """ArduCopter custom mode numbers (HEARTBEAT.custom_mode) this vehicle flies."""

    STABILIZE = 0
    ALT_HOLD = 2
    AUTO = 3
    GUIDED = 4
    LOITER = 5
    RTL = 6
    LAND = 9
    POSHOLD = 16
    BRAKE = 17


ARMABLE_MODES = frozenset({CopterMode.STABILIZE, CopterMode.ALT_HOLD, CopterMode.GUIDED,
                           CopterMode.LOITER, CopterMode.POSHOLD})

REAL32 = int(mavlink.MAV_PARAM_TYPE_REAL32)
INT8 = int(mavlink.MAV_PARAM_TYPE_INT8)
INT16 = int(mavlink.MAV_PARAM_TYPE_INT16)

# ArduCopter's names, units (cm, cm/s, cm/s^2 as ArduCopter keeps them) and defaults, except
# the fence, which is on and report-only here so a validation sees every breach. The flight
# profile's own parameters (validator.motion.profile.PARAM_SPECS) are added to these.
BASE_PARAMS: dict[str, tuple[float, int]] = {
    "WPNAV_SPEED": (1000.0, REAL32),
    "WPNAV_ACCEL": (250.0, REAL32),
    "WPNAV_JERK": (1.0, REAL32),
    "WPNAV_SPEED_UP": (250.0, REAL32),
    "WPNAV_SPEED_DN": (150.0, REAL32),
    "LAND_SPEED": (50.0, INT16),
    "RTL_ALT": (1500.0, INT16),
    "RTL_SPEED": (0.0, INT16),
    "FENCE_ENABLE": (1.0, INT8),
    "FENCE_TYPE": (7.0, INT8),
    "FENCE_ACTION": (0.0, INT8),
}
SITL_TOP_SPEED_MPS = 10.4  # ArduPilot's SITL quad at ANGLE_MAX 30 deg (mavlink-facts.md)


@dataclass(frozen=True)
class VehicleConfig:
    """How the simulated vehicle starts and runs.

    ``home`` is (lat deg, lon deg, alt m AMSL); ``speedup`` simulated seconds per wall second;
    ``loss`` the fraction of packets dropped in each direction (``seed`` makes it repeatable);
    ``telemetry_hz`` the GLOBAL_POSITION_INT rate in simulated time; ``profile`` the flight
    model flown in AUTO (:data:`validator.motion.profile.PROFILES`); ``params`` initial parameter
    values (autopilot units) over ArduCopter's defaults; ``max_speed_mps`` the vehicle's top
    speed (the profile's VEHICLE_SPEED_MAX default); ``signing_key`` a MAVLink 2 signing key.
    """

    home: tuple[float, float, float]
    system_id: int = 1
    speedup: float = 1.0
    loss: float = 0.0
    seed: int = 0
    telemetry_hz: float = 20.0
    profile: str = "arducopter"
    params: Mapping[str, float] = field(default_factory=dict)
    max_speed_mps: float = SITL_TOP_SPEED_MPS
    signing_key: bytes | None = None  # sign, and refuse what is not signed (mavlink.signing)


class LossyWriter:
    """A ``write(bytes)`` target that drops packets at random (thread-safe, seeded)."""

    def __init__(self, conn: Any, loss: float, rng: random.Random) -> None:
        self.conn = conn
        self.loss = loss
        self.rng = rng
        self.lock = threading.Lock()
        self.sent = 0
        self.dropped = 0

    def write(self, buf: bytes) -> None:
        with self.lock:
            if self.loss > 0 and self.rng.random() < self.loss:
                self.dropped += 1
                return
            self.sent += 1
            try:
                self.conn.write(buf)
            except OSError:
                # No peer yet, or it went away: a radio would lose this packet too.
                self.dropped += 1


@dataclass
class _Fence:
    """Fence areas in the vehicle's local frame (metres east/north of home)."""

    circles: list[tuple[NDArray[np.float64], float, bool]]  # centre, radius, inclusion
    polygons: list[tuple[Any, bool]]  # shapely Polygon, inclusion

    def breached(self, xy: NDArray[np.float64]) -> bool:
        for centre, radius, inclusion in self.circles:
            inside = float(np.hypot(*(xy - centre))) < radius
            if inside != inclusion:
                return True
        if self.polygons:
            from shapely.geometry import Point

            p = Point(float(xy[0]), float(xy[1]))
            for poly, inclusion in self.polygons:
                if poly.contains(p) != inclusion:
                    return True
        return False


def _fence_of(plan: Plan, frame: LocalFrame) -> _Fence:
    fence = local_fence(plan, frame)
    return _Fence(fence.circles, fence.polygons)


class SitlVehicle:
    """The simulated ArduCopter. ``start()`` runs it in a background thread, ``stop()`` ends
    it; or call :meth:`run` in the foreground. ``address`` is the bound (host, port)."""

    def __init__(self, listen_url: str, config: VehicleConfig) -> None:
        if not config.speedup > 0:
            raise ValueError("speedup must be > 0")
        if not 0.0 <= config.loss < 1.0:
            raise ValueError("loss must be in [0, 1)")
        if not listen_url.startswith(("udpin:", "udp:")):
            raise ValueError("listen on UDP, e.g. udpin:127.0.0.1:14550")
        self.config = config
        self.frame = LocalFrame(*config.home)
        self.site = vehicle_site(self.frame, config.max_speed_mps)
        profile = vehicle_profile(config.profile, self.site,
                                  {**{k: v for k, (v, _) in BASE_PARAMS.items()}, **config.params})
        self.params: dict[str, list[float]] = {k: [v, t] for k, (v, t) in BASE_PARAMS.items()}
        for name, value in profile.params.items():
            self.params[name] = [float(value), float(REAL32)]
        for name, value in config.params.items():
            if name not in self.params:
                raise InputError(f"--param {name}: the vehicle has no such parameter")
            self.params[name][0] = float(value)
        self.params["SYSID_THISMAV"] = [float(config.system_id), float(INT16)]
        self.conn = mavutil.mavlink_connection(listen_url, source_system=config.system_id,
                                               source_component=1)
        rng = random.Random(config.seed)
        self._rx_rng = random.Random(rng.random())
        self.writer = LossyWriter(self.conn, config.loss, random.Random(rng.random()))
        self.mav = mavlink.MAVLink(self.writer, srcSystem=config.system_id, srcComponent=1)
        # MAVSDK's answers, re-signed as a second stream (link id 1) when signing is on
        self._mavsdk_signer: Any = None
        self._mavsdk_signer_lock = threading.Lock()
        if config.signing_key is not None:
            sign_and_verify(self.conn.mav, config.signing_key)  # refuses unsigned input
            sign_and_verify(self.mav, config.signing_key)
            self._mavsdk_signer = mavlink.MAVLink(self.writer, srcSystem=config.system_id,
                                                  srcComponent=1)
            sign_and_verify(self._mavsdk_signer, config.signing_key, link_id=1)
        self._lists_lock = threading.Lock()
        self._lists: dict[int, tuple[WireItem, ...]] = {0: (), 1: (), 2: ()}
        self._completed: dict[int, int] = {}  # mission_type -> items of its finished upload
        self._fence = _Fence([], [])
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._mavsdk: Any = None
        self._mission_server: Any = None
        self._out_parser = mavlink.MAVLink(None)
        self._out_parser.robust_parsing = True
        # flight state (simulated seconds, metres east/north/up of home)
        self.t_s = 0.0
        self.xy = np.zeros(2)
        self.alt_m = 0.0
        self.vel = np.zeros(3)
        self.armed = False
        self.landed = True
        self.mode = CopterMode.STABILIZE
        self.current_seq = 1  # ArduPilot: 0 is home
        self.mission_complete = False
        self._target: tuple[NDArray[np.float64], float] | None = None  # hold/goto target
        self._land_after_target = False
        self._auto: AutoTrack | None = None
        self._auto_t0 = 0.0
        self._auto_reached = 0  # events of self._auto already sent
        self.breach = False
        self.breach_count = 0
        self.breach_time_ms = 0
        self.guided_speed_mps: float | None = None
        self._updates: queue.SimpleQueue[int] = queue.SimpleQueue()
        self._last_command: tuple[tuple[int, int, int] | None, int] = (None, 0)
        self.rx_dropped = 0

    # -- lifecycle -------------------------------------------------------------------------

    @property
    def address(self) -> tuple[str, int]:
        host, port = self.conn.port.getsockname()[:2]
        return str(host), int(port)

    def start(self) -> SitlVehicle:
        """Run in a daemon thread; returns at once."""
        self._start_mavsdk()
        self._thread = threading.Thread(target=self._loop, name="sitl-vehicle", daemon=True)
        self._thread.start()
        return self

    def run(self) -> None:
        """Run in the calling thread until :meth:`stop` (or KeyboardInterrupt)."""
        self._start_mavsdk()
        try:
            self._loop()
        finally:
            self._close()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
            self._close()

    def __enter__(self) -> SitlVehicle:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _close(self) -> None:
        if self._mavsdk is not None:
            self._mavsdk.destroy()
            self._mavsdk = None
            self._mission_server = None
        self.conn.close()

    # -- MAVSDK mission server -------------------------------------------------------------

    def _start_mavsdk(self) -> None:
        from mavsdk import Configuration, Mavsdk
        from mavsdk.plugins.mission_raw_server import MissionRawServer, MissionRawServerResult

        _quiet_mavsdk_log()
        cfg = Configuration.create_manual(self.config.system_id, 1, False)
        self._mavsdk = Mavsdk(cfg)
        self._mavsdk.add_any_connection("raw://")
        self._mavsdk.subscribe_raw_bytes_to_be_sent(self._from_mavsdk)
        self._mission_server = MissionRawServer(self._mavsdk.server_component())

        def incoming(result: Any, plan: Any, _ud: Any) -> None:
            if result != MissionRawServerResult.SUCCESS:
                return
            items = tuple(
                WireItem(int(i.seq), int(i.frame), int(i.command), float(i.param1),
                         float(i.param2), float(i.param3), float(i.param4), int(i.x), int(i.y),
                         float(i.z), int(i.mission_type), int(i.autocontinue))
                for i in plan.mission_items
            )
            if not items:
                return  # MAVSDK does not say which list is empty: see MISSION_COUNT in _handle
            self._completed[items[0].mission_type] = len(items)
            self._set_list(items[0].mission_type, items)

        def cleared(mission_type: int, _ud: Any) -> None:
            types = [0, 1, 2] if mission_type == 255 else [int(mission_type)]
            for t in types:
                self._set_list(t, ())

        self._mission_server.subscribe_incoming_mission(incoming)
        self._mission_server.subscribe_clear_all(cleared)

    def _set_list(self, mission_type: int, items: tuple[WireItem, ...]) -> None:
        """Store a list the ground station uploaded (called from MAVSDK's thread too); the
        main loop applies what follows from it (:meth:`_apply_updates`)."""
        with self._lists_lock:
            self._lists[mission_type] = items
        self._updates.put(mission_type)

    def _apply_updates(self) -> None:
        while not self._updates.empty():
            mission_type = self._updates.get()
            if mission_type == MissionType.FENCE:
                self._fence = _fence_of(self._plan_of(self.lists()), self.frame)
            elif mission_type == MissionType.MISSION and self._auto is None:
                self.current_seq = 1
                self.mission_complete = False

    def _from_mavsdk(self, data: bytes) -> None:
        """MAVSDK's outgoing bytes: pass on its mission-protocol answers, drop the rest (its
        GENERIC heartbeat, PING, AUTOPILOT_VERSION, MISSION_CURRENT)."""
        try:
            msgs = self._out_parser.parse_buffer(bytes(data)) or []
        except Exception:  # a packet we cannot parse is one we would not forward either
            return
        for msg in msgs:
            if msg.get_type() not in MAVSDK_PACKET_TYPES_TO_GCS:
                continue
            if self._mavsdk_signer is None:
                self.writer.write(bytes(msg.get_msgbuf()))
            else:
                with self._mavsdk_signer_lock:
                    self._mavsdk_signer.send(msg)

    def lists(self) -> WireLists:
        """The mission, fence and rally lists the vehicle holds."""
        with self._lists_lock:
            return WireLists(self._lists[0], self._lists[1], self._lists[2])

    def _plan_of(self, lists: WireLists) -> Plan:
        return wire_to_plan(lists, home_item=True, home=self.config.home)

    # -- main loop -------------------------------------------------------------------------

    def _loop(self) -> None:
        cfg = self.config
        step_s = 1.0 / cfg.telemetry_hz
        wall0 = time.monotonic()
        next_step = 0.0
        last_slow_wall = -1.0
        last_slow_sim = -1.0
        last_current_sim = -1.0
        fd = self.conn.port.fileno()
        while not self._stop.is_set():
            self._drain()
            self._apply_updates()
            now = time.monotonic()
            sim_now = (now - wall0) * cfg.speedup
            if sim_now - next_step > 1.0 * cfg.speedup:
                # Starved of CPU: let simulated time slip rather than burst.
                wall0 += (sim_now - next_step) / cfg.speedup
                sim_now = next_step
            while next_step <= sim_now:
                self._step(next_step, step_s)
                if next_step - last_slow_sim >= 1.0 or now - last_slow_wall >= 1.0:
                    self._send_slow()
                    last_slow_sim, last_slow_wall = next_step, now
                elif next_step - last_current_sim >= MISSION_CURRENT_PERIOD_S:
                    # often enough that a short leg shows up in a lossy recording
                    self._send_mission_current()
                    last_current_sim = next_step
                next_step += step_s
            wait = wall0 + next_step / cfg.speedup - time.monotonic()
            if wait > 0:
                select.select([fd], [], [], min(wait, 0.02))

    def _drain(self) -> None:
        while True:
            try:
                msg = self.conn.recv_msg()
            except OSError:
                return
            if msg is None:
                return
            if msg.get_type() == "BAD_DATA":
                continue
            if self.config.loss > 0 and self._rx_rng.random() < self.config.loss:
                self.rx_dropped += 1
                continue
            target = getattr(msg, "target_system", None)
            if target not in (None, 0, self.config.system_id):
                continue
            self._handle(msg)

    def _handle(self, msg: Any) -> None:
        kind = msg.get_type()
        if kind in MAVLINK_PACKET_TYPES_FOR_MAVSDK and self._mavsdk is not None:
            mtype = int(getattr(msg, "mission_type", 0))
            if kind == "MISSION_COUNT":
                self._completed.pop(mtype, None)
                if msg.count == 0:
                    self._set_list(mtype, ())
            if kind == "MISSION_ITEM_INT" and self._completed.get(mtype) == msg.seq + 1:
                # The ground station repeats the last item because our ACK was lost; MAVSDK
                # has finished and would stay silent, so answer as the protocol asks.
                self.mav.mission_ack_send(msg.get_srcSystem(), msg.get_srcComponent(),
                                          mavlink.MAV_MISSION_ACCEPTED, mtype)
                return
            self._mavsdk.pass_received_raw_bytes(bytes(msg.get_msgbuf()))
            return
        handler: Callable[[Any], None] | None = {
            "COMMAND_LONG": self._on_command,
            "COMMAND_INT": self._on_command,
            "SET_MODE": self._on_set_mode_msg,
            "PARAM_REQUEST_LIST": self._on_param_list,
            "PARAM_REQUEST_READ": self._on_param_read,
            "PARAM_SET": self._on_param_set,
            "MISSION_SET_CURRENT": self._on_set_current,
        }.get(kind)
        if handler is not None:
            handler(msg)

    # -- commands --------------------------------------------------------------------------

    def _ack(self, msg: Any, result: int) -> None:
        self.mav.command_ack_send(msg.command, result, 0, 0, msg.get_srcSystem(),
                                  msg.get_srcComponent())

    def _on_command(self, msg: Any) -> None:
        c = int(msg.command)
        key = (c, msg.get_srcSystem(), msg.get_srcComponent())
        if getattr(msg, "confirmation", 0) > 0 and self._last_command[0] == key:
            # A repeat because our ACK was lost: answer again, do not act twice.
            self._ack(msg, self._last_command[1])
            return
        result = self._execute(msg)
        if result is not None:
            self._last_command = (key, result)
            self._ack(msg, result)

    def _execute(self, msg: Any) -> int | None:
        """Carry out a COMMAND_LONG/COMMAND_INT; its MAV_RESULT, or None once answered."""
        c = int(msg.command)
        p = [msg.param1, msg.param2, msg.param3, msg.param4]
        m = mavlink
        result = m.MAV_RESULT_UNSUPPORTED
        if c == m.MAV_CMD_COMPONENT_ARM_DISARM:
            result = self._arm(p[0] > 0.5, int(round(p[1])) == FORCE_DISARM_MAGIC)
        elif c == m.MAV_CMD_DO_SET_MODE:
            if int(p[0]) & m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                result = self._set_mode(int(round(p[1])))
            else:
                result = m.MAV_RESULT_DENIED
        elif c == m.MAV_CMD_NAV_TAKEOFF:
            z = msg.z if kind_is_int(msg) else msg.param7
            result = self._takeoff(float(z))
        elif c == m.MAV_CMD_MISSION_START:
            result = self._mission_start(int(round(p[0])))
        elif c == m.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            result = self._set_mode(CopterMode.RTL)
        elif c == m.MAV_CMD_NAV_LAND:
            result = self._set_mode(CopterMode.LAND)
        elif c == m.MAV_CMD_DO_SET_MISSION_CURRENT:
            result = self._set_current(int(round(p[0])))
        elif c == m.MAV_CMD_DO_CHANGE_SPEED:
            if self.mode == CopterMode.AUTO or not p[1] > 0:
                result = m.MAV_RESULT_DENIED  # AUTO follows the mission's own speeds
            else:
                self.guided_speed_mps = float(p[1])
                result = m.MAV_RESULT_ACCEPTED
        elif c in (m.MAV_CMD_REQUEST_MESSAGE, m.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES):
            wanted = (int(round(p[0])) if c == m.MAV_CMD_REQUEST_MESSAGE
                      else m.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
            if wanted in (m.MAVLINK_MSG_ID_HOME_POSITION, m.MAVLINK_MSG_ID_AUTOPILOT_VERSION):
                self._ack(msg, m.MAV_RESULT_ACCEPTED)  # the protocol: ACK, then the message
                self._send_requested(wanted)
                return None
        elif c == m.MAV_CMD_SET_MESSAGE_INTERVAL:
            result = m.MAV_RESULT_ACCEPTED  # telemetry runs at its configured rate
        return result

    def _on_set_mode_msg(self, msg: Any) -> None:
        if msg.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            self._set_mode(int(msg.custom_mode))

    def _arm(self, arm: bool, force: bool) -> int:
        m = mavlink
        if arm:
            if self.armed:
                return m.MAV_RESULT_ACCEPTED
            if self.mode not in ARMABLE_MODES:
                self._say(f"Arm: Mode not armable ({self.mode.name})")
                return m.MAV_RESULT_FAILED
            self.armed = True
            self._say("Arming motors")
            return m.MAV_RESULT_ACCEPTED
        if not self.landed and not force:
            self._say("Disarm: still flying")
            return m.MAV_RESULT_FAILED
        self._disarm()
        return m.MAV_RESULT_ACCEPTED

    def _disarm(self) -> None:
        self.armed = False
        self.vel[:] = 0.0
        self._auto = None
        self._target = None
        self._say("Disarming motors")

    def _set_mode(self, number: int) -> int:
        m = mavlink
        try:
            mode = CopterMode(number)
        except ValueError:
            return m.MAV_RESULT_UNSUPPORTED
        if mode == CopterMode.AUTO and len(self.lists().mission) <= 1:
            self._say("Mode change failed: AUTO requires a mission")
            return m.MAV_RESULT_FAILED
        previous = self.mode
        self.mode = mode
        self._land_after_target = False
        if mode == CopterMode.AUTO:
            if previous != CopterMode.AUTO:
                self._start_auto(self.current_seq)
        else:
            self._auto = None
            if mode in (CopterMode.GUIDED, CopterMode.LOITER, CopterMode.POSHOLD,
                        CopterMode.BRAKE, CopterMode.ALT_HOLD, CopterMode.STABILIZE):
                self._hold_here()
            elif mode == CopterMode.RTL:
                rtl_alt = self._param("RTL_ALT") / 100.0
                self._target = (np.zeros(2), max(self.alt_m, rtl_alt))
                self._land_after_target = True
            elif mode == CopterMode.LAND:
                self._target = (self.xy.copy(), 0.0)
        return m.MAV_RESULT_ACCEPTED

    def _hold_here(self) -> None:
        self._target = None if self.landed else (self.xy.copy(), self.alt_m)

    def _takeoff(self, alt_m: float) -> int:
        m = mavlink
        if self.mode != CopterMode.GUIDED or not self.armed or not self.landed or not alt_m > 0:
            return m.MAV_RESULT_FAILED
        self.landed = False
        self._target = (self.xy.copy(), float(alt_m))
        return m.MAV_RESULT_ACCEPTED

    def _mission_start(self, first: int) -> int:
        m = mavlink
        if not self.armed:
            return m.MAV_RESULT_FAILED
        if self.mode != CopterMode.AUTO:
            result = self._set_mode(CopterMode.AUTO)
            if result != m.MAV_RESULT_ACCEPTED:
                return result
        start = first if first > 0 else (1 if self.mission_complete else self.current_seq)
        self._start_auto(start)
        return m.MAV_RESULT_ACCEPTED

    def _set_current(self, seq: int) -> int:
        n = len(self.lists().mission)
        if not 1 <= seq < n:
            return mavlink.MAV_RESULT_DENIED
        self.current_seq = seq
        self.mission_complete = False
        if self.mode == CopterMode.AUTO and self.armed:
            self._start_auto(seq)
        self._send_mission_current()
        return mavlink.MAV_RESULT_ACCEPTED

    def _on_set_current(self, msg: Any) -> None:
        self._set_current(int(msg.seq))

    def _send_requested(self, msg_id: int) -> int:
        m = mavlink
        if msg_id == m.MAVLINK_MSG_ID_HOME_POSITION:
            lat, lon, alt = self.config.home
            self.mav.home_position_send(int(to_int_e7(lat)), int(to_int_e7(lon)),
                                        int(round(alt * 1000)), 0.0, 0.0, 0.0,
                                        [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0)
            return m.MAV_RESULT_ACCEPTED
        if msg_id == m.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            caps = (m.MAV_PROTOCOL_CAPABILITY_MISSION_INT | m.MAV_PROTOCOL_CAPABILITY_MAVLINK2
                    | m.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
                    | m.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
                    | m.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                    | m.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST)
            version = (4 << 24) | (5 << 16) | (6 << 8) | 255  # 4.5.6 official
            self.mav.autopilot_version_send(caps, version, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8,
                                            0, 0, 0)
            return m.MAV_RESULT_ACCEPTED
        return m.MAV_RESULT_UNSUPPORTED

    # -- parameters ------------------------------------------------------------------------

    def _param(self, name: str) -> float:
        return float(self.params[name][0])

    def _send_param(self, name: str) -> None:
        names = list(self.params)
        value, ptype = self.params[name]
        self.mav.param_value_send(name.encode("ascii"), float(value), int(ptype), len(names),
                                  names.index(name))

    def _on_param_list(self, _msg: Any) -> None:
        for name in self.params:
            self._send_param(name)

    def _on_param_read(self, msg: Any) -> None:
        names = list(self.params)
        name = msg.param_id if msg.param_index < 0 else (
            names[msg.param_index] if msg.param_index < len(names) else None)
        if name in self.params:
            self._send_param(name)

    def _on_param_set(self, msg: Any) -> None:
        name = msg.param_id
        if name not in self.params or not math.isfinite(msg.param_value):
            return  # ArduPilot ignores unknown parameters: the ground station times out
        ptype = self.params[name][1]
        value = float(msg.param_value)
        if ptype != REAL32:
            value = float(int(round(value)))
        try:
            self._profile({name: value})
        except InputError:
            value = self.params[name][0]  # out of range: keep it; the reply says so
        self.params[name][0] = value
        self._send_param(name)

    def _profile(self, changes: Mapping[str, float] | None = None) -> Any:
        values = {k: float(v[0]) for k, v in self.params.items()}
        values.update(changes or {})
        return vehicle_profile(self.config.profile, self.site, values)

    # -- flight ----------------------------------------------------------------------------

    def _start_auto(self, seq: int) -> None:
        """Fly the mission from item ``seq`` (vehicle numbering, 1 = first plan item)."""
        self.current_seq = seq
        self.mission_complete = False
        self._target = None
        if not self.armed:
            self._auto = None
            return
        plan = self._plan_of(self.lists())
        try:
            self._auto = build_auto_track(
                plan,
                self.frame,
                start_index=seq - 1,
                start_xy_m=self.xy.copy(),
                start_alt_m=self.alt_m,
                profile=self._profile(),
                dt_s=1.0 / self.config.telemetry_hz,
            )
        except InputError as err:  # a mission ArduCopter would refuse to fly
            self._say(f"Mission: {err}"[:50])
            self._auto = None
        if self._auto is None:
            self.mission_complete = True
            self._hold_here()
            self._send_mission_current()
            return
        self._auto_t0 = self.t_s
        self._auto_reached = 0
        self.landed = False
        self._send_mission_current()

    def _step(self, t_s: float, dt_s: float) -> None:
        """Advance the flight to simulated time ``t_s`` and send its telemetry."""
        self.t_s = t_s
        if self.armed and self.mode == CopterMode.AUTO and self._auto is not None:
            self._step_auto(t_s)
        elif self.armed and self._target is not None:
            self._step_target(dt_s)
        else:
            self.vel[:] = 0.0
        self._check_fence()
        self._send_position()

    def _step_auto(self, t_s: float) -> None:
        auto = self._auto
        assert auto is not None
        tau = t_s - self._auto_t0
        xy, alt, vel = auto.state_at(tau)
        self.xy, self.alt_m, self.vel = xy, alt, vel
        while self._auto_reached < len(auto.reached) and auto.reached[self._auto_reached][0] <= tau:
            index = auto.reached[self._auto_reached][1]
            self._auto_reached += 1
            self.mav.mission_item_reached_send(index + 1)
            self.current_seq = min(index + 2, max(1, len(self.lists().mission) - 1))
            self._send_mission_current()
        seq_now = auto.current_index_at(tau)
        if seq_now + 1 != self.current_seq and not self.mission_complete:
            self.current_seq = seq_now + 1
            self._send_mission_current()
        if tau >= auto.duration_s and auto.completes:
            self.mission_complete = True
            self._auto = None
            if auto.lands:
                self.alt_m = 0.0
                self.landed = True
                self._disarm()
            else:
                self._target = (self.xy.copy(), self.alt_m)
            self._say("Mission complete")
            self._send_mission_current()

    def _step_target(self, dt_s: float) -> None:
        """Plain point following: speed and acceleration limited, vertical apart."""
        assert self._target is not None
        target_xy, target_alt = self._target
        accel = self._param("WPNAV_ACCEL") / 100.0
        speed_h = self.guided_speed_mps or self._param("WPNAV_SPEED") / 100.0
        if self.mode == CopterMode.RTL and self._param("RTL_SPEED") > 0:
            speed_h = self._param("RTL_SPEED") / 100.0
        d = target_xy - self.xy
        dist = float(np.hypot(*d))
        want = d / dist * min(speed_h, math.sqrt(2 * accel * dist)) if dist > 1e-6 else np.zeros(2)
        dv = want - self.vel[:2]
        n = float(np.hypot(*dv))
        if n > accel * dt_s:
            dv *= accel * dt_s / n
        self.vel[:2] += dv
        self.xy = self.xy + self.vel[:2] * dt_s
        if dist < 0.05 and float(np.hypot(*self.vel[:2])) < 0.1:
            self.xy = target_xy.copy()
            self.vel[:2] = 0.0
        dz = target_alt - self.alt_m
        up = self._param("WPNAV_SPEED_UP") / 100.0
        down = self._param("WPNAV_SPEED_DN") / 100.0
        if self.mode == CopterMode.LAND or (target_alt == 0.0 and self.alt_m < 10.0):
            down = self._param("LAND_SPEED") / 100.0
        vz = float(np.clip(dz / dt_s, -down, up))
        self.vel[2] = vz
        self.alt_m += vz * dt_s
        at_target = dist < 0.05 and abs(dz) < 0.01
        if at_target and self._land_after_target:
            self._target = (target_xy, 0.0)
            self._land_after_target = False
        elif target_alt == 0.0 and self.alt_m <= 0.01:
            self.alt_m = 0.0
            self.landed = True
            self._target = None
            self._disarm()

    def _check_fence(self) -> None:
        if self._param("FENCE_ENABLE") < 0.5 or not self.armed or self.landed:
            breached = False
        else:
            breached = self._fence.breached(self.xy)
        if breached and not self.breach:
            self.breach_count += 1
            self.breach_time_ms = int(self.t_s * 1000)
            self._say("Fence Breached")
            action = int(self._param("FENCE_ACTION"))
            if action in (1, 3, 5):
                self._set_mode(CopterMode.RTL)
            elif action == 2:
                self._set_mode(CopterMode.LAND)
            elif action == 4:
                self._set_mode(CopterMode.BRAKE)
        if breached != self.breach:
            self.breach = breached
            self._send_fence_status()

    # -- telemetry -------------------------------------------------------------------------

    def _say(self, text: str) -> None:
        self.mav.statustext_send(mavlink.MAV_SEVERITY_INFO, text.encode("ascii")[:50])

    def _send_position(self) -> None:
        lat, lon = self.frame.to_geodetic(self.xy)
        heading = math.degrees(math.atan2(self.vel[0], self.vel[1])) % 360.0
        self.mav.global_position_int_send(
            int(self.t_s * 1000),
            int(to_int_e7(lat)),
            int(to_int_e7(lon)),
            int(round((self.config.home[2] + self.alt_m) * 1000)),
            int(round(self.alt_m * 1000)),
            int(round(self.vel[1] * 100)),  # north
            int(round(self.vel[0] * 100)),  # east
            int(round(-self.vel[2] * 100)),  # down
            int(round(heading * 100)) if np.hypot(*self.vel[:2]) > 0.2 else 65535,
        )

    def _send_mission_current(self) -> None:
        n = len(self.lists().mission)
        m = mavlink
        if n <= 1:
            state = m.MISSION_STATE_NO_MISSION
        elif self.mission_complete:
            state = m.MISSION_STATE_COMPLETE
        elif self.mode == CopterMode.AUTO and self._auto is not None:
            state = m.MISSION_STATE_ACTIVE
        elif self.current_seq > 1:
            state = m.MISSION_STATE_PAUSED
        else:
            state = m.MISSION_STATE_NOT_STARTED
        self.mav.mission_current_send(self.current_seq, max(0, n - 1), state,
                                      1 if self.mode == CopterMode.AUTO else 0)

    def _send_fence_status(self) -> None:
        if self._param("FENCE_ENABLE") < 0.5:
            return
        self.mav.fence_status_send(int(self.breach), self.breach_count,
                                   mavlink.FENCE_BREACH_BOUNDARY if self.breach else 0,
                                   self.breach_time_ms, 0)

    def _send_slow(self) -> None:
        m = mavlink
        base = m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | m.MAV_MODE_FLAG_STABILIZE_ENABLED
        if self.armed:
            base |= m.MAV_MODE_FLAG_SAFETY_ARMED
        if self.mode in (CopterMode.AUTO, CopterMode.GUIDED, CopterMode.RTL):
            base |= m.MAV_MODE_FLAG_GUIDED_ENABLED
        if self.mode == CopterMode.AUTO:
            base |= m.MAV_MODE_FLAG_AUTO_ENABLED
        status = m.MAV_STATE_ACTIVE if self.armed else m.MAV_STATE_STANDBY
        self.mav.heartbeat_send(m.MAV_TYPE_QUADROTOR, m.MAV_AUTOPILOT_ARDUPILOTMEGA, base,
                                int(self.mode), status)
        landed = (m.MAV_LANDED_STATE_ON_GROUND if self.landed
                  else m.MAV_LANDED_STATE_IN_AIR)
        self.mav.extended_sys_state_send(m.MAV_VTOL_STATE_UNDEFINED, landed)
        self._send_mission_current()
        self._send_fence_status()


def kind_is_int(msg: Any) -> bool:
    """COMMAND_INT carries param5..7 as x, y, z."""
    return bool(msg.get_type() == "COMMAND_INT")


_mavsdk_log_quiet = False


def _quiet_mavsdk_log() -> None:
    """Route MAVSDK's own log lines to :mod:`logging` instead of stderr (once per process)."""
    global _mavsdk_log_quiet
    if _mavsdk_log_quiet:
        return
    from mavsdk import LogLevel, log_subscribe

    def handler(level: Any, message: str, _file: str | None, _line: int) -> bool:
        if level >= LogLevel.WARN:
            log.debug("mavsdk: %s", message)
        return True

    log_subscribe(handler)
    _mavsdk_log_quiet = True
