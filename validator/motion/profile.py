"""Flight profiles: which profile flies, with which parameters, in the autopilot's own units.

Each profile takes parameters in its autopilot's names and units, so a ``.param`` file's values
can be passed straight through (``--param WPNAV_ACCEL=500``). Accelerations and jerks default to
the site's ``uav.max_accel`` / ``uav.max_jerk``, speeds to its ``max_speed``;
``VEHICLE_SPEED_MAX`` (m/s, every profile) is the vehicle's real top speed (default: the site's
V), e.g. 10.4 for ArduPilot's SITL quad.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

from validator.errors import InputError
from validator.motion.limits import SITL_QUAD_DRAG_PER_M
from validator.site import Site

ProfileName = Literal["ideal", "arducopter", "px4"]
PROFILES: tuple[ProfileName, ...] = ("ideal", "arducopter", "px4")


@dataclass(frozen=True)
class ParamSpec:
    """One profile parameter: its unit, factor to SI, and documentation."""

    unit: str
    to_si: float
    doc: str


_COMMON = {
    "VEHICLE_SPEED_MAX": ParamSpec("m/s", 1.0, "the vehicle's real top speed (default: site V)"),
}
PARAM_SPECS: dict[str, dict[str, ParamSpec]] = {
    "ideal": {
        "SPEED": ParamSpec("m/s", 1.0, "speed of legs without DO_CHANGE_SPEED (default: site V)"),
        "SPEED_UP": ParamSpec("m/s", 1.0, "climb speed (default 2.5)"),
        "SPEED_DN": ParamSpec("m/s", 1.0, "descent speed (default 1.5)"),
        **_COMMON,
    },
    "arducopter": {
        "WPNAV_SPEED": ParamSpec("cm/s", 0.01, "horizontal speed without DO_CHANGE_SPEED "
                                 "(default: site V, as our .param files set it)"),
        "WPNAV_ACCEL": ParamSpec("cm/s/s", 0.01, "horizontal acceleration (default: site "
                                 "max_accel)"),
        "WPNAV_JERK": ParamSpec("m/s/s/s", 1.0, "horizontal jerk (default: site max_jerk)"),
        "WPNAV_RADIUS": ParamSpec("cm", 0.01, "waypoint radius; corners are cut inside it "
                                  "(default 200)"),
        "WPNAV_ACCEL_C": ParamSpec("cm/s/s", 0.01, "corner acceleration, 0 = 2 x WPNAV_ACCEL "
                                   "(default 0)"),
        "WPNAV_SPEED_UP": ParamSpec("cm/s", 0.01, "climb speed (default 250)"),
        "WPNAV_SPEED_DN": ParamSpec("cm/s", 0.01, "descent speed (default 150)"),
        "WPNAV_ACCEL_Z": ParamSpec("cm/s/s", 0.01, "vertical acceleration (default 100)"),
        "PSC_JERK_Z": ParamSpec("m/s/s/s", 1.0, "vertical jerk (default 5)"),
        "ANGLE_MAX": ParamSpec("cdeg", 0.01, "lean angle limit; caps WPNAV_ACCEL at "
                               "g·tan(ANGLE_MAX) (default 3000)"),
        "ATC_INPUT_TC": ParamSpec("s", 1.0, "attitude input time constant; jerk ramps over "
                                  "2·ATC_INPUT_TC (default 0.15)"),
        "ATC_ACCEL_R_MAX": ParamSpec("cdeg/s/s", 0.01, "roll acceleration limit; bounds how "
                                     "fast jerk can change (default 110000)"),
        "RTL_LOIT_TIME": ParamSpec("ms", 0.001, "hover over home before landing (default 5000)"),
        "PSC_ANGLE_MAX": ParamSpec("deg", 1.0, "position controller lean limit, 0 = ANGLE_MAX "
                                   "(default 0)"),
        "LAND_SPEED": ParamSpec("cm/s", 0.01, "final descent speed below LAND_ALT_LOW "
                                "(default 50)"),
        "LAND_ALT_LOW": ParamSpec("cm", 0.01, "altitude where a landing slows to LAND_SPEED "
                                  "(default 1000)"),
        "VEHICLE_DRAG": ParamSpec("1/m", 1.0, "drag deceleration over speed squared at sea "
                                  "level; with the lean limit it sets the top speed (default "
                                  f"{SITL_QUAD_DRAG_PER_M}, ArduPilot's SITL quad)"),
        "ALT_AMSL": ParamSpec("m", 1.0, "flight altitude above mean sea level, for the air "
                              "density (default: the site's ground altitude + H)"),
        **_COMMON,
    },
    "px4": {
        "MPC_XY_CRUISE": ParamSpec("m/s", 1.0, "speed without DO_CHANGE_SPEED (default: site V)"),
        "MPC_XY_VEL_MAX": ParamSpec("m/s", 1.0, "horizontal speed limit (default: site V)"),
        "MPC_ACC_HOR": ParamSpec("m/s/s", 1.0, "horizontal acceleration (default: site "
                                 "max_accel)"),
        "MPC_JERK_AUTO": ParamSpec("m/s/s/s", 1.0, "jerk in missions (default: site max_jerk)"),
        "NAV_ACC_RAD": ParamSpec("m", 1.0, "acceptance radius; corners are cut inside it "
                                 "(default 2)"),
        "MPC_Z_V_AUTO_UP": ParamSpec("m/s", 1.0, "climb speed (default 3)"),
        "MPC_Z_V_AUTO_DN": ParamSpec("m/s", 1.0, "descent speed (default 1.5)"),
        "MPC_ACC_UP_MAX": ParamSpec("m/s/s", 1.0, "climb acceleration (default 4)"),
        "MPC_ACC_DOWN_MAX": ParamSpec("m/s/s", 1.0, "descent acceleration (default 3)"),
        "MPC_XY_TRAJ_P": ParamSpec("", 1.0, "share of MPC_ACC_HOR used to turn through a "
                                   "waypoint (default 0.5)"),
        "NAV_MC_ALT_RAD": ParamSpec("m", 1.0, "altitude acceptance radius (default 0.8)"),
        "MPC_LAND_SPEED": ParamSpec("m/s", 1.0, "landing speed below MPC_LAND_ALT2 "
                                    "(default 0.7)"),
        "MPC_LAND_ALT1": ParamSpec("m", 1.0, "height where a landing starts to slow "
                                   "(default 10)"),
        "MPC_LAND_ALT2": ParamSpec("m", 1.0, "height below which it lands at MPC_LAND_SPEED "
                                   "(default 5)"),
        "MPC_XY_P": ParamSpec("1/s", 1.0, "horizontal position gain (default 0.95)"),
        "MPC_XY_VEL_P_ACC": ParamSpec("1/s", 1.0, "horizontal velocity P gain (default 1.8)"),
        "MPC_XY_VEL_I_ACC": ParamSpec("1/s/s", 1.0, "horizontal velocity I gain (default 0.4)"),
        "MPC_XY_ERR_MAX": ParamSpec("m", 1.0, "lag at which the trajectory waits for the "
                                    "vehicle (default 2)"),
        "MPC_TILTMAX_AIR": ParamSpec("deg", 1.0, "tilt limit; with the drag it sets the top "
                                     "speed (default 45)"),
        "VEHICLE_LIN_DRAG": ParamSpec("1/s", 1.0, "drag deceleration over speed (default 1, "
                                      "PX4 SIH's quad: SIH_KDV / SIH_MASS)"),
        **_COMMON,
    },
}


def _defaults(name: ProfileName, site: Site) -> dict[str, float]:
    v = site.max_speed_mps
    common = {"VEHICLE_SPEED_MAX": v}
    if name == "ideal":
        return {"SPEED": v, "SPEED_UP": 2.5, "SPEED_DN": 1.5, **common}
    if name == "arducopter":
        return {
            "WPNAV_SPEED": v * 100.0,
            "WPNAV_ACCEL": site.max_accel_mps2 * 100.0,
            "WPNAV_JERK": site.max_jerk_mps3,
            "WPNAV_RADIUS": 200.0,
            "WPNAV_ACCEL_C": 0.0,
            "WPNAV_SPEED_UP": 250.0,
            "WPNAV_SPEED_DN": 150.0,
            "WPNAV_ACCEL_Z": 100.0,
            "PSC_JERK_Z": 5.0,
            "ANGLE_MAX": 3000.0,
            "ATC_INPUT_TC": 0.15,
            "ATC_ACCEL_R_MAX": 110000.0,
            "RTL_LOIT_TIME": 5000.0,
            "PSC_ANGLE_MAX": 0.0,
            "LAND_SPEED": 50.0,
            "LAND_ALT_LOW": 1000.0,
            "VEHICLE_DRAG": SITL_QUAD_DRAG_PER_M,
            "ALT_AMSL": site.frame.alt0_m + site.altitude_m,
            **common,
        }
    return {
        "MPC_XY_CRUISE": v,
        "MPC_XY_VEL_MAX": v,
        "MPC_ACC_HOR": site.max_accel_mps2,
        "MPC_JERK_AUTO": site.max_jerk_mps3,
        "NAV_ACC_RAD": 2.0,
        "MPC_Z_V_AUTO_UP": 3.0,
        "MPC_Z_V_AUTO_DN": 1.5,
        "MPC_ACC_UP_MAX": 4.0,
        "MPC_ACC_DOWN_MAX": 3.0,
        "MPC_XY_TRAJ_P": 0.5,
        "NAV_MC_ALT_RAD": 0.8,
        "MPC_LAND_SPEED": 0.7,
        "MPC_LAND_ALT1": 10.0,
        "MPC_LAND_ALT2": 5.0,
        "MPC_XY_P": 0.95,
        "MPC_XY_VEL_P_ACC": 1.8,
        "MPC_XY_VEL_I_ACC": 0.4,
        "MPC_XY_ERR_MAX": 2.0,
        "MPC_TILTMAX_AIR": 45.0,
        "VEHICLE_LIN_DRAG": 1.0,
        **common,
    }


@dataclass(frozen=True)
class Profile:
    """A flight profile: its name and every parameter in the autopilot's units."""

    name: ProfileName
    params: Mapping[str, float]

    def si(self, param: str) -> float:
        """The parameter converted to SI units (m, m/s, m/s², m/s³, s, rad for angles)."""
        spec = PARAM_SPECS[self.name][param]
        value = float(self.params[param]) * spec.to_si
        return math.radians(value) if spec.unit.startswith("cdeg") else value


