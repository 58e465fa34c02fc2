"""The simulated copter's flight: its state, the mode changes, arming and takeoff ArduCopter
allows, and how it moves in simulated time (AUTO along the replay of its mission, other modes
by the point follower), with the reports each change sends. Its home is where it armed until
a mission's DO_SET_HOME (:mod:`validator.flight.home`) or a ground station's
(:meth:`Copter.set_home_here`, :meth:`Copter.set_home_at`) moves it: RTL flies there, and
HOME_POSITION, the relative altitude and the downloaded mission's item 0 report it, as
ArduCopter's do."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from validator.errors import InputError
from validator.fence_geometry import LocalFence, local_fence
from validator.flight import Home
from validator.geodesy import LocalFrame
from validator.mavlink.autoflight import AutoTrack, build_auto_track
from validator.mavlink.sim import telemetry
from validator.mavlink.sim.arducopter import ARMABLE_MODES, CopterMode
from validator.mavlink.sim.config import VehicleConfig
from validator.mavlink.sim.fence import BREACH_MODES, NO_FENCE, breached
from validator.mavlink.sim.params import ParamTable
from validator.mavlink.sim.physics import FollowLimits, follow
from validator.mavlink.wire import MissionType, WireLists, mavlink, wire_to_plan
from validator.plan_format import Plan

# Modes that hold the vehicle where it is when entered (outside AUTO, RTL and LAND)
HOLDING_MODES = frozenset({CopterMode.GUIDED, CopterMode.LOITER, CopterMode.POSHOLD,
                           CopterMode.BRAKE, CopterMode.ALT_HOLD, CopterMode.STABILIZE})
LAND_SPEED_BELOW_M = 10.0  # descending to the ground, LAND_SPEED applies below this height
# Copter::far_from_EKF_origin (EKF_ORIGIN_MAX_ALT_KM 50): a home further above or below the EKF
# origin (here the first home) is refused
EKF_ORIGIN_MAX_ALT_M = 50_000.0


class Copter:
    """The flight state (simulated seconds, metres east/north/up of the first home, where the
    ground is) and what changes it.

    The transitions (:meth:`arm`, :meth:`set_mode`, :meth:`takeoff`, :meth:`mission_start`,
    :meth:`set_current`, :meth:`change_speed`) return a MAV_RESULT. ``mav`` sends the
    reports; ``lists`` reads the lists the vehicle holds."""

    def __init__(self, config: VehicleConfig, frame: LocalFrame, param_table: ParamTable,
                 mav: Any, lists: Callable[[], WireLists]) -> None:
        self.config = config
        self.frame = frame
        self.param_table = param_table
        self.mav = mav
        self._lists = lists
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
        self._auto_homes = 0  # its homes already set
        self.home = Home(np.zeros(2))  # the home in force: RTL's destination
        self._home_locked = False  # set by a ground station's DO_SET_HOME (ahrs.lock_home)
        self._fence: LocalFence = NO_FENCE
        self.breach = False
        self.breach_count = 0
        self.breach_time_ms = 0
        self.guided_speed_mps: float | None = None

    def lists(self) -> WireLists:
        """The mission, fence and rally lists the vehicle holds."""
        return self._lists()

    @property
    def params(self) -> dict[str, list[float]]:
        """Name -> [value in ArduCopter's units, MAV_PARAM_TYPE]."""
        return self.param_table.values

    def _param(self, name: str) -> float:
        return self.param_table.value(name)

    def _param_si(self, name: str) -> float:
        return self.param_table.si(name)

    def _plan_of(self, lists: WireLists) -> Plan:
        return wire_to_plan(lists, home_item=True, home=self.config.home)

    def list_changed(self, mission_type: int) -> None:
        """A ground station stored a new list: a fence applies at once, a new mission starts
        from its first item (unless AUTO is flying the old one)."""
        if mission_type == MissionType.FENCE:
            self._fence = local_fence(self._plan_of(self.lists()), self.frame)
        elif mission_type == MissionType.MISSION and self._auto is None:
            self.current_seq = 1
            self.mission_complete = False

    # -- transitions -----------------------------------------------------------------------

    def arm(self, arm: bool, force: bool) -> int:
        m = mavlink
        if arm:
            if self.armed:
                return m.MAV_RESULT_ACCEPTED
            if self.mode not in ARMABLE_MODES:
                self.say(f"Arm: Mode not armable ({self.mode.name})")
                return m.MAV_RESULT_FAILED
            if not self._home_locked:  # AP_Arming_Copter::arm: a ground station's home stays
                self._set_home(Home(self.xy.copy(), None, self.alt_m))
            self.armed = True
            self.say("Arming motors")
            return m.MAV_RESULT_ACCEPTED
        if not self.landed and not force:
            self.say("Disarm: still flying")
            return m.MAV_RESULT_FAILED
        self._disarm()
        return m.MAV_RESULT_ACCEPTED

    def _disarm(self) -> None:
        self.armed = False
        self.vel[:] = 0.0
        self._auto = None
        self._target = None
        self.say("Disarming motors")

    def set_mode(self, number: int) -> int:
        m = mavlink
        try:
            mode = CopterMode(number)
        except ValueError:
            return m.MAV_RESULT_UNSUPPORTED
        if mode == CopterMode.AUTO and len(self.lists().mission) <= 1:
            self.say("Mode change failed: AUTO requires a mission")
            return m.MAV_RESULT_FAILED
        previous = self.mode
        self.mode = mode
        self._land_after_target = False
        if mode == CopterMode.AUTO:
            if previous != CopterMode.AUTO:
                self._start_auto(self.current_seq)
        else:
            self._auto = None
            if mode in HOLDING_MODES:
                self._hold_here()
            elif mode == CopterMode.RTL:
                rtl_alt = self.home.alt_m + self._param_si("RTL_ALT")  # above the home in force
                self._target = (self.home.xy_m.copy(), max(self.alt_m, rtl_alt))
                self._land_after_target = True
            elif mode == CopterMode.LAND:
                self._target = (self.xy.copy(), 0.0)
        return m.MAV_RESULT_ACCEPTED

    def _hold_here(self) -> None:
        self._target = None if self.landed else (self.xy.copy(), self.alt_m)

    def takeoff(self, alt_m: float) -> int:
        m = mavlink
        if self.mode != CopterMode.GUIDED or not self.armed or not self.landed or not alt_m > 0:
            return m.MAV_RESULT_FAILED
        self.landed = False
        self._target = (self.xy.copy(), float(alt_m))
        return m.MAV_RESULT_ACCEPTED

    def mission_start(self, first: int) -> int:
        m = mavlink
        if not self.armed:
            return m.MAV_RESULT_FAILED
        if self.mode != CopterMode.AUTO:
            result = self.set_mode(CopterMode.AUTO)
            if result != m.MAV_RESULT_ACCEPTED:
                return result
        start = first if first > 0 else (1 if self.mission_complete else self.current_seq)
        self._start_auto(start)
        return m.MAV_RESULT_ACCEPTED

    def set_current(self, seq: int) -> int:
        n = len(self.lists().mission)
        if not 1 <= seq < n:
            return mavlink.MAV_RESULT_DENIED
        self.current_seq = seq
        self.mission_complete = False
        if self.mode == CopterMode.AUTO and self.armed:
            self._start_auto(seq)
        self.send_mission_current()
        return mavlink.MAV_RESULT_ACCEPTED

    def change_speed(self, speed_mps: float) -> int:
        if self.mode == CopterMode.AUTO or not speed_mps > 0:
            return mavlink.MAV_RESULT_DENIED  # AUTO follows the mission's own speeds
        self.guided_speed_mps = float(speed_mps)
        return mavlink.MAV_RESULT_ACCEPTED

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
                profile=self.param_table.profile(),
                dt_s=1.0 / self.config.telemetry_hz,
            )
        except InputError as err:  # a mission ArduCopter would refuse to fly
            self.say(f"Mission: {err}"[:50])
            self._auto = None
        if self._auto is None:
            self.mission_complete = True
            self._hold_here()
            self.send_mission_current()
            return
        self._auto_t0 = self.t_s
        self._auto_reached = 0
        self._auto_homes = 0
        self.landed = False
        self.send_mission_current()

    def step(self, t_s: float, dt_s: float) -> None:
        """Advance the flight to simulated time ``t_s`` and send its telemetry."""
        self.t_s = t_s
        if self.armed and self.mode == CopterMode.AUTO and self._auto is not None:
            self._step_auto(t_s)
        elif self.armed and self._target is not None:
            self._step_target(dt_s)
        else:
            self.vel[:] = 0.0
        self._check_fence()
        self.send_position()

    def _step_auto(self, t_s: float) -> None:
        auto = self._auto
        assert auto is not None
        tau = t_s - self._auto_t0
        xy, alt, vel = auto.state_at(tau)
        self.xy, self.alt_m, self.vel = xy, alt, vel
        while self._auto_homes < len(auto.homes) and auto.homes[self._auto_homes][0] <= tau:
            # the resolved flight's home; param1 1: where the flown track is (AutoTrack.homes)
            self._set_home(auto.homes[self._auto_homes][1])
            self._auto_homes += 1
        while self._auto_reached < len(auto.reached) and auto.reached[self._auto_reached][0] <= tau:
            index = auto.reached[self._auto_reached][1]
            self._auto_reached += 1
            self.mav.mission_item_reached_send(index + 1)
            self.current_seq = min(index + 2, max(1, len(self.lists().mission) - 1))
            self.send_mission_current()
        seq_now = auto.current_index_at(tau)
        if seq_now + 1 != self.current_seq and not self.mission_complete:
            self.current_seq = seq_now + 1
            self.send_mission_current()
        if tau >= auto.duration_s and auto.completes:
            self.mission_complete = True
            self._auto = None
            if auto.lands:
                self.alt_m = 0.0
                self.landed = True
                self._disarm()
            else:
                self._target = (self.xy.copy(), self.alt_m)
            self.say("Mission complete")
            self.send_mission_current()

    def _step_target(self, dt_s: float) -> None:
        """Towards the hold/goto target (:func:`~.physics.follow`); on arrival RTL descends
        to land, and a vehicle that reaches the ground lands and disarms."""
        assert self._target is not None
        target_xy, target_alt = self._target
        speed_h = self.guided_speed_mps or self._param_si("WPNAV_SPEED")
        if self.mode == CopterMode.RTL and self._param("RTL_SPEED") > 0:
            speed_h = self._param_si("RTL_SPEED")
        down = self._param_si("WPNAV_SPEED_DN")
        if self.mode == CopterMode.LAND or (target_alt == 0.0
                                            and self.alt_m < LAND_SPEED_BELOW_M):
            down = self._param_si("LAND_SPEED")
        limits = FollowLimits(speed_mps=speed_h, accel_mps2=self._param_si("WPNAV_ACCEL"),
                              up_mps=self._param_si("WPNAV_SPEED_UP"), down_mps=down)
        moved = follow(self.xy, self.vel, self.alt_m, target_xy, target_alt, dt_s, limits)
        self.xy, self.vel, self.alt_m = moved.xy, moved.vel, moved.alt_m
        if moved.at_target and self._land_after_target:
            self._target = (target_xy, 0.0)
            self._land_after_target = False
        elif target_alt == 0.0 and self.alt_m <= 0.01:
            self.alt_m = 0.0
            self.landed = True
            self._target = None
            self._disarm()

    def _check_fence(self) -> None:
        if self._param("FENCE_ENABLE") < 0.5 or not self.armed or self.landed:
            now_breached = False
        else:
            now_breached = breached(self._fence, self.xy)
        if now_breached and not self.breach:
            self.breach_count += 1
            self.breach_time_ms = int(self.t_s * 1000)
            self.say("Fence Breached")
            mode = BREACH_MODES.get(int(self._param("FENCE_ACTION")))
            if mode is not None:
                self.set_mode(mode)
        if now_breached != self.breach:
            self.breach = now_breached
            self.send_fence_status()

    def set_home_here(self) -> None:
        """A ground station's home where the vehicle is, altitude included
        (``set_home_to_current_location(true)``), locked: arming no longer moves it."""
        self._set_home(Home(self.xy.copy(), None, self.alt_m))
        self._home_locked = True

    def set_home_at(self, lat_deg: float, lon_deg: float, amsl_m: float) -> bool:
        """A ground station's home at a location (``Copter::set_home(loc, true)``,
        ``AP_AHRS::set_home``), locked as :meth:`set_home_here`'s: False (home unchanged) at
        0°, 0°, 0 m, beyond ±90° / ±180°, or more than :data:`EKF_ORIGIN_MAX_ALT_M` above or
        below the first home (``amsl_m`` above sea level)."""
        if lat_deg == 0 and lon_deg == 0 and amsl_m == 0:
            return False
        if not (abs(lat_deg) <= 90.0 and abs(lon_deg) <= 180.0):
            return False
        alt_m = amsl_m - self.config.home[2]
        if not abs(alt_m) <= EKF_ORIGIN_MAX_ALT_M:
            return False
        xy = np.asarray(self.frame.to_local(lat_deg, lon_deg), dtype=float).reshape(2)
        self._set_home(Home(xy, None, alt_m))
        self._home_locked = True
        return True

    def _set_home(self, home: Home) -> None:
        """The one way home changes (arming, the mission's DO_SET_HOME, a command's)."""
        self.home = home
        self.send_home_position()  # AP_AHRS::set_home sends it unasked

    # -- reports ---------------------------------------------------------------------------

    @property
    def home_lla(self) -> tuple[float, float, float]:
        """The home in force: latitude, longitude (degrees), altitude (m above sea level)."""
        if not self.home.xy_m.any() and self.home.alt_m == 0.0:
            return self.config.home  # exactly, not through the frame and back
        lat, lon = self.frame.to_geodetic(self.home.xy_m)
        return float(lat), float(lon), self.config.home[2] + self.home.alt_m

    def send_home_position(self) -> None:
        telemetry.send_requested(self.mav, mavlink.MAVLINK_MSG_ID_HOME_POSITION, self.home_lla)

    def say(self, text: str) -> None:
        telemetry.say(self.mav, text)

    def send_position(self) -> None:
        lat, lon = self.frame.to_geodetic(self.xy)
        telemetry.send_position(self.mav, self.t_s, lat, lon, self.config.home[2] + self.alt_m,
                                self.alt_m - self.home.alt_m, self.vel)

    def send_mission_current(self) -> None:
        telemetry.send_mission_current(self.mav, self.current_seq, len(self.lists().mission),
                                       complete=self.mission_complete,
                                       flying=self._auto is not None, mode=self.mode)

    def send_fence_status(self) -> None:
        if self._param("FENCE_ENABLE") < 0.5:
            return
        telemetry.send_fence_status(self.mav, self.breach, self.breach_count,
                                    self.breach_time_ms)

    def send_slow(self) -> None:
        """What ArduCopter sends once a second."""
        telemetry.send_heartbeat(self.mav, self.mode, self.armed, self.landed)
        self.send_mission_current()
        self.send_fence_status()
