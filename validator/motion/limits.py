"""A multicopter's own limits: how far it may lean, and the top speed its drag then allows."""

from __future__ import annotations

import math

from validator.errors import InputError

GRAVITY_MPS2 = 9.80665
# Fitted to ArduCopter 4.5.6 SITL (quad, `+` frame; ../shared/data/arducopter-sitl-2): level
# top speed 10.03 m/s at 40 m AMSL and 10.37 m/s at 584 m, both at the 30° lean limit.
SITL_QUAD_DRAG_PER_M = 0.0561


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
