"""ArduCopter's speed change at a corner flown through: the rules of ``SCurve::set_speed_max``
(ArduCopter 4.5.6) for a leg whose S-curve was built at the speed of the leg before.

While a leg runs, AC_WPNav builds the next leg's S-curve at the speed then in force; the
DO_CHANGE_SPEED between the two legs only runs once the corner's waypoint is reached, when
the next leg has started. :func:`corner_first_speeds_mps` is the speed that leg first runs at,
:func:`corner_changed_speeds_mps` the speed it then changes to. Speeds in m/s, distances in m,
times in s; the flight model that uses them is :mod:`validator.motion.arducopter`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from validator.motion.scurve import change_reach_mps


def corner_changed_speeds_mps(
    first_mps: NDArray[np.float64], speed_mps: NDArray[np.float64],
    built_const_m: NDArray[np.float64], jerk_ramp_s: NDArray[np.float64],
    accel_mps2: NDArray[np.float64], jerk_mps3: NDArray[np.float64],
) -> NDArray[np.float64]:
    """(n,) the speed (m/s) a leg that first runs at ``first_mps`` changes to on the way to its
    own ``speed_mps``, as ``SCurve::set_speed_max`` allows: only where the constant-speed part
    of the S-curve it was built as (``built_const_m``, m) lasts more than 12 jerk times (the
    jerk ramp ``jerk_ramp_s``, at most 1 s) at the first speed, else it keeps the first speed;
    a rise only to that part's length over 12 jerk times; and, up or down, only as far as the
    change gets in half that part (:func:`~validator.motion.scurve.change_reach_mps`, at
    ``accel_mps2`` and ``jerk_mps3``). Measured on ArduCopter 4.5.6 SITL (harbour site, 7 m/s
    from 315°): a 79 m leg built at 5.2 m/s with 54 m at that speed, commanded 10, rose to
    8.4 m/s (the change that fits in 27 m) and braked for the next corner."""
    jerk_time = np.minimum(np.asarray(jerk_ramp_s, dtype=float), 1.0)
    room = np.asarray(built_const_m, dtype=float) / (12.0 * jerk_time)
    up = np.minimum(speed_mps, room)
    changed = np.where(speed_mps > first_mps, up, speed_mps)
    target = np.where(room > first_mps, changed, first_mps)
    return change_reach_mps(first_mps, target, np.asarray(built_const_m, dtype=float) / 2.0,
                            accel_mps2, jerk_mps3, jerk_ramp_s)


def corner_first_speeds_mps(
    speed_mps: NDArray[np.float64], built_mps: NDArray[np.float64],
    after_corner: NDArray[np.bool_], jerk_gain_mps: NDArray[np.float64],
) -> NDArray[np.float64]:
    """(n,) the speed (m/s) each leg first accelerates to before it changes to its own
    ``speed_mps``: its own speed, but for a leg entered through a corner flown through
    (``after_corner``), whose S-curve ArduCopter built while the leg before ran, at that
    leg's speed (``built_mps``, whatever this leg's course lets the vehicle fly: the
    S-curve's own speed, which the vehicle follows no faster than it can). Its DO_CHANGE_SPEED
    runs once the corner's waypoint is reached, when the new leg has started, and
    ``SCurve::set_speed_max`` can then only shorten the constant-acceleration segment still
    ahead: a slower leg first reaches the built speed, or at least what the jerk phases alone
    gain (``jerk_gain_mps``, :func:`~validator.motion.scurve.accel_phase_gain_mps`), then
    slows; a faster one first reaches the built speed, then speeds up. Measured on ArduCopter
    4.5.6 SITL in wind (harbour site, 7 m/s from 315°): a leg built at 9.3 m/s and commanded
    3.57 m/s ran at 5.3 m/s (its top speed in that wind) for 5 s before slowing; one built at
    3.11 commanded 10 held 3.1 m/s for a second before accelerating again."""
    slower = built_mps > speed_mps
    first = np.where(slower, np.minimum(built_mps, np.maximum(speed_mps, jerk_gain_mps)),
                     built_mps)
    return np.asarray(np.where(after_corner, first, speed_mps), dtype=float)