def make_profile(
    name: str, site: Site, overrides: Mapping[str, float] | None = None
) -> Profile:
    """The profile ``name`` with the site's defaults and ``overrides`` (autopilot units).

    Raises :class:`InputError` for an unknown profile or parameter, or a value that is not a
    finite number > 0 (>= 0 for WPNAV_ACCEL_C, RTL_LOIT_TIME, PSC_ANGLE_MAX, VEHICLE_DRAG and
    ALT_AMSL).
    """
    if name not in PROFILES:
        raise InputError(f"--profile: unknown profile {name!r} (choose from {', '.join(PROFILES)})")
    pname: ProfileName = name
    params = _defaults(pname, site)
    for key, value in (overrides or {}).items():
        if key not in params:
            known = ", ".join(sorted(params))
            raise InputError(
                f"--param {key}: unknown parameter for profile {name} (known: {known})"
            )
        v = float(value)
        may_be_zero = key in ("WPNAV_ACCEL_C", "RTL_LOIT_TIME", "PSC_ANGLE_MAX", "VEHICLE_DRAG",
                              "ALT_AMSL")
        if not math.isfinite(v) or v < 0 or (v == 0 and not may_be_zero):
            raise InputError(f"--param {key}: must be a number > 0, got {value}")
        params[key] = v
    return Profile(pname, params)


def flight_params(name: str, site: Site, params: Mapping[str, float]) -> dict[str, float]:
    """Those of ``params`` (a vehicle's parameter file) that profile ``name`` flies with; the
    rest (the geofence, say) do not move the vehicle."""
    known = make_profile(name, site).params
    return {k: float(v) for k, v in params.items() if k in known}


def parse_param_overrides(pairs: list[str] | None) -> dict[str, float]:
    """``["NAME=VALUE", ...]`` from the command line as a dict; InputError naming the bad one."""
    out: dict[str, float] = {}
    for pair in pairs or []:
        name, sep, value = pair.partition("=")
        name = name.strip().upper()
        if not sep or not name:
            raise InputError(f"--param {pair}: expected NAME=VALUE")
        try:
            out[name] = float(value)
        except ValueError:
            raise InputError(f"--param {name}: {value!r} is not a number") from None
    return out
