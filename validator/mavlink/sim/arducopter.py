"""What the simulated vehicle copies from ArduCopter: its mode numbers and its parameters.

Parameter values are in ArduCopter's own units (cm, cm/s, cm/s² as ArduCopter keeps them);
the flight profile's parameters (:data:`validator.dynamics.PARAM_SPECS`) are added to these.
"""

from __future__ import annotations

from enum import IntEnum

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

# ArduCopter's names, units and defaults, except the fence, which is on and report-only here
# so a validation sees every breach.
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
