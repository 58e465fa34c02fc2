"""How each autopilot flies what a plan says: holds, when a vehicle stands still, corner radius.

- **Holds.** ArduCopter keeps a waypoint's hold (NAV_WAYPOINT param1) as whole seconds, and
  truncates a fraction (:func:`stored_hold_s`; the replay and a recorded track's reading of
  it use this). So an ArduPilot mission is exported with whole-second holds, rounded by error
  diffusion along the cycle (:func:`whole_second_holds`), so that no hold is off by a second or
  more and the cycle's total differs from the plan by less than half a second. PX4 keeps
  fractional holds.
- **Standing still.** A planned slot that moves less than :data:`STATIONARY_M` is a hover: the
  exporter merges it into a waypoint's hold, the flyable timing takes it for a hover point,
  the throughput reading of a track for a hold.
- **Slowest speed.** ArduCopter ignores a DO_CHANGE_SPEED below
  :data:`ARDUPILOT_MIN_SPEED_MPS` (WPNAV_SPEED's documented minimum); the exporter flies a
  slower leg at that speed and holds for the rest of its slot.
- **A failsafe's landing.** ArduCopter's failsafe LAND pauses :data:`FAILSAFE_LAND_PAUSE_S`,
  then descends at LAND_SPEED_HIGH (0: WPNAV_SPEED_DN) to LAND_ALT_LOW and at LAND_SPEED to the
  ground (:func:`failsafe_land_s`); a vehicle without a position drifts with the wind all
  that time (:mod:`validator.position_loss`). PX4's Descend, its fallback without a position,
  sinks at MPC_LAND_SPEED all the way (:func:`px4_descend_s`).
- **Corner radius.** Both autopilots cut a corner inside the acceptance radius (ArduCopter
  WPNAV_RADIUS, PX4 NAV_ACC_RAD; :data:`ACCEPTANCE_RADIUS_PARAM`). :func:`acceptance_radius_m`
  keeps a wanted radius between the autopilot's minimum and its default (wider corners save
  little time).

The S-curve limits ArduCopter flies with (WPNAV_ACCEL capped by the lean angle, the lean- and
drag-limited top speed, the jerk ramp) are derived from the parameters in one place,
:func:`validator.motion.arducopter.scurve_limits`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from validator.autopilot.tables import param_table

STATIONARY_M = 0.05  # a planned slot that moves less than this (m) is a hover
# ArduCopter ignores a DO_CHANGE_SPEED below WPNAV_SPEED's minimum (AC_WPNav's
# WPNAV_WP_SPEED_MIN, 20 cm/s): a slower leg must be flown faster and wait at its end.
_WPNAV_SPEED = param_table("ardupilot")["WPNAV_SPEED"]
ARDUPILOT_MIN_SPEED_MPS = _WPNAV_SPEED.minimum * _WPNAV_SPEED.to_si
ACCEPTANCE_RADIUS_PARAM = {"ardupilot": "WPNAV_RADIUS", "px4": "NAV_ACC_RAD"}


def default_speed_mps(params: Mapping[str, float] | None, autopilot: str = "ardupilot"
                      ) -> float:
    """The horizontal speed (m/s) ``autopilot`` flies a leg with no DO_CHANGE_SPEED in force:
    ArduCopter's WPNAV_SPEED (cm/s), PX4's MPC_XY_CRUISE, from ``params``, else its default."""
    if autopilot == "px4":
        return _param_si("MPC_XY_CRUISE", params, "px4")
    return _param_si("WPNAV_SPEED", params)


def _param_si(name: str, params: Mapping[str, float] | None, autopilot: str = "ardupilot"
              ) -> float:
    """``autopilot``'s parameter ``name`` in SI units: from ``params`` (its own units), else
    its default."""
    spec = param_table(autopilot)[name]
    return spec.to_si * float((params or {}).get(name, spec.default))


FAILSAFE_LAND_PAUSE_S = 4.0  # ArduCopter's LAND_WITH_DELAY_MS (config.h): a failsafe's pause
PX4_TOUCHDOWN_S = 3.0  # Descend's last metres to ground contact (fitted: 46.0 s from 30.1 m)
TOUCHDOWN_S = 4.5  # slowing onto LAND_ALT_LOW and the land detector (fitted: 41.8 s from 30 m)


def failsafe_land_s(altitude_m: float, params: Mapping[str, float] | None) -> float:
    """Seconds (s) from ArduCopter's failsafe LAND, ``altitude_m`` above home, to touchdown:
    the pause, LAND_SPEED_HIGH (0: WPNAV_SPEED_DN, never below LAND_SPEED) down to
    LAND_ALT_LOW, LAND_SPEED below, and :data:`TOUCHDOWN_S`. ArduCopter 4.5.6 SITL from 30 m
    with the defaults: 41.75 and 41.8 s measured (GPS loss in 4 and 6 m/s of wind), 41.8 s
    here."""
    slow = _param_si("LAND_SPEED", params)
    fast = max(_param_si("LAND_SPEED_HIGH", params) or _param_si("WPNAV_SPEED_DN", params),
               slow)
    low = _param_si("LAND_ALT_LOW", params)
    h = max(float(altitude_m), 0.0)
    return FAILSAFE_LAND_PAUSE_S + max(h - low, 0.0) / fast + min(h, low) / slow + TOUCHDOWN_S


def px4_descend_s(altitude_m: float, params: Mapping[str, float] | None) -> float:
    """Seconds (s) from PX4's Descend, ``altitude_m`` above home, to touchdown: the mode a
    failsafe falls back to without a position (FlightTaskDescend) sinks at MPC_LAND_SPEED all
    the way (its slower stages need a position), then :data:`PX4_TOUCHDOWN_S` of slowing
    onto the ground. PX4 v1.15.4 SIH from 30 m (GPS loss): on the ground 46 s after the
    failsafe, 45.9 s here (its land detector, on an estimate without a position, then took
    up to 16 s more to disarm: the vehicle no longer moves)."""
    return (max(float(altitude_m), 0.0) / _param_si("MPC_LAND_SPEED", params, "px4")
            + PX4_TOUCHDOWN_S)


def stored_hold_s(hold_s: float, autopilot: str = "ardupilot") -> float:
    """The hold (s) ``autopilot`` keeps of a planned ``hold_s``: ArduCopter truncates it to
    whole seconds (a uint16; float noise just below a second still counts as that second), PX4
    keeps it."""
    return float(math.floor(hold_s + 1e-9)) if autopilot == "ardupilot" else float(hold_s)


def whole_second_holds(holds_s: ArrayLike) -> NDArray[np.float64]:
    """Holds (s) rounded to whole seconds by error diffusion along the sequence.

    Hold k becomes round(Σ_{i≤k} h_i) − round(Σ_{i<k} h_i): never negative, zero where the
    planned hold is zero, and the total stays within half a second of the planned total.
    """
    cum = np.cumsum(np.asarray(holds_s, dtype=float))
    rounded = np.floor(cum + 0.5)
    return np.diff(np.concatenate([[0.0], rounded]))


def programmed_holds_s(holds_s: ArrayLike, autopilot: str) -> NDArray[np.float64]:
    """The holds (s) to write in ``autopilot``'s mission for the planned ``holds_s``: whole
    seconds for ArduPilot (:func:`whole_second_holds`), unchanged for PX4."""
    if autopilot == "ardupilot":
        return whole_second_holds(holds_s)
    return np.asarray(holds_s, dtype=float)


def acceptance_radius_m(wanted_m: float, autopilot: str = "ardupilot") -> float:
    """``wanted_m`` within ``autopilot``'s acceptance radius range as a mission uses it: at
    least the documented minimum (ArduCopter 5 cm, PX4 0.05 m), at most the default (2 m for
    both multicopters)."""
    spec = param_table(autopilot)[ACCEPTANCE_RADIUS_PARAM[autopilot]]
    lowest, widest = spec.minimum * spec.to_si, spec.default * spec.to_si
    return float(min(widest, max(lowest, wanted_m)))
