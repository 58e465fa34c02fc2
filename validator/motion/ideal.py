"""The ``ideal`` profile: the plan's own timing.

Straight lines at the commanded speeds, instant speed changes, exact holds. Legs without a
commanded speed fly at ``SPEED`` (m/s, default: the site's V).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from validator.flight import Flight
from validator.motion.path import (
    FlownPath,
    LegGeometry,
    active_leg,
    kinematic_limit,
    leg_geometry,
    superpose,
    time_grid,
)
from validator.motion.profile import Profile
from validator.motion.scurve import Profiles1D, constant_speed


def _ideal_timing(
    flight: Flight, profile: Profile
) -> tuple[LegGeometry, Profiles1D, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    legs = flight.legs
    geom = leg_geometry(legs)
    cmd = np.array([leg.speed_mps or profile.si("SPEED") for leg in legs], dtype=float)
    horiz = np.minimum(cmd, profile.si("VEHICLE_SPEED_MAX"))
    speed = kinematic_limit(geom.unit, horiz, profile.si("SPEED_UP"), profile.si("SPEED_DN"))
    prof = constant_speed(geom.length_m, speed)
    hold = np.array([leg.hold_s for leg in legs], dtype=float)
    span = prof.total_s + hold
    start = np.concatenate([[0.0], np.cumsum(span)[:-1]])
    reached = start + prof.total_s
    done = reached + hold
    return geom, prof, start, reached, done


def ideal_leg_times(
    flight: Flight, profile: Profile
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Per leg: start, arrival and completion times (s) at the commanded speeds and holds.

    ``profile`` must be the ``ideal`` one (it supplies the default and vertical speeds).
    """
    _, _, start, reached, done = _ideal_timing(flight, profile)
    return start, reached, done


def fly(flight: Flight, profile: Profile, dt_s: float) -> FlownPath:
    """Fly ``flight`` with an ``ideal`` profile, sampled every ``dt_s`` seconds."""
    geom, prof, start, reached, done = _ideal_timing(flight, profile)
    t = time_grid(float(done[-1]), dt_s)
    pos, vel = superpose(geom, prof, start, t)
    return FlownPath(t, pos, vel, active_leg(done, t), start, reached, done)
