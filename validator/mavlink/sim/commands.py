"""What the simulated vehicle does when asked: COMMAND_LONG / COMMAND_INT, SET_MODE and
MISSION_SET_CURRENT, answered as ArduCopter answers them (one COMMAND_ACK per command, and a
repeat whose ACK was lost answered again, not carried out twice)."""

from __future__ import annotations

import math
from typing import Any

from validator.flight import DO_SET_HOME
from validator.flight.home import location_alt_m
from validator.geodesy import from_int_e7
from validator.item_lists import GLOBAL_FRAMES
from validator.mavlink.sim import telemetry
from validator.mavlink.sim.arducopter import FORCE_DISARM_MAGIC, CopterMode
from validator.mavlink.sim.copter import Copter
from validator.mavlink.wire import mavlink
from validator.plan_format import MissionItem

LOCATION_ALT_MAX_M = 83_000.0  # ArduPilot's Location: a command's altitude beyond is refused


def kind_is_int(msg: Any) -> bool:
    """COMMAND_INT carries param5..7 as x, y, z."""
    return bool(msg.get_type() == "COMMAND_INT")


def command_location(msg: Any) -> tuple[int, int, int, float]:
    """(frame, x, y, z) of a location command as ArduPilot reads it: COMMAND_INT's own;
    COMMAND_LONG's param5/6 degrees made int x 1e7 (NaN: 0) in MAV_FRAME_GLOBAL, the frame
    ArduPilot assumes for DO_SET_HOME (``convert_COMMAND_LONG_to_COMMAND_INT``)."""
    if kind_is_int(msg):
        return int(msg.frame), int(msg.x), int(msg.y), float(msg.z)

    def e7(deg: float) -> int:
        return 0 if math.isnan(deg) else int(deg * 1e7)  # a C cast: truncated

    return int(mavlink.MAV_FRAME_GLOBAL), e7(msg.param5), e7(msg.param6), float(msg.param7)


class Commands:
    """Carries out what a ground station asks of ``copter``; the answers go out on its
    ``mav``."""

    def __init__(self, copter: Copter) -> None:
        self.copter = copter
        self._last_command: tuple[tuple[int, int, int] | None, int] = (None, 0)

    def on_command(self, msg: Any) -> None:
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

    def on_set_mode(self, msg: Any) -> None:
        if msg.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            self.copter.set_mode(int(msg.custom_mode))

    def on_set_current(self, msg: Any) -> None:
        self.copter.set_current(int(msg.seq))

    def _ack(self, msg: Any, result: int) -> None:
        self.copter.mav.command_ack_send(msg.command, result, 0, 0, msg.get_srcSystem(),
                                         msg.get_srcComponent())

    def _execute(self, msg: Any) -> int | None:
        """Carry out a COMMAND_LONG/COMMAND_INT; its MAV_RESULT, or None once answered."""
        copter = self.copter
        c = int(msg.command)
        p = [msg.param1, msg.param2, msg.param3, msg.param4]
        m = mavlink
        result = m.MAV_RESULT_UNSUPPORTED
        if c == m.MAV_CMD_COMPONENT_ARM_DISARM:
            result = copter.arm(p[0] > 0.5, int(round(p[1])) == FORCE_DISARM_MAGIC)
        elif c == m.MAV_CMD_DO_SET_MODE:
            if int(p[0]) & m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                result = copter.set_mode(int(round(p[1])))
            else:
                result = m.MAV_RESULT_DENIED
        elif c == m.MAV_CMD_NAV_TAKEOFF:
            z = msg.z if kind_is_int(msg) else msg.param7
            result = copter.takeoff(float(z))
        elif c == m.MAV_CMD_MISSION_START:
            result = copter.mission_start(int(round(p[0])))
        elif c == m.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            result = copter.set_mode(CopterMode.RTL)
        elif c == m.MAV_CMD_NAV_LAND:
            result = copter.set_mode(CopterMode.LAND)
        elif c == m.MAV_CMD_DO_SET_MISSION_CURRENT:
            result = copter.set_current(int(round(p[0])))
        elif c == m.MAV_CMD_DO_SET_HOME:
            result = self._set_home(msg)
        elif c == m.MAV_CMD_DO_CHANGE_SPEED:
            result = copter.change_speed(p[1])
        elif c in (m.MAV_CMD_REQUEST_MESSAGE, m.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES):
            wanted = (int(round(p[0])) if c == m.MAV_CMD_REQUEST_MESSAGE
                      else m.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
            if wanted in (m.MAVLINK_MSG_ID_HOME_POSITION, m.MAVLINK_MSG_ID_AUTOPILOT_VERSION):
                self._ack(msg, m.MAV_RESULT_ACCEPTED)  # the protocol: ACK, then the message
                telemetry.send_requested(copter.mav, wanted, copter.home_lla)
                return None
        elif c == m.MAV_CMD_SET_MESSAGE_INTERVAL:
            result = m.MAV_RESULT_ACCEPTED  # telemetry runs at its configured rate
        return result

    def _set_home(self, msg: Any) -> int:
        """MAV_CMD_DO_SET_HOME as ArduCopter 4.5 answers it (``handle_command_do_set_home``):
        param1 1, or latitude and longitude both 0, is where the vehicle is; any param1 but
        0 and 1 FAILED; an altitude NaN or beyond 83 km, or a frame not global, DENIED; a
        location ``set_home`` refuses FAILED. The altitude is made absolute as a mission
        item's is (:func:`~validator.flight.home.location_alt_m`)."""
        copter = self.copter
        frame, x, y, z = command_location(msg)
        if msg.param1 == 1.0 or (x == 0 and y == 0):
            copter.set_home_here()
            return mavlink.MAV_RESULT_ACCEPTED
        if msg.param1 != 0.0:
            return mavlink.MAV_RESULT_FAILED
        if not abs(z) <= LOCATION_ALT_MAX_M or frame not in GLOBAL_FRAMES:
            return mavlink.MAV_RESULT_DENIED
        lat, lon = float(from_int_e7(x)), float(from_int_e7(y))
        ground_amsl_m = copter.config.home[2]  # the first home: the model's level ground
        it = MissionItem(DO_SET_HOME, [0.0, 0.0, 0.0, 0.0, lat, lon, z], frame)
        amsl_m = ground_amsl_m + location_alt_m(it, copter.home, ground_amsl_m)
        if not copter.set_home_at(lat, lon, amsl_m):
            return mavlink.MAV_RESULT_FAILED
        return mavlink.MAV_RESULT_ACCEPTED
