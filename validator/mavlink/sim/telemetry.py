"""What the simulated vehicle reports, as ArduCopter 4.5.6 encodes it: HEARTBEAT, landed state,
position, mission progress, fence status, text, and HOME_POSITION / AUTOPILOT_VERSION on
request. ``mav`` is the vehicle's sender; times are simulated."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from validator.geodesy import to_int_e7
from validator.mavlink.sim.arducopter import CopterMode
from validator.mavlink.wire import mavlink

NO_HEADING = 65535  # GLOBAL_POSITION_INT.hdg when unknown
HEADING_MIN_SPEED_MPS = 0.2  # slower than this a heading is noise, so none is reported


def say(mav: Any, text: str) -> None:
    mav.statustext_send(mavlink.MAV_SEVERITY_INFO, text.encode("ascii")[:50])


def send_position(mav: Any, t_s: float, lat_deg: ArrayLike, lon_deg: ArrayLike, amsl_m: float,
                  rel_alt_m: float, vel: NDArray[np.float64]) -> None:
    """GLOBAL_POSITION_INT; ``amsl_m`` above sea level, ``rel_alt_m`` above the home in force,
    ``vel`` (east, north, up) m/s."""
    heading = math.degrees(math.atan2(vel[0], vel[1])) % 360.0
    mav.global_position_int_send(
        int(t_s * 1000),
        int(to_int_e7(lat_deg)),
        int(to_int_e7(lon_deg)),
        int(round(amsl_m * 1000)),
        int(round(rel_alt_m * 1000)),
        int(round(vel[1] * 100)),  # north
        int(round(vel[0] * 100)),  # east
        int(round(-vel[2] * 100)),  # down
        int(round(heading * 100)) if np.hypot(*vel[:2]) > HEADING_MIN_SPEED_MPS else NO_HEADING,
    )


def send_mission_current(mav: Any, seq: int, items: int, *, complete: bool, flying: bool,
                         mode: CopterMode) -> None:
    """MISSION_CURRENT for a mission of ``items`` (home included) at ``seq``; ``flying``:
    AUTO is flying it now."""
    m = mavlink
    if items <= 1:
        state = m.MISSION_STATE_NO_MISSION
    elif complete:
        state = m.MISSION_STATE_COMPLETE
    elif mode == CopterMode.AUTO and flying:
        state = m.MISSION_STATE_ACTIVE
    elif seq > 1:
        state = m.MISSION_STATE_PAUSED
    else:
        state = m.MISSION_STATE_NOT_STARTED
    mav.mission_current_send(seq, max(0, items - 1), state,
                             1 if mode == CopterMode.AUTO else 0)


def send_fence_status(mav: Any, breach: bool, count: int, time_ms: int) -> None:
    mav.fence_status_send(int(breach), count,
                          mavlink.FENCE_BREACH_BOUNDARY if breach else 0, time_ms, 0)


def send_heartbeat(mav: Any, mode: CopterMode, armed: bool, landed: bool) -> None:
    """HEARTBEAT and EXTENDED_SYS_STATE (the landed state), as ArduCopter sends them."""
    m = mavlink
    base = m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | m.MAV_MODE_FLAG_STABILIZE_ENABLED
    if armed:
        base |= m.MAV_MODE_FLAG_SAFETY_ARMED
    if mode in (CopterMode.AUTO, CopterMode.GUIDED, CopterMode.RTL):
        base |= m.MAV_MODE_FLAG_GUIDED_ENABLED
    if mode == CopterMode.AUTO:
        base |= m.MAV_MODE_FLAG_AUTO_ENABLED
    status = m.MAV_STATE_ACTIVE if armed else m.MAV_STATE_STANDBY
    mav.heartbeat_send(m.MAV_TYPE_QUADROTOR, m.MAV_AUTOPILOT_ARDUPILOTMEGA, base, int(mode),
                       status)
    landed_state = m.MAV_LANDED_STATE_ON_GROUND if landed else m.MAV_LANDED_STATE_IN_AIR
    mav.extended_sys_state_send(m.MAV_VTOL_STATE_UNDEFINED, landed_state)


def send_requested(mav: Any, msg_id: int, home: tuple[float, float, float]) -> bool:
    """Send HOME_POSITION (``home`` lat deg, lon deg, alt m AMSL) or AUTOPILOT_VERSION;
    False for any other message, which the vehicle does not send on request."""
    m = mavlink
    if msg_id == m.MAVLINK_MSG_ID_HOME_POSITION:
        lat, lon, alt = home
        mav.home_position_send(int(to_int_e7(lat)), int(to_int_e7(lon)),
                               int(round(alt * 1000)), 0.0, 0.0, 0.0,
                               [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0)
        return True
    if msg_id == m.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
        caps = (m.MAV_PROTOCOL_CAPABILITY_MISSION_INT | m.MAV_PROTOCOL_CAPABILITY_MAVLINK2
                | m.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
                | m.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
                | m.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | m.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST)
        version = (4 << 24) | (5 << 16) | (6 << 8) | 255  # 4.5.6 official
        mav.autopilot_version_send(caps, version, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, 0)
        return True
    return False
