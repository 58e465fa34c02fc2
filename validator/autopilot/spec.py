"""One autopilot parameter as the autopilot documents it: unit, factor to SI, default, range."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

# MAV_PARAM_TYPE: how a parameter travels in PARAM_VALUE / PARAM_SET and in QGC's files
MAV_PARAM_TYPE_INT8 = 2
MAV_PARAM_TYPE_INT16 = 4
MAV_PARAM_TYPE_INT32 = 6
MAV_PARAM_TYPE_REAL32 = 9

# A vehicle limit a flight model puts in place of the autopilot's default (the field of
# :class:`validator.motion.limits.VehicleLimits` it reads).
LimitName = Literal["speed_mps", "accel_mps2", "jerk_mps3", "alt_amsl_m", "wind_speed_mps",
                    "wind_from_deg", "wind_turbulence_mps"]

# The least acceleration (m/s²) and jerk (m/s³) any flight model takes: a fifth of the least
# either autopilot documents (WPNAV_ACCEL 50 cm/s², MPC_ACC_HOR 2 m/s²) and a tenth of the
# least jerk (1 m/s³ both). A vehicle slower to speed up hovers; and the models' S-curves
# and corner searches grow as these shrink (WPNAV_ACCEL 1e-9 cm/s² took 25 GiB).
MIN_ACCEL_MPS2 = 0.1
MIN_JERK_MPS3 = 0.1
_FLOOR_SI = {"cm/s/s": MIN_ACCEL_MPS2, "m/s/s": MIN_ACCEL_MPS2, "m/s/s/s": MIN_JERK_MPS3}


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: ``unit`` as the autopilot writes it, ``to_si`` the factor to SI units
    (m, m/s, m/s², m/s³, s; angles stay in their unit), ``default`` the value a flight model
    assumes when nothing sets it (the autopilot's own, unless ``doc`` says otherwise), the
    documented range ``minimum``..``maximum``, and ``mav_type`` its MAV_PARAM_TYPE.

    ``limit``: a flight model of a vehicle with known limits starts from that limit instead of
    ``default`` (WPNAV_SPEED from the vehicle's top speed, say). ``zero_ok``: 0 is a setting
    (off, or "use another parameter"), not a missing value.
    """

    unit: str
    to_si: float
    default: float
    minimum: float
    maximum: float
    doc: str
    mav_type: int = MAV_PARAM_TYPE_REAL32
    limit: LimitName | None = None
    zero_ok: bool = False

    def in_range(self, value: float) -> bool:
        """Whether ``value`` (the autopilot's units) lies in the documented range."""
        return self.minimum <= value <= self.maximum

    def least(self) -> float:
        """The least value a flight model takes (the autopilot's units; 0 for no floor but 0)."""
        return _FLOOR_SI.get(self.unit, 0.0) / self.to_si

    def from_si(self, value_si: float) -> float:
        """``value_si`` in the autopilot's units."""
        return value_si * (1.0 / self.to_si)


def model_param(unit: str, doc: str, default: float = math.nan, *,
                limit: LimitName | None = None, zero_ok: bool = False) -> ParamSpec:
    """A parameter of our flight model, not of any autopilot (SI units, any value >= 0)."""
    return ParamSpec(unit, 1.0, default, 0.0, math.inf, doc, limit=limit, zero_ok=zero_ok)
