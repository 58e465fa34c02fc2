"""ArduCopter 4.5's parameters we set or model: unit, factor to SI, default, documented range.

Names, units, ranges and defaults are ArduCopter's own parameter documentation (``@Units``,
``@Range`` and the ``AP_GROUPINFO`` defaults of AC_WPNav, AC_PosControl, AC_AttitudeControl,
AC_Fence and ArduCopter/Parameters.cpp). The planner writes some of them, the replay flies
with them (:mod:`validator.motion.arducopter`), the simulated vehicle serves them and the
parameter-file checks read them: all from this one table.
"""

from __future__ import annotations

from validator.autopilot.spec import (
    MAV_PARAM_TYPE_INT8,
    MAV_PARAM_TYPE_INT16,
    MAV_PARAM_TYPE_INT32,
    ParamSpec,
)

_I8, _I16, _I32 = MAV_PARAM_TYPE_INT8, MAV_PARAM_TYPE_INT16, MAV_PARAM_TYPE_INT32

PARAMS: dict[str, ParamSpec] = {
    "WPNAV_SPEED": ParamSpec("cm/s", 0.01, 1000.0, 20.0, 2000.0,
                             "horizontal speed without DO_CHANGE_SPEED", limit="speed_mps"),
    "WPNAV_ACCEL": ParamSpec("cm/s/s", 0.01, 250.0, 50.0, 500.0, "horizontal acceleration",
                             limit="accel_mps2"),
    "WPNAV_JERK": ParamSpec("m/s/s/s", 1.0, 1.0, 1.0, 20.0, "horizontal jerk",
                            limit="jerk_mps3"),
    "WPNAV_RADIUS": ParamSpec("cm", 0.01, 200.0, 5.0, 1000.0,
                              "waypoint radius; corners are cut inside it"),
    "WPNAV_ACCEL_C": ParamSpec("cm/s/s", 0.01, 0.0, 0.0, 500.0,
                               "corner acceleration, 0 = 2 x WPNAV_ACCEL", zero_ok=True),
    "WPNAV_SPEED_UP": ParamSpec("cm/s", 0.01, 250.0, 10.0, 1000.0, "climb speed"),
    "WPNAV_SPEED_DN": ParamSpec("cm/s", 0.01, 150.0, 10.0, 500.0, "descent speed"),
    "WPNAV_ACCEL_Z": ParamSpec("cm/s/s", 0.01, 100.0, 50.0, 500.0, "vertical acceleration"),
    "PSC_JERK_Z": ParamSpec("m/s/s/s", 1.0, 5.0, 5.0, 50.0, "vertical jerk"),
    "ANGLE_MAX": ParamSpec("cdeg", 0.01, 3000.0, 1000.0, 8000.0,
                           "lean angle limit; caps WPNAV_ACCEL at g·tan(ANGLE_MAX)", _I16),
    "ATC_INPUT_TC": ParamSpec("s", 1.0, 0.15, 0.0, 1.0, "attitude input time constant; jerk "
                              "ramps over 2·ATC_INPUT_TC"),
    "ATC_ACCEL_R_MAX": ParamSpec("cdeg/s/s", 0.01, 110000.0, 0.0, 180000.0,
                                 "roll acceleration limit; bounds how fast jerk can change"),
    "RTL_LOIT_TIME": ParamSpec("ms", 0.001, 5000.0, 0.0, 60000.0,
                               "hover over home before landing", _I32, zero_ok=True),
    "PSC_ANGLE_MAX": ParamSpec("deg", 1.0, 0.0, 0.0, 45.0,
                               "position controller lean limit, 0 = ANGLE_MAX", zero_ok=True),
    "WP_YAW_BEHAVIOR": ParamSpec("enum", 1.0, 2.0, 0.0, 3.0, "yaw on mission legs: 0 kept, "
                                 "1 toward the next waypoint, 2 the same but not in RTL, 3 "
                                 "along the course over the ground", _I8, zero_ok=True),
    "LAND_SPEED": ParamSpec("cm/s", 0.01, 50.0, 30.0, 200.0,
                            "final descent speed below LAND_ALT_LOW", _I16),
    "LAND_ALT_LOW": ParamSpec("cm", 0.01, 1000.0, 100.0, 10000.0,
                              "altitude where a landing slows to LAND_SPEED", _I16),
    "LAND_SPEED_HIGH": ParamSpec("cm/s", 0.01, 0.0, 0.0, 500.0,
                                 "descent speed above LAND_ALT_LOW, 0 = WPNAV_SPEED_DN", _I16,
                                 zero_ok=True),
    "CIRCLE_RADIUS": ParamSpec("cm", 0.01, 1000.0, 0.0, 200000.0, "the circle a LOITER_TURNS "
                               "of radius 0 flies (AC_Circle)", zero_ok=True),
    "RTL_ALT": ParamSpec("cm", 0.01, 1500.0, 200.0, 300000.0, "altitude of a return home",
                         _I32),
    "RTL_SPEED": ParamSpec("cm/s", 0.01, 0.0, 0.0, 2000.0,
                           "speed of a return home, 0 = WPNAV_SPEED", _I16, zero_ok=True),
    # the geofence (validator.autopilot.fence says which values are safe)
    "FENCE_ENABLE": ParamSpec("boolean", 1.0, 0.0, 0.0, 1.0, "fence on", _I8, zero_ok=True),
    "FENCE_TYPE": ParamSpec("bitmask", 1.0, 7.0, 0.0, 15.0, "which fences: 1 max altitude, "
                            "2 circle round home, 4 polygons and circles, 8 min altitude", _I8,
                            zero_ok=True),
    "FENCE_ACTION": ParamSpec("enum", 1.0, 1.0, 0.0, 5.0, "what a breach does", _I8,
                              zero_ok=True),
    # failsafes (validator.autopilot.failsafe says what each value flies)
    "FS_THR_ENABLE": ParamSpec("enum", 1.0, 1.0, 0.0, 7.0, "RC loss action", _I8, zero_ok=True),
    "FS_GCS_ENABLE": ParamSpec("enum", 1.0, 0.0, 0.0, 7.0, "ground-station loss action", _I8,
                               zero_ok=True),
    "FS_OPTIONS": ParamSpec("bitmask", 1.0, 16.0, 0.0, 63.0, "failsafe options: continue in "
                            "Auto (1 RC, 2 GCS), 8 finish a landing, 16 pilot keeps GCS loss",
                            _I32, zero_ok=True),
    "BATT_FS_LOW_ACT": ParamSpec("enum", 1.0, 0.0, 0.0, 6.0, "low battery action", _I8,
                                 zero_ok=True),
    "BATT_FS_CRT_ACT": ParamSpec("enum", 1.0, 0.0, 0.0, 6.0, "critical battery action", _I8,
                                 zero_ok=True),
    "FS_EKF_ACTION": ParamSpec("enum", 1.0, 1.0, 1.0, 3.0, "EKF failsafe action", _I8),
    "FS_DR_ENABLE": ParamSpec("enum", 1.0, 2.0, 0.0, 6.0, "dead-reckoning failsafe action", _I8,
                              zero_ok=True),
    # a vehicle's own calibration, never written by the planner: with any of them above 0,
    # EKF3 fuses drag, estimates the wind and dead reckons through a GPS loss
    # (validator.position_loss.dead_reckons)
    "EK3_DRAG_BCOEF_X": ParamSpec("kg/m/m", 1.0, 0.0, 0.0, 1000.0, "EKF3 ballistic coefficient "
                                  "along the body's X axis (0 = no drag fusion)", zero_ok=True),
    "EK3_DRAG_BCOEF_Y": ParamSpec("kg/m/m", 1.0, 0.0, 0.0, 1000.0, "EKF3 ballistic coefficient "
                                  "along the body's Y axis (0 = no drag fusion)", zero_ok=True),
    "EK3_DRAG_MCOEF": ParamSpec("1/s", 1.0, 0.0, 0.0, 1.0, "EKF3 rotor momentum drag "
                                "coefficient (0 = no drag fusion)", zero_ok=True),
    "SRTL_POINTS": ParamSpec("count", 1.0, 300.0, 0.0, 500.0, "SmartRTL path points (0 = off; "
                             "after a reboot)", _I16, zero_ok=True),
    "SRTL_ACCURACY": ParamSpec("m", 1.0, 2.0, 0.0, 10.0, "SmartRTL point spacing", zero_ok=True),
    "RALLY_INCL_HOME": ParamSpec("boolean", 1.0, 1.0, 0.0, 1.0, "RTL may choose home", _I8,
                                 zero_ok=True),
    "RALLY_LIMIT_KM": ParamSpec("km", 1000.0, 0.3, 0.0, 1000.0, "rally points further than "
                                "this are not used (0 = no limit)", zero_ok=True),
}
