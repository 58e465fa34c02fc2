"""How the simulated vehicle moves outside AUTO: a point follower, speed- and
acceleration-limited horizontally, rate-limited vertically (AUTO flies the replay instead:
:mod:`validator.mavlink.autoflight`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

ARRIVED_M = 0.05  # closer than this and slower than SETTLED_MPS, the vehicle is there
SETTLED_MPS = 0.1
ARRIVED_ALT_M = 0.01


@dataclass(frozen=True)
class FollowLimits:
    """Horizontal speed (m/s) and acceleration (m/s²), climb and descent rates (m/s)."""

    speed_mps: float
    accel_mps2: float
    up_mps: float
    down_mps: float


@dataclass(frozen=True)
class Step:
    """The vehicle after one step: position (m east/north), velocity (east, north, up; m/s),
    altitude (m above home), and whether it is at the target."""

    xy: NDArray[np.float64]
    vel: NDArray[np.float64]
    alt_m: float
    at_target: bool


def follow(xy: NDArray[np.float64], vel: NDArray[np.float64], alt_m: float,
           target_xy: NDArray[np.float64], target_alt_m: float, dt_s: float,
           limits: FollowLimits) -> Step:
    """One step of ``dt_s`` towards the target: horizontally at most the speed, and no faster
    than it can still stop at the acceleration limit; vertically straight at the climb or
    descent rate."""
    accel = limits.accel_mps2
    vel = vel.copy()
    d = target_xy - xy
    dist = float(np.hypot(*d))
    want = (d / dist * min(limits.speed_mps, math.sqrt(2 * accel * dist)) if dist > 1e-6
            else np.zeros(2))
    dv = want - vel[:2]
    n = float(np.hypot(*dv))
    if n > accel * dt_s:
        dv *= accel * dt_s / n
    vel[:2] += dv
    xy = xy + vel[:2] * dt_s
    if dist < ARRIVED_M and float(np.hypot(*vel[:2])) < SETTLED_MPS:
        xy = target_xy.copy()
        vel[:2] = 0.0
    dz = target_alt_m - alt_m
    vz = float(np.clip(dz / dt_s, -limits.down_mps, limits.up_mps))
    vel[2] = vz
    alt_m += vz * dt_s
    return Step(xy, vel, alt_m, dist < ARRIVED_M and abs(dz) < ARRIVED_ALT_M)
