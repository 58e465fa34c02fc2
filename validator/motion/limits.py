"""A multicopter's own limits: speed, acceleration, jerk, lean, and the top speed drag allows."""

from __future__ import annotations

import math
from dataclasses import dataclass

from validator.errors import InputError
from validator.site import Site

GRAVITY_MPS2 = 9.80665
# Fitted to ArduCopter 4.5.6 SITL (quad, `+` frame; ../shared/data/arducopter-sitl-2): level
# top speed 10.03 m/s at 40 m AMSL and 10.37 m/s at 584 m, both at the 30° lean limit.
SITL_QUAD_DRAG_PER_M = 0.0561
# The share of that drag, at that top speed, that is the rotors' momentum drag: linear in the
# airspeed and the same every way; the rest is the body's, quadratic per body axis (SITL's
# quad, SIM_Motor.cpp and SIM_Frame.cpp at 4.5.6: mdrag_coef·sqrt(ρ·disc_area·T)·v, with
# mdrag_coef 0.2, disc_area 0.385 m², T = m·g / cos 30°, m 3 kg, against m·g·tan 30°: 8.0 N
# of 17.0 at 10.03 m/s and 40 m AMSL, 0.475 at 584 m). It sets how much more air speed the
# quad holds crabbing across a wind (:func:`validator.wind.lean_limit_ground_speed_mps`).
SITL_QUAD_LINEAR_DRAG_SHARE = 0.47


@dataclass(frozen=True)
class VehicleLimits:
    """What a flight model needs to know of the vehicle: its top speed (m/s), acceleration
    (m/s²) and jerk (m/s³) limits, and the altitude it flies at above mean sea level (m, for
    the air density), and the air it flies in there: the wind's speed (m/s), the direction
    it blows from (degrees true) and its turbulence (m/s; :mod:`validator.wind`)."""

    speed_mps: float
    accel_mps2: float
    jerk_mps3: float
    alt_amsl_m: float = 0.0
    wind_speed_mps: float = 0.0
    wind_from_deg: float = 0.0
    wind_turbulence_mps: float = 0.0


def site_limits(site: Site) -> VehicleLimits:
    """The limits of a site's vehicle (``uav`` block), flying at the site's altitude in its
    wind there (``wind:``; still air without)."""
    wind = site.flight_wind
    return VehicleLimits(site.max_speed_mps, site.max_accel_mps2, site.max_jerk_mps3,
                         site.frame.alt0_m + site.altitude_m,
                         wind.speed_mps if wind else 0.0, wind.from_deg if wind else 0.0,
                         wind.turbulence_mps if wind else 0.0)


def air_density_ratio(alt_amsl_m: float) -> float:
    """Air density at ``alt_amsl_m`` metres above mean sea level over sea level's (ISA
    troposphere: (1 − 2.25577e-5·h)^4.2559)."""
    return float((1.0 - 2.25577e-5 * alt_amsl_m) ** 4.2559)


def lean_angle_max_deg(angle_max_cdeg: float, psc_angle_max_deg: float = 0.0) -> float:
    """The lean limit (degrees) ArduCopter's position controller flies with: PSC_ANGLE_MAX
    (degrees) when set, else ANGLE_MAX (centidegrees)."""
    return psc_angle_max_deg if psc_angle_max_deg > 0 else angle_max_cdeg / 100.0


def top_speed_mps(
    angle_max_deg: float,
    drag_per_m: float = SITL_QUAD_DRAG_PER_M,
    density_ratio: float = 1.0,
) -> float:
    """Fastest level speed (m/s) of a multicopter leaning at most ``angle_max_deg`` degrees.

    Holding altitude at lean θ leaves g·tan θ (m/s²) of horizontal thrust, which the air's drag
    ``drag_per_m``·σ·v² (m/s², σ = ``density_ratio``, the air density over sea level's, see
    :func:`air_density_ratio`) balances at v = sqrt(g·tan θ / (k·σ)). The default k (1/m) is
    fitted to ArduPilot's SITL quad: 10.07 m/s at 30° near sea level. No drag: infinite.
    """
    if not 0.0 < angle_max_deg < 90.0:
        raise InputError(f"lean angle limit: must be between 0 and 90 degrees, got "
                         f"{angle_max_deg}")
    drag = drag_per_m * density_ratio
    if drag <= 0:
        return math.inf
    return math.sqrt(GRAVITY_MPS2 * math.tan(math.radians(angle_max_deg)) / drag)
