"""Multicopter flight profiles: how an autopilot turns a resolved flight into motion in time.

Three profiles (:func:`~validator.motion.profile.make_profile`), parameters in the autopilot's
own names and units so a ``.param`` file's values can be passed straight through
(``--param WPNAV_ACCEL=500``):

``ideal`` (:mod:`validator.motion.ideal`)
    Straight lines at the commanded speeds, instant speed changes, exact holds: the plan's own
    timing.
``arducopter`` (:mod:`validator.motion.arducopter`)
    ArduCopter 4.x S-curve navigation: every leg a jerk-limited S-curve from rest to rest, a
    waypoint without a hold passed by blending the two legs inside WPNAV_RADIUS, holds in whole
    seconds, speed capped by the lean-limited top speed (:mod:`validator.motion.limits`);
    take-off, landing and stops timed as ArduCopter 4.5.6 SITL flew them.
``px4`` (:mod:`validator.motion.px4_mission`)
    PX4 v1.15 mission following by its own rules (:mod:`validator.motion.px4`): corners
    rounded inside NAV_ACC_RAD, the vehicle tracking its trajectory against drag, holds in
    fractional seconds; checked on PX4 v1.15.4 SIH flights of our plans.

:func:`fly` evaluates a profile and returns a :class:`~validator.motion.path.FlownPath`:
samples of the commanded position (the vehicle is assumed to track its target; the position
controller's small lag is not modelled) and the time each leg started, reached its
destination and completed.

The rules live in :mod:`validator.motion`; the names below are re-exported from there, so
``from validator.dynamics import X`` works as it always has.
"""

from __future__ import annotations

from validator.errors import InputError
from validator.flight import Flight
from validator.motion import arducopter, ideal, px4_mission
from validator.motion.arducopter import (
    CORNER_SEARCH_STEP_S,
    LAND_DETECT_S,
    LIFTOFF_DELAY_S,
    STOP_LAG_S,
    arducopter_accel_mps2,
    arducopter_lean_max_deg,
    arducopter_top_speed_mps,
    corner_overlaps_s,
    jerk_ramp_s,
)
from validator.motion.ideal import ideal_leg_times
from validator.motion.limits import (
    GRAVITY_MPS2,
    SITL_QUAD_DRAG_PER_M,
    VehicleLimits,
    air_density_ratio,
    lean_angle_max_deg,
    site_limits,
    top_speed_mps,
)
from validator.motion.path import FlownPath, LegGeometry, kinematic_limit, leg_geometry
from validator.motion.profile import (
    PARAM_SPECS,
    PROFILES,
    ParamSpec,
    Profile,
    ProfileName,
    flown_params,
    make_profile,
    parse_param_overrides,
)
from validator.motion.px4_mission import (
    PX4_ARRIVAL_LAG_S,
    PX4_LAND_DETECT_S,
    PX4_LIFTOFF_DELAY_S,
    px4_rest_to_rest,
    px4_top_speed_mps,
)
from validator.motion.scurve import (
    SEG_CRUISE,
    SEG_DECEL_START,
    Profiles1D,
    constant_speed,
    scurve_peak_speed,
    scurve_rest_to_rest,
    scurve_to_touchdown,
)

__all__ = [
    "CORNER_SEARCH_STEP_S", "GRAVITY_MPS2", "LAND_DETECT_S", "LIFTOFF_DELAY_S", "PARAM_SPECS",
    "PROFILES", "PX4_ARRIVAL_LAG_S", "PX4_LAND_DETECT_S", "PX4_LIFTOFF_DELAY_S", "SEG_CRUISE",
    "SEG_DECEL_START", "SITL_QUAD_DRAG_PER_M", "STOP_LAG_S", "FlownPath", "LegGeometry",
    "ParamSpec", "Profile", "ProfileName", "Profiles1D", "VehicleLimits", "air_density_ratio",
    "arducopter_accel_mps2", "arducopter_lean_max_deg", "arducopter_top_speed_mps",
    "constant_speed", "corner_overlaps_s", "flown_params", "fly",
    "ideal_leg_times", "jerk_ramp_s", "kinematic_limit", "lean_angle_max_deg", "leg_geometry",
    "make_profile", "parse_param_overrides", "px4_rest_to_rest", "px4_top_speed_mps",
    "scurve_peak_speed", "scurve_rest_to_rest", "scurve_to_touchdown", "site_limits",
    "top_speed_mps"
]


def fly(flight: Flight, profile: Profile, *, dt_s: float = 0.05) -> FlownPath:
    """Fly ``flight`` with ``profile``, sampled every ``dt_s`` seconds (and at the very end)."""
    if not flight.legs:
        raise InputError("plan: nothing to replay (no navigation items)")
    if not dt_s > 0:
        raise InputError(f"--dt: must be > 0, got {dt_s}")
    if profile.name == "ideal":
        return ideal.fly(flight, profile, dt_s)
    if profile.name == "arducopter":
        return arducopter.fly(flight, profile, dt_s)
    return px4_mission.fly(flight, profile, dt_s)
