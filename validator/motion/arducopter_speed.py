"""ArduCopter's speed limits: the top speed its lean limit holds against the air's drag, what
the wind's gusts leave of it, and what a course in the wind leaves of it over the ground, both
as a plan commands it (the planner's cone, whatever the vehicle's drag) and as the vehicle
flies it leaning at its limit (the drag of ArduPilot's SITL quad, per body axis)."""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import partial

import numpy as np
from numpy.typing import ArrayLike, NDArray

from validator.flight import Finding
from validator.motion.limits import (
    GRAVITY_MPS2,
    SITL_QUAD_LINEAR_DRAG_SHARE,
    air_density_ratio,
    lean_angle_max_deg,
    top_speed_mps,
)
from validator.motion.profile import Profile, profile_wind
from validator.wind import (
    course_speeds_mps,
    ground_speed_mps,
    held_air_speed_mps,
    lean_limit_ground_speed_mps,
)

# WP_YAW_BEHAVIOR values under which ArduCopter faces along its course on a mission leg (1
# toward the next waypoint, 2 the same but not in RTL, 3 along its course over the ground), as
# the drag per body axis takes it: crabbing across a wind, the body meets the air at the crab
# angle. At 0 the vehicle keeps its yaw and meets a crosswind at whatever angle that leaves.
YAW_ALONG_COURSE = (1.0, 2.0, 3.0)
# ... and the one a plan sets: ArduCopter's own default for a multicopter (config.h), written
# so that the vehicle flies the yaw its timing was made with whatever it was set to before.
PLAN_YAW_BEHAVIOR = 2.0


def arducopter_lean_max_deg(profile: Profile) -> float:
    """The lean limit (degrees) of an ``arducopter`` profile."""
    return lean_angle_max_deg(float(profile.params["ANGLE_MAX"]),
                              float(profile.params["PSC_ANGLE_MAX"]))


def arducopter_accel_mps2(profile: Profile) -> float:
    """The horizontal acceleration (m/s²) an ``arducopter`` profile's legs use: WPNAV_ACCEL,
    capped by what its lean limit allows (g·tan θ)."""
    lean = math.radians(arducopter_lean_max_deg(profile))
    return min(profile.si("WPNAV_ACCEL"), GRAVITY_MPS2 * math.tan(lean))


def arducopter_top_speed_mps(profile: Profile) -> float:
    """The fastest an ``arducopter`` profile's vehicle flies (m/s), whatever WPNAV_SPEED says:
    its lean-limited top speed (:func:`top_speed_mps` at the profile's air density), capped by
    VEHICLE_SPEED_MAX."""
    return min(_lean_top_speed_mps(profile), profile.si("VEHICLE_SPEED_MAX"))


def held_top_speed_mps(profile: Profile) -> float:
    """The top airspeed (m/s) a plan commands an ``arducopter`` profile's vehicle in its wind:
    what the lean limit holds through the wind's gusts (:func:`held_lean_top_speed_mps`),
    capped by VEHICLE_SPEED_MAX; in still air :func:`arducopter_top_speed_mps`."""
    return min(held_lean_top_speed_mps(profile), profile.si("VEHICLE_SPEED_MAX"))


def held_lean_top_speed_mps(profile: Profile) -> float:
    """The airspeed (m/s) an ``arducopter`` profile's vehicle holds leaning at its limit in its
    wind: the lean limit's top speed less what the gusts take (WIND_TURB,
    :func:`validator.wind.held_air_speed_mps`). Commanded more, the vehicle gives up the speed
    to the gusts: ArduCopter SITL flew legs straight into 7-8 m/s of wind with turbulence
    2 m/s at 9.79-9.88 m/s of air, 3-7 % late over the ground."""
    wind = profile_wind(profile)
    top = _lean_top_speed_mps(profile)
    return top if wind is None else held_air_speed_mps(top, wind.turbulence_mps)


def _lean_top_speed_mps(profile: Profile) -> float:
    """What the lean limit alone lets an ``arducopter`` profile's vehicle fly (m/s), in still
    air (:func:`top_speed_mps` at the profile's drag and air density)."""
    return top_speed_mps(arducopter_lean_max_deg(profile), _drag_per_m(profile))


def _drag_per_m(profile: Profile) -> float:
    """The drag deceleration over airspeed² (1/m) of an ``arducopter`` profile's vehicle:
    VEHICLE_DRAG at the air density of ALT_AMSL."""
    return profile.si("VEHICLE_DRAG") * air_density_ratio(profile.si("ALT_AMSL"))


