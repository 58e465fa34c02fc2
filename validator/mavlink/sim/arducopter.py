"""What the simulated vehicle copies from ArduCopter: its mode numbers and its parameters.

Parameter values are in ArduCopter's own units (cm, cm/s, cm/s² as ArduCopter keeps them),
names, defaults and types from :mod:`validator.autopilot.ardupilot`; the flight profile's
parameters (:data:`validator.motion.profile.PARAM_SPECS`) are added to these.
"""

from __future__ import annotations

from enum import IntEnum

from validator.autopilot.ardupilot import PARAMS as ARDUPILOT_PARAMS
from validator.autopilot.failsafe import FAILSAFE_PARAMS
from validator.mavlink.wire import mavlink

# COMPONENT_ARM_DISARM param2 that disarms in flight (ArduPilot's "force" value)
FORCE_DISARM_MAGIC = 21196


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

# The ArduCopter parameters served besides the flight profile's, at ArduCopter's defaults
# (validator.autopilot.ardupilot), except the fence, which is on and report-only here so a
# validation sees every breach. The failsafe parameters are held (a .param sets them) but
# nothing here fails: the simulated vehicle never loses a link, its battery or its position.
_SERVED = ("WPNAV_SPEED", "WPNAV_ACCEL", "WPNAV_JERK", "WPNAV_SPEED_UP", "WPNAV_SPEED_DN",
           "LAND_SPEED", "RTL_ALT", "RTL_SPEED", "FENCE_ENABLE", "FENCE_TYPE", "FENCE_ACTION",
           *FAILSAFE_PARAMS["ardupilot"])
_REPORT_ONLY_FENCE = {"FENCE_ENABLE": 1.0, "FENCE_TYPE": 7.0, "FENCE_ACTION": 0.0}
BASE_PARAMS: dict[str, tuple[float, int]] = {
    name: (_REPORT_ONLY_FENCE.get(name, ARDUPILOT_PARAMS[name].default),
           ARDUPILOT_PARAMS[name].mav_type)
    for name in _SERVED
}
SITL_TOP_SPEED_MPS = 10.4  # ArduPilot's SITL quad at ANGLE_MAX 30 deg (mavlink-facts.md)
