"""PX4 v1.15's parameters we set or model: unit, factor to SI, default, documented range.

Names, units and ranges are PX4's own parameter documentation (``@unit``, ``@min``, ``@max`` in
mc_pos_control, navigator and geofence); defaults are PX4's, as its multicopter airframes set
them (NAV_ACC_RAD is 10 m in the firmware, 2 m in ``rc.mc_defaults``). The planner writes some
of them, the replay flies with them (:mod:`validator.motion.px4_mission`) and the
parameter-file checks read them: all from this one table.
"""

from __future__ import annotations

import math

from validator.autopilot.spec import MAV_PARAM_TYPE_INT32, ParamSpec

PARAMS: dict[str, ParamSpec] = {
    "MPC_XY_CRUISE": ParamSpec("m/s", 1.0, 5.0, 3.0, 20.0, "speed without DO_CHANGE_SPEED",
                               limit="speed_mps"),
    "MPC_XY_VEL_MAX": ParamSpec("m/s", 1.0, 12.0, 0.0, 20.0, "horizontal speed limit",
                                limit="speed_mps"),
    "MPC_ACC_HOR": ParamSpec("m/s/s", 1.0, 3.0, 2.0, 15.0, "horizontal acceleration",
                             limit="accel_mps2"),
    "MPC_JERK_AUTO": ParamSpec("m/s/s/s", 1.0, 4.0, 1.0, 80.0, "jerk in missions",
                               limit="jerk_mps3"),
    "NAV_ACC_RAD": ParamSpec("m", 1.0, 2.0, 0.05, 200.0,
                             "acceptance radius; corners are cut inside it"),
    "MPC_Z_V_AUTO_UP": ParamSpec("m/s", 1.0, 3.0, 0.5, 8.0, "climb speed"),
    "MPC_Z_V_AUTO_DN": ParamSpec("m/s", 1.0, 1.5, 0.5, 4.0, "descent speed"),
    "MPC_ACC_UP_MAX": ParamSpec("m/s/s", 1.0, 4.0, 2.0, 15.0, "climb acceleration"),
    "MPC_ACC_DOWN_MAX": ParamSpec("m/s/s", 1.0, 3.0, 2.0, 15.0, "descent acceleration"),
    "MPC_XY_TRAJ_P": ParamSpec("", 1.0, 0.5, 0.1, 1.0,
                               "share of MPC_ACC_HOR used to turn through a waypoint"),
    "NAV_MC_ALT_RAD": ParamSpec("m", 1.0, 0.8, 0.05, 200.0, "altitude acceptance radius"),
    "MPC_LAND_SPEED": ParamSpec("m/s", 1.0, 0.7, 0.6, math.inf,
                                "landing speed below MPC_LAND_ALT2"),
    "MPC_LAND_ALT1": ParamSpec("m", 1.0, 10.0, 0.0, 122.0,
                               "height where a landing starts to slow"),
    "MPC_LAND_ALT2": ParamSpec("m", 1.0, 5.0, 0.0, 122.0,
                               "height below which it lands at MPC_LAND_SPEED"),
    "MPC_XY_P": ParamSpec("1/s", 1.0, 0.95, 0.0, 2.0, "horizontal position gain"),
    "MPC_XY_VEL_P_ACC": ParamSpec("1/s", 1.0, 1.8, 1.2, 5.0, "horizontal velocity P gain"),
    "MPC_XY_VEL_I_ACC": ParamSpec("1/s/s", 1.0, 0.4, 0.0, 60.0, "horizontal velocity I gain"),
    "MPC_XY_ERR_MAX": ParamSpec("m", 1.0, 2.0, 0.1, 10.0,
                                "lag at which the trajectory waits for the vehicle"),
    "MPC_TILTMAX_AIR": ParamSpec("deg", 1.0, 45.0, 20.0, 89.0,
                                 "tilt limit; with the drag it sets the top speed"),
    # the geofence (validator.autopilot.fence says which values are safe)
    "GF_ACTION": ParamSpec("enum", 1.0, 2.0, 0.0, 5.0, "what a breach does",
                           MAV_PARAM_TYPE_INT32, zero_ok=True),
    # failsafes (validator.autopilot.failsafe says what each value flies)
    "NAV_RCL_ACT": ParamSpec("enum", 1.0, 2.0, 0.0, 6.0, "RC loss action", MAV_PARAM_TYPE_INT32,
                             zero_ok=True),
    "NAV_DLL_ACT": ParamSpec("enum", 1.0, 0.0, 0.0, 6.0, "data-link loss action",
                             MAV_PARAM_TYPE_INT32, zero_ok=True),
    "COM_LOW_BAT_ACT": ParamSpec("enum", 1.0, 0.0, 0.0, 3.0, "battery failsafe action",
                                 MAV_PARAM_TYPE_INT32, zero_ok=True),
    "COM_FLTT_LOW_ACT": ParamSpec("enum", 1.0, 3.0, 0.0, 3.0, "low flight time action",
                                  MAV_PARAM_TYPE_INT32, zero_ok=True),
    "COM_POSCTL_NAVL": ParamSpec("enum", 1.0, 0.0, 0.0, 1.0, "navigation loss response",
                                 MAV_PARAM_TYPE_INT32, zero_ok=True),
    "COM_RCL_EXCEPT": ParamSpec("bitmask", 1.0, 0.0, 0.0, 7.0, "modes ignoring RC loss (1 "
                                "Mission)", MAV_PARAM_TYPE_INT32, zero_ok=True),
    "COM_WIND_MAX_ACT": ParamSpec("enum", 1.0, 0.0, 0.0, 5.0, "high wind action",
                                  MAV_PARAM_TYPE_INT32, zero_ok=True),
    "COM_IMB_PROP_ACT": ParamSpec("enum", 1.0, 0.0, -1.0, 2.0, "imbalanced propeller action",
                                  MAV_PARAM_TYPE_INT32, zero_ok=True),
    "COM_ACT_FAIL_ACT": ParamSpec("enum", 1.0, 0.0, 0.0, 4.0, "actuator failure action",
                                  MAV_PARAM_TYPE_INT32, zero_ok=True),
    "RTL_TYPE": ParamSpec("enum", 1.0, 0.0, 0.0, 3.0, "Return destination and path",
                          MAV_PARAM_TYPE_INT32, zero_ok=True),
    "RTL_RETURN_ALT": ParamSpec("m", 1.0, 60.0, 0.0, math.inf, "Return altitude above the "
                                "destination", zero_ok=True),
}