def leg_speed_caps_mps(profile: Profile, unit: NDArray[np.float64],
                       names: list[str] | None = None,
                       top_mps: float | None = None) -> NDArray[np.float64]:
    """(n,) the fastest ground speed (m/s) a plan commands an ``arducopter`` profile's vehicle
    along each leg's direction ``unit`` (n, 3): its top speed (``top_mps``, by default
    :func:`arducopter_top_speed_mps`), which in wind (WIND_SPEED, WIND_FROM) holds in the air,
    so less upwind and more downwind (:func:`validator.wind.ground_speed_mps`: the planner's
    cone, whatever the vehicle's drag). A wind at or above the top speed is refused
    (:class:`InputError` naming the first leg, of ``names``, it cannot fly)."""
    top = arducopter_top_speed_mps(profile) if top_mps is None else top_mps
    return _course_caps_mps(profile, unit, top, names, ground_speed_mps)


def lean_caps_mps(profile: Profile, unit: NDArray[np.float64], air_speed_mps: float,
                  names: list[str] | None = None, held: bool = False) -> NDArray[np.float64]:
    """(n,) the ground speed (m/s) an ``arducopter`` profile's vehicle flies along each leg's
    direction ``unit`` (n, 3) leaning at its limit, ``air_speed_mps`` its top airspeed (with
    ``held``, what it holds through the wind's gusts): in wind, what the course leaves of it
    with the drag of ArduPilot's SITL quad, whose body drag is per axis
    (:data:`SITL_QUAD_LINEAR_DRAG_SHARE`, :func:`validator.wind.lean_limit_ground_speed_mps`),
    so across a wind more than a plan commands (:func:`leg_speed_caps_mps`). A wind at or
    above it is refused, as there."""
    return _course_caps_mps(profile, unit, air_speed_mps, names,
                            partial(lean_limit_ground_speed_mps,
                                    linear_share=SITL_QUAD_LINEAR_DRAG_SHARE), held)


def _course_caps_mps(profile: Profile, unit: NDArray[np.float64], top_mps: float,
                     names: list[str] | None,
                     along: Callable[[float, ArrayLike, ArrayLike], NDArray[np.float64]],
                     held: bool = False) -> NDArray[np.float64]:
    """(n,) :func:`validator.wind.course_speeds_mps` of ``top_mps`` along each leg's ``unit``
    in the profile's wind (``held``: an airspeed held through the gusts, as a refusal says),
    ``top_mps`` in still air."""
    wind = profile_wind(profile)
    if wind is None:
        return np.full(len(unit), top_mps)
    return course_speeds_mps(top_mps, wind, unit, names, along=along,
                             gusts=held and wind.turbulence_mps > 0)


def leg_speeds_mps(profile: Profile, speed_mps: float, unit_xy: ArrayLike) -> NDArray[np.float64]:
    """(n,) the ground speed (m/s) a plan commands an ``arducopter`` profile's legs along
    ``unit_xy`` (n, 2) at, and times them with, for a cruise speed ``speed_mps``: that speed,
    or in wind the lower ground speed the course leaves of the airspeed the vehicle holds
    through the gusts (:func:`held_top_speed_mps`; the replay's cap, :func:`lean_caps_mps`,
    is no less on any course, so it flies them as commanded). A wind at or above that airspeed
    is refused."""
    unit = np.atleast_2d(np.asarray(unit_xy, dtype=float))
    caps = leg_speed_caps_mps(profile, np.column_stack([unit, np.zeros(len(unit))]),
                              top_mps=held_top_speed_mps(profile))
    return np.asarray(np.minimum(float(speed_mps), caps), dtype=float)


def faces_course(profile: Profile) -> bool:
    """Whether an ``arducopter`` profile's vehicle faces along its course on mission legs
    (WP_YAW_BEHAVIOR in :data:`YAW_ALONG_COURSE`), as :func:`lean_caps_mps` takes it."""
    return float(profile.params["WP_YAW_BEHAVIOR"]) in YAW_ALONG_COURSE


def yaw_findings(profile: Profile) -> list[Finding]:
    """In wind, a warning when an ``arducopter`` profile's vehicle does not face along its
    course (:func:`faces_course`): the replay times its legs with the drag per body axis of a
    vehicle that does, so a crosswind leg flown at the lean limit may take another time."""
    if profile_wind(profile) is None or faces_course(profile):
        return []
    return [Finding("warning", f"WP_YAW_BEHAVIOR {profile.params['WP_YAW_BEHAVIOR']:g} does "
                    f"not turn the vehicle along its course on mission legs (1-3 do, 0 keeps "
                    f"its yaw), but the replay times legs in wind for a vehicle that does "
                    f"(WP_YAW_BEHAVIOR {PLAN_YAW_BEHAVIOR:g}, as the plan's parameters set "
                    f"it): legs across the wind at the lean limit may be flown at another "
                    f"speed")]
