"""Legs in 3-D and the flown path: every leg's 1-D motion laid along its leg and summed in time."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from validator.flight import Leg
from validator.motion.scurve import Profiles1D


@dataclass(frozen=True)
class LegGeometry:
    """Legs as 3-D vectors (x east, y north, z up; metres): start points and displacements."""

    start: NDArray[np.float64]  # (n, 3)
    delta: NDArray[np.float64]  # (n, 3)

    @property
    def length_m(self) -> NDArray[np.float64]:
        return np.asarray(np.linalg.norm(self.delta, axis=1), dtype=float)

    @property
    def unit(self) -> NDArray[np.float64]:
        L = self.length_m
        return np.divide(self.delta, L[:, None], out=np.zeros_like(self.delta),
                         where=L[:, None] > 0)


def leg_geometry(legs: tuple[Leg, ...]) -> LegGeometry:
    """The legs as 3-D vectors, altitudes as z."""
    start = np.array([[*leg.start_xy_m, leg.start_alt_m] for leg in legs], dtype=float)
    end = np.array([[*leg.end_xy_m, leg.end_alt_m] for leg in legs], dtype=float)
    return LegGeometry(start.reshape(-1, 3), (end - start).reshape(-1, 3))


def kinematic_limit(
    unit: NDArray[np.float64], horiz: NDArray[np.float64], up: NDArray[np.float64] | float,
    down: NDArray[np.float64] | float,
) -> NDArray[np.float64]:
    """Largest magnitude along ``unit`` (n, 3) whose horizontal part ≤ ``horiz`` and vertical
    part ≤ ``up`` (climbing) or ``down`` (descending)."""
    h = np.hypot(unit[:, 0], unit[:, 1])
    z = unit[:, 2]
    vert = np.where(z > 0, up, down) * np.ones_like(z)
    with np.errstate(divide="ignore"):
        lim_h = np.where(h > 1e-9, horiz / np.maximum(h, 1e-12), np.inf)
        lim_z = np.where(np.abs(z) > 1e-9, vert / np.maximum(np.abs(z), 1e-12), np.inf)
    out = np.minimum(lim_h, lim_z)
    return np.asarray(np.where(np.isfinite(out), out, horiz), dtype=np.float64)


@dataclass(frozen=True)
class FlownPath:
    """A modelled flight sampled in time.

    ``t_s`` (n,) from the start of the mission; ``xyz_m`` (n, 3) east, north, up above home;
    ``vel_mps`` (n, 3); ``leg`` (n,) the active leg (index into ``Flight.legs``; the leg whose
    item is the autopilot's current mission item). Per leg: ``start_s`` the leg's motion
    begins, ``reached_s`` its destination is reached (hold starts), ``done_s`` the item
    completes (hold over, the next item becomes current).
    """

    t_s: NDArray[np.float64]
    xyz_m: NDArray[np.float64]
    vel_mps: NDArray[np.float64]
    leg: NDArray[np.int64]
    start_s: NDArray[np.float64]
    reached_s: NDArray[np.float64]
    done_s: NDArray[np.float64]
    # when each leg's own motion ends, where it is not start_s plus its profile's duration
    # (ArduCopter: a sharp corner's lag slows the clock inside the legs; None elsewhere)
    end_s: NDArray[np.float64] | None = None


def superpose(
    geom: LegGeometry, prof: Profiles1D, start_s: NDArray[np.float64], t: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Target position and velocity at times ``t``: the sum of every leg's own profile."""
    n = len(start_s)
    total = prof.total_s
    end_s = start_s + total
    order = np.argsort(end_s, kind="stable")
    cum = np.vstack([np.zeros((1, 3)), np.cumsum(geom.delta[order], axis=0)])
    ended = np.searchsorted(end_s[order], t, side="right")
    pos = geom.start[0] + cum[ended] if n else np.zeros((t.size, 3))
    vel = np.zeros((t.size, 3))
    lo = np.searchsorted(t, start_s, side="right")
    hi = np.searchsorted(t, end_s, side="left")
    counts = np.maximum(hi - lo, 0)
    if counts.sum():
        leg_idx = np.repeat(np.arange(n), counts)
        offsets = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        sample = np.repeat(lo, counts) + offsets
        p, v, _ = prof.state(leg_idx, t[sample] - start_s[leg_idx])
        u = geom.unit[leg_idx]
        np.add.at(pos, sample, u * p[:, None])
        np.add.at(vel, sample, u * v[:, None])
    return pos, vel


def active_leg(done_s: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.int64]:
    """Leg whose item is current: leg i is current from done_s[i-1] until done_s[i]."""
    n = len(done_s)
    return np.minimum(np.searchsorted(done_s, t, side="right"), max(n - 1, 0)).astype(np.int64)


def time_grid(end_s: float, dt_s: float) -> NDArray[np.float64]:
    """Sample times (s) every ``dt_s`` from 0, and at ``end_s`` itself."""
    n = int(math.floor(end_s / dt_s + 1e-9)) + 1
    t = np.arange(n, dtype=np.float64) * dt_s
    return t if t[-1] >= end_s - 1e-9 else np.append(t, np.float64(end_s))
