"""Flight profiles: which profile flies, with which parameters, in the autopilot's own units.

Each profile takes parameters in its autopilot's names and units, so a ``.param`` file's values
can be passed straight through (``--param WPNAV_ACCEL=500``). Their units, defaults and
ranges are the autopilots' own tables (:mod:`validator.autopilot.ardupilot`,
:mod:`validator.autopilot.px4`); a profile is made for a vehicle's
:class:`~validator.motion.limits.VehicleLimits`, from which speeds, accelerations and jerks
default (a site's ``uav.max_speed``, ``max_accel``, ``max_jerk``). A few parameters are our
model's own, in SI units: ``VEHICLE_SPEED_MAX`` (m/s, every profile) is the vehicle's real top
speed (default: its speed limit), e.g. 10.4 for ArduPilot's SITL quad; drag and altitude;
and (``arducopter``, ``px4``) the wind the vehicle flies in, ``WIND_SPEED`` (m/s) from
``WIND_FROM`` (degrees true) with turbulence ``WIND_TURB`` (m/s; default: the site's
``wind:`` at the flight altitude): the top speed then holds in the air, so the ground speed
along each leg is what :func:`validator.wind.ground_speed_mps` leaves of it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

from validator.autopilot import ardupilot, px4
from validator.autopilot.param_file import ParamFile
from validator.autopilot.spec import ParamSpec, model_param
from validator.errors import InputError
from validator.motion.limits import SITL_QUAD_DRAG_PER_M, VehicleLimits
from validator.wind import Wind

ProfileName = Literal["ideal", "arducopter", "px4"]
PROFILES: tuple[ProfileName, ...] = ("ideal", "arducopter", "px4")

# The autopilot parameters each profile flies with (their specs: validator.autopilot's tables)
ARDUCOPTER_FLOWN = ("WPNAV_SPEED", "WPNAV_ACCEL", "WPNAV_JERK", "WPNAV_RADIUS", "WPNAV_ACCEL_C",
                    "WPNAV_SPEED_UP", "WPNAV_SPEED_DN", "WPNAV_ACCEL_Z", "PSC_JERK_Z",
                    "ANGLE_MAX", "ATC_INPUT_TC", "ATC_ACCEL_R_MAX", "RTL_LOIT_TIME",
                    "PSC_ANGLE_MAX", "LAND_SPEED", "LAND_ALT_LOW", "WP_YAW_BEHAVIOR")
PX4_FLOWN = tuple(n for n in px4.PARAMS if n != "GF_ACTION")

# Our model's own parameters, in SI units (no autopilot has them)
_COMMON = {
    "VEHICLE_SPEED_MAX": model_param("m/s", "the vehicle's real top speed (default: its speed "
                                     "limit, the site's V)", limit="speed_mps"),
}
_WIND = {
    "WIND_SPEED": model_param("m/s", "mean wind speed at the flight altitude (default: the "
                              "site's wind:)", limit="wind_speed_mps", zero_ok=True),
    "WIND_FROM": model_param("deg", "direction the wind blows from, degrees true",
                             limit="wind_from_deg", zero_ok=True),
    "WIND_TURB": model_param("m/s", "the wind's turbulence, the gusts' standard deviation "
                             "(default: the site's wind:)", limit="wind_turbulence_mps",
                             zero_ok=True),
}
PARAM_SPECS: dict[str, dict[str, ParamSpec]] = {
    "ideal": {
        "SPEED": model_param("m/s", "speed of legs without DO_CHANGE_SPEED (default: site V)",
                             limit="speed_mps"),
        "SPEED_UP": model_param("m/s", "climb speed", 2.5),
        "SPEED_DN": model_param("m/s", "descent speed", 1.5),
        **_COMMON,
    },
    "arducopter": {
        **{n: ardupilot.PARAMS[n] for n in ARDUCOPTER_FLOWN},
        "VEHICLE_DRAG": model_param("1/m", "drag deceleration over speed squared at sea level; "
                                    "with the lean limit it sets the top speed (default: "
                                    "ArduPilot's SITL quad)", SITL_QUAD_DRAG_PER_M,
                                    zero_ok=True),
        "ALT_AMSL": model_param("m", "flight altitude above mean sea level, for the air "
                                "density (default: the site's ground altitude + H)",
                                limit="alt_amsl_m", zero_ok=True),
        **_COMMON,
        **_WIND,
    },
    "px4": {
        **{n: px4.PARAMS[n] for n in PX4_FLOWN},
        "VEHICLE_LIN_DRAG": model_param("1/s", "drag deceleration over speed (default: PX4 "
                                        "SIH's quad, SIH_KDV / SIH_MASS)", 1.0),
        **_COMMON,
        **_WIND,
    },
}


def _defaults(name: ProfileName, limits: VehicleLimits) -> dict[str, float]:
    """Every parameter of profile ``name`` at its default, the vehicle's ``limits`` standing
    in for those the autopilot would take from them (speed, acceleration, jerk)."""
    return {param: spec.from_si(getattr(limits, spec.limit)) if spec.limit else spec.default
            for param, spec in PARAM_SPECS[name].items()}


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


def profile_wind(profile: Profile) -> Wind | None:
    """The wind a profile flies in (WIND_SPEED from WIND_FROM, WIND_TURB), None in still air."""
    speed = float(profile.params.get("WIND_SPEED", 0.0))
    if speed <= 0.0:
        return None
    return Wind(speed, float(profile.params["WIND_FROM"]) % 360.0,
                float(profile.params.get("WIND_TURB", 0.0)))


def make_profile(
    name: str, vehicle: VehicleLimits, overrides: Mapping[str, float] | None = None, *,
    vehicle_params: Mapping[str, float] | None = None,
) -> Profile:
    """The profile ``name`` for a vehicle with these limits, with the parameters it flies of
    ``vehicle_params`` (what the vehicle holds: a parameter file, :func:`flown_params`) and
    then ``overrides`` (``--param`` flags), autopilot units; a site's vehicle is
    :func:`~validator.motion.limits.site_limits` of it.

    Raises :class:`InputError` for an unknown profile or parameter, or a value that is not a
    finite number > 0 (>= 0 where 0 is a setting, ``ParamSpec.zero_ok``: WPNAV_ACCEL_C,
    RTL_LOIT_TIME, PSC_ANGLE_MAX, WP_YAW_BEHAVIOR, VEHICLE_DRAG, ALT_AMSL, the wind's), naming
    where the value came from: its flag, or its file and line (a
    :class:`~validator.autopilot.param_file.ParamFile`).
    """
    if name not in PROFILES:
        raise InputError(f"--profile: unknown profile {name!r} (choose from {', '.join(PROFILES)})")
    pname: ProfileName = name
    params = _defaults(pname, vehicle)
    flags = overrides or {}
    for key, value in {**flown_params(pname, vehicle_params or {}), **flags}.items():
        where = f"--param {key}" if key in flags else _file_where(vehicle_params, key)
        if key not in params:
            known = ", ".join(sorted(params))
            raise InputError(f"{where}: unknown parameter for profile {name} (known: {known})")
        v = float(value)
        if not math.isfinite(v) or v < 0 or (v == 0 and not PARAM_SPECS[pname][key].zero_ok):
            raise InputError(f"{where}: must be a number > 0, got {value}")
        floor = PARAM_SPECS[pname][key].least()
        if 0 < v < floor:
            raise InputError(f"{where}: {v:g} {PARAM_SPECS[pname][key].unit} is below "
                             f"{floor:g}, the least acceleration or jerk the replay flies")
        params[key] = v
    return Profile(pname, params)


def _file_where(values: Mapping[str, float] | None, key: str) -> str:
    """How a message about ``key``'s value in a vehicle's parameters starts: its file and line
    when they were read from one."""
    return values.where(key) if isinstance(values, ParamFile) else f"parameter {key}"


def flown_params(name: str, params: Mapping[str, float]) -> dict[str, float]:
    """Those of ``params`` (a vehicle's parameter file) that profile ``name`` flies with; the
    rest (the geofence, say) do not move the vehicle."""
    known = PARAM_SPECS.get(name, {})
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
