"""Motion along one straight leg in 1-D: jerk-limited S-curves and constant-speed moves."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

# S-curves: segments 0-6 accelerate, 7-13 change to the leg's speed (empty but after a speed
# change at a corner flown through), 14 cruises, 15-21 decelerate, 22 end run
SEG_CHANGE_START = 7
SEG_CRUISE = 14
SEG_DECEL_START = 15


@dataclass(frozen=True)
class Profiles1D:
    """Piecewise-polynomial motion along ``n`` straight legs (1-D, metres along each leg).

    ``dur_s``, ``jerk0`` and ``snap`` are (n, S): per segment its duration (s), the jerk at its
    start (m/s³) and its constant snap (m/s⁴). ``v0_mps`` (n,) is the speed at the start (0 for
    rest-to-rest). Boundary states (position, speed, acceleration) are precomputed. Before time
    0 and after the last segment the leg is at rest (position 0, resp. ``length_m``).
    """

    length_m: NDArray[np.float64]
    v0_mps: NDArray[np.float64]
    dur_s: NDArray[np.float64]
    jerk0: NDArray[np.float64]
    snap: NDArray[np.float64]

    def __post_init__(self) -> None:
        n, segs = self.dur_s.shape
        t, p, v, a = (np.zeros((n, segs + 1)) for _ in range(4))
        v[:, 0] = self.v0_mps
        for k in range(segs):
            d, j, s = self.dur_s[:, k], self.jerk0[:, k], self.snap[:, k]
            t[:, k + 1] = t[:, k] + d
            p[:, k + 1] = p[:, k] + v[:, k] * d + a[:, k] * d**2 / 2 + j * d**3 / 6 + s * d**4 / 24
            v[:, k + 1] = v[:, k] + a[:, k] * d + j * d**2 / 2 + s * d**3 / 6
            a[:, k + 1] = a[:, k] + j * d + s * d**2 / 2
        object.__setattr__(self, "_bounds", (t, p, v, a))

    @property
    def total_s(self) -> NDArray[np.float64]:
        """Duration of each leg's motion (s)."""
        return np.asarray(self._bounds[0][:, -1])  # type: ignore[attr-defined]

    def boundary_time_s(self, k: int) -> NDArray[np.float64]:
        """Time (s) at which segment ``k`` starts (k = S: the end)."""
        return np.asarray(self._bounds[0][:, k])  # type: ignore[attr-defined]

    def end_speed_mps(self) -> NDArray[np.float64]:
        """The speed (m/s) each leg brakes from: its cruise, or a short leg's peak."""
        return np.asarray(self._bounds[2][:, SEG_DECEL_START])  # type: ignore[attr-defined]

    def state(
        self, leg: NDArray[np.int64], tau_s: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Position (m), speed (m/s), acceleration (m/s²) of legs ``leg`` at local times
        ``tau_s``."""
        t, p, v, a = self._bounds  # type: ignore[attr-defined]
        leg = np.asarray(leg, dtype=np.int64)
        tau = np.asarray(tau_s, dtype=float)
        bt = t[leg]
        segs = self.dur_s.shape[1]
        k = np.clip(np.sum(tau[:, None] >= bt[:, 1:], axis=1), 0, segs - 1)
        d = np.clip(tau - bt[np.arange(leg.size), k], 0.0, None)
        p0, v0, a0 = p[leg, k], v[leg, k], a[leg, k]
        j0, s = self.jerk0[leg, k], self.snap[leg, k]
        pos = p0 + v0 * d + a0 * d**2 / 2 + j0 * d**3 / 6 + s * d**4 / 24
        vel = v0 + a0 * d + j0 * d**2 / 2 + s * d**3 / 6
        acc = a0 + j0 * d + s * d**2 / 2
        done = tau >= bt[:, -1]
        before = tau <= 0.0
        pos = np.where(done, self.length_m[leg], np.where(before, 0.0, pos))
        vel = np.where(done | (before & (self.v0_mps[leg] == 0)), 0.0, vel)
        acc = np.where(done | before, 0.0, acc)
        return pos, vel, acc


def _full_jerk(
    A: NDArray[np.float64], J: NDArray[np.float64], tj: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The peak jerk (m/s³) and its hold t2 (s) of an acceleration phase that reaches ``A``."""
    jm = np.minimum(J, np.divide(A, tj, out=np.full_like(A, np.inf), where=tj > 0))
    return jm, np.maximum(A / jm - tj, 0.0)


def _accel_phase(
    v: NDArray[np.float64], A: NDArray[np.float64], J: NDArray[np.float64], tj: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Jerk (m/s³), jerk-hold t2, accel-hold t4 and duration (s) of a rest-to-``v`` phase.

    The jerk ramps over ``tj`` to ±J, holds t2, ramps back; the acceleration holds its peak t4.
    Peak acceleration J·(tj + t2) ≤ A; speed gained = peak·(2·tj + t2 + t4).
    """
    jm, t2_full = _full_jerk(A, J, tj)
    v_full = A * (2.0 * tj + t2_full)  # least speed gain that reaches A
    with np.errstate(invalid="ignore", divide="ignore"):
        # below v_full: v = J·(tj + t2)·(2·tj + t2), solved for t2 >= 0
        t2_part = (-3.0 * tj + np.sqrt(tj * tj + 4.0 * v / jm)) / 2.0
    small = t2_part < 0  # too small even for full-height jerk ramps: lower the jerk
    jm_small = np.divide(v, 2.0 * tj * tj, out=np.zeros_like(v), where=tj > 0)
    full = v >= v_full
    t2 = np.where(full, t2_full, np.where(small, 0.0, t2_part))
    jm = np.where(~full & small, jm_small, jm)
    peak = jm * (tj + t2)
    t4 = np.where(full, np.divide(v, A, out=np.zeros_like(v), where=A > 0) - 2.0 * tj - t2, 0.0)
    t4 = np.maximum(t4, 0.0)
    dur = 4.0 * tj + 2.0 * t2 + t4
    ok = v > 0
    return (np.where(ok, jm, 0.0), np.where(ok, t2, 0.0), np.where(ok, t4, 0.0),
            np.where(ok & (peak > 0), dur, 0.0))


def _bisect(
    distance: Callable[[NDArray[np.float64]], NDArray[np.float64]], length_m: NDArray[np.float64],
    lo: NDArray[np.float64], hi: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The largest speed (m/s) in [lo, hi] whose ``distance`` stays within ``length_m``
    (``distance`` increasing), to 1e-10 of ``hi``: far below any tolerance of a plan.

    Regula falsi with the Illinois rule (the end kept twice in a row has its residual halved),
    which keeps a bracket like bisection but converges superlinearly on these smooth curves:
    about 10 evaluations where halving took 34 (the export times dozens of legs)."""
    tol = 1e-10 * hi
    f_lo = distance(lo) - length_m
    f_hi = distance(hi) - length_m
    # Outside the bracket's assumptions the answer is an end: all of [lo, hi] fits (hi), or
    # nothing does (lo), as halving would have returned.
    lo = np.where(f_hi <= 0.0, hi, lo)
    hi = np.where(f_lo > 0.0, lo, hi)
    kept = np.zeros(lo.shape, dtype=np.int8)  # the end kept last time: -1 lo, +1 hi
    for _ in range(100):
        if np.all(hi - lo <= tol):
            break
        with np.errstate(invalid="ignore", divide="ignore"):
            mid = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        # Fall back to halving where the secant leaves the open bracket.
        mid = np.where((mid > lo) & (mid < hi), mid, (lo + hi) / 2.0)
        f_mid = distance(mid) - length_m
        longer = f_mid > 0.0
        f_lo = np.where(longer, np.where(kept == -1, f_lo / 2.0, f_lo), f_mid)
        f_hi = np.where(longer, f_mid, np.where(kept == 1, f_hi / 2.0, f_hi))
        kept = np.where(longer, -1, 1).astype(np.int8)
        hi = np.where(longer, mid, hi)
        lo = np.where(longer, lo, mid)
    return lo


def accel_phase_gain_mps(
    accel_mps2: NDArray[np.float64], jerk_mps3: NDArray[np.float64],
    jerk_ramp_s: NDArray[np.float64] | float,
) -> NDArray[np.float64]:
    """The speed (m/s) an acceleration phase gains in its jerk segments alone, with no time at
    full acceleration: the least gain that reaches ``accel_mps2``."""
    A = np.asarray(accel_mps2, dtype=float)
    tj = np.broadcast_to(np.asarray(jerk_ramp_s, dtype=float), A.shape)
    _, t2_full = _full_jerk(A, np.asarray(jerk_mps3, dtype=float), tj)
    return np.asarray(A * (2.0 * tj + t2_full), dtype=float)


def rest_to_rest_m(
    speed_mps: NDArray[np.float64], accel_mps2: NDArray[np.float64],
    jerk_mps3: NDArray[np.float64], jerk_ramp_s: NDArray[np.float64] | float,
) -> NDArray[np.float64]:
    """The distance (m) a move from rest to ``speed_mps`` and back to rest covers, with no
    cruise: the speed times one acceleration phase (the two phases mirror each other)."""
    v = np.asarray(speed_mps, dtype=float)
    tj = np.broadcast_to(np.asarray(jerk_ramp_s, dtype=float), v.shape)
    return np.asarray(v * _accel_phase(v, np.asarray(accel_mps2, dtype=float),
                                       np.asarray(jerk_mps3, dtype=float), tj)[3], dtype=float)


def _change_distance(
    v1: NDArray[np.float64], v2: NDArray[np.float64], A: NDArray[np.float64],
    J: NDArray[np.float64], tj: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Distance (m) a jerk-limited change from ``v1`` to ``v2`` covers: the mean speed over an
    acceleration phase of |v2 − v1| (symmetric, so the mean is the midpoint)."""
    return np.asarray((v1 + v2) / 2.0 * _accel_phase(np.abs(v2 - v1), A, J, tj)[3], dtype=float)


def change_reach_mps(
    from_mps: NDArray[np.float64], to_mps: NDArray[np.float64], length_m: NDArray[np.float64],
    accel_mps2: NDArray[np.float64], jerk_mps3: NDArray[np.float64],
    jerk_ramp_s: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The speed (m/s) a jerk-limited change from ``from_mps`` toward ``to_mps`` reaches when
    it is given ``length_m`` metres: ``to_mps`` where the whole change fits, else as far as a
    change of that size starting from the lower of the two speeds fits in ``length_m`` (how
    ArduCopter's ``SCurve::calculate_path`` shortens a speed change, up or down)."""
    v1 = np.asarray(from_mps, dtype=float)
    v2 = np.broadcast_to(np.asarray(to_mps, dtype=float), v1.shape)
    shape = v1.shape
    A, J, tj, L = (np.broadcast_to(np.asarray(x, dtype=float), shape)
                   for x in (accel_mps2, jerk_mps3, jerk_ramp_s, length_m))
    lower = np.minimum(v1, v2)

    def distance(gap: NDArray[np.float64]) -> NDArray[np.float64]:
        return _change_distance(lower, lower + gap, A, J, tj)

    gap = _bisect(distance, np.maximum(L, 0.0), np.zeros(shape), np.abs(v2 - v1))
    return np.asarray(v1 + np.sign(v2 - v1) * gap, dtype=float)


def scurve_peak_speed(
    length_m: NDArray[np.float64] | float,
    speed_mps: NDArray[np.float64] | float,
    accel_mps2: NDArray[np.float64] | float,
    jerk_mps3: NDArray[np.float64] | float,
    jerk_ramp_s: NDArray[np.float64] | float = 0.0,
) -> NDArray[np.float64]:
    """Top speed (m/s) of a rest-to-rest move over ``length_m`` with these limits.

    With instant jerk changes (``jerk_ramp_s`` = 0) accelerating from rest to v takes
    v/A + A/J seconds and v²/(2A) + vA/(2J) metres when v ≥ A²/J, else 2·sqrt(v/J) s and
    v·sqrt(v/J) m; so a move of length L reaches min(V, the v whose rest-to-v-to-rest distance
    is L). With jerk ramps the same holds with the phase lengthened by ``jerk_ramp_s``.
    """
    L = np.atleast_1d(np.asarray(length_m, dtype=float))
    shape = L.shape
    V, A, J, tj = (np.broadcast_to(np.asarray(x, dtype=float), shape).astype(float)
                   for x in (speed_mps, accel_mps2, jerk_mps3, jerk_ramp_s))

    def distance(v: NDArray[np.float64]) -> NDArray[np.float64]:
        return rest_to_rest_m(v, A, J, tj)

    reach = distance(V) <= L
    return np.asarray(np.where(reach, V, _bisect(distance, L, np.zeros(shape), V)), dtype=float)


def scurve_rest_to_rest(
    length_m: NDArray[np.float64],
    speed_mps: NDArray[np.float64],
    accel_mps2: NDArray[np.float64],
    jerk_mps3: NDArray[np.float64],
    jerk_ramp_s: NDArray[np.float64] | float = 0.0,
) -> Profiles1D:
    """Jerk-limited profiles from rest over ``length_m`` back to rest.

    Acceleration phase: jerk ramps up over ``jerk_ramp_s`` (constant snap), holds, ramps down,
    acceleration holds, the mirror image brings it back to 0; then cruise; then the
    deceleration phase mirrors the acceleration phase. With ``jerk_ramp_s`` = 0 this is the
    classic seven-segment profile (jerk +J, accel A, jerk −J, cruise, ...) and a long move
    lasts L/V + V/A + A/J; jerk ramps add ``jerk_ramp_s`` to that.
    """
    return scurve_to_touchdown(length_m, speed_mps, accel_mps2, jerk_mps3, jerk_ramp_s, 0.0, 0.0)


def scurve_to_touchdown(
    length_m: NDArray[np.float64],
    speed_mps: NDArray[np.float64],
    accel_mps2: NDArray[np.float64],
    jerk_mps3: NDArray[np.float64],
    jerk_ramp_s: NDArray[np.float64] | float,
    end_speed_mps: NDArray[np.float64] | float,
    end_run_m: NDArray[np.float64] | float,
    first_speed_mps: NDArray[np.float64] | None = None,
) -> Profiles1D:
    """Jerk-limited moves from rest that end with ``end_run_m`` metres at ``end_speed_mps``.

    ArduCopter's landing: the descent runs at ``speed_mps`` (at least the end speed), slows
    jerk-limited to the end speed as it reaches the end run (LAND_ALT_LOW) and touches down at
    that speed. With no end speed (0) this is :func:`scurve_rest_to_rest`. Same segments as
    that (accelerate, cruise, decelerate) plus the end run.

    ``first_speed_mps`` (per leg, m/s): a leg that first accelerates to that speed and then,
    jerk-limited as its own phase, changes to ``speed_mps`` before it cruises (ArduCopter's
    speed change at a corner flown through, :mod:`validator.motion.arducopter`). Where the two
    phases and the braking do not fit in the leg, or there is an end speed, the leg flies
    rest-to-rest at the first speed.
    """
    L = np.maximum(np.asarray(length_m, dtype=float), 0.0)
    shape = L.shape
    V, A, J, tj, ve, run = (np.broadcast_to(np.asarray(x, dtype=float), shape).astype(float)
                            for x in (speed_mps, accel_mps2, jerk_mps3, jerk_ramp_s,
                                      end_speed_mps, end_run_m))
    ramp_to_ve = ve * _accel_phase(ve, A, J, tj)[3] / 2.0
    ve = np.where(L >= ramp_to_ve, ve, 0.0)  # too short to reach the end speed: stop instead
    run = np.where(ve > 0, np.clip(run, 0.0, L - ramp_to_ve), 0.0)
    V = np.maximum(V, ve)
    v1 = V.copy() if first_speed_mps is None else np.broadcast_to(
        np.asarray(first_speed_mps, dtype=float), shape).astype(float)
    change = _change_distance(v1, V, A, J, tj)
    two = (np.abs(v1 - V) > 1e-9) & (ve <= 0) & (v1 > 0) & (V > 0)
    # accelerate to v1, change to V, brake from V: half of each rest-to-rest move
    fits = two & ((rest_to_rest_m(v1, A, J, tj) + rest_to_rest_m(V, A, J, tj)) / 2.0 + change
                  <= L)
    V = np.where(two & ~fits, v1, V)
    v1 = np.where(fits, v1, V)

    def distance(v: NDArray[np.float64]) -> NDArray[np.float64]:
        up = _accel_phase(v, A, J, tj)[3]
        down = _accel_phase(v - ve, A, J, tj)[3]
        return v * up / 2.0 + (v + ve) * down / 2.0 + run

    lo = _bisect(distance, L, ve.copy(), V.copy())
    v = np.where(L <= 0, 0.0, np.where(fits | (distance(V) <= L), V, lo))
    v1 = np.where(fits, v1, v)
    jm, t2, t4, up = _accel_phase(v1, A, J, tj)
    jc, t2c, t4c, chg = _accel_phase(np.abs(v - v1), A, J, tj)
    jc = np.where(v < v1, -jc, jc)
    jd, t2d, t4d, down = _accel_phase(v - ve, A, J, tj)
    cruise = (L - v1 * up / 2.0 - (v1 + v) * chg / 2.0 - (v + ve) * down / 2.0 - run)
    tc = np.divide(np.maximum(cruise, 0.0), v, out=np.zeros_like(v), where=v > 0)
    t_run = np.divide(run, ve, out=np.zeros_like(ve), where=ve > 0)
    tu = np.where(up > 0, tj, 0.0)  # no move, no jerk ramps: a zero-length leg takes no time
    td = np.where(down > 0, tj, 0.0)
    tcg = np.where(chg > 0, tj, 0.0)
    snap = np.divide(jm, tu, out=np.zeros_like(jm), where=tu > 0)
    snap_d = np.divide(jd, td, out=np.zeros_like(jd), where=td > 0)
    snap_c = np.divide(jc, tcg, out=np.zeros_like(jc), where=tcg > 0)
    z = np.zeros_like(L)
    up_segs = [(tu, z, snap), (t2, jm, z), (tu, jm, -snap)]
    down_segs = [(tu, z, -snap), (t2, -jm, z), (tu, -jm, snap)]
    change_segs = [(tcg, z, snap_c), (t2c, jc, z), (tcg, jc, -snap_c), (t4c, z, z),
                   (tcg, z, -snap_c), (t2c, -jc, z), (tcg, -jc, snap_c)]
    brake = [(td, z, -snap_d), (t2d, -jd, z), (td, -jd, snap_d), (t4d, z, z),
             (td, z, snap_d), (t2d, jd, z), (td, jd, -snap_d)]
    segs = (up_segs + [(t4, z, z)] + down_segs + change_segs + [(tc, z, z)] + brake
            + [(t_run, z, z)])
    dur, jerk0, snaps = (np.stack([seg[i] for seg in segs], axis=1) for i in range(3))
    return Profiles1D(L, np.zeros_like(L), dur, jerk0, snaps)


def constant_speed(length_m: NDArray[np.float64], speed_mps: NDArray[np.float64]) -> Profiles1D:
    """Moves at a constant speed (instant start and stop): the ideal profile."""
    L = np.maximum(np.asarray(length_m, dtype=float), 0.0)
    v = np.asarray(speed_mps, dtype=float)
    dur = np.where(L > 0, L / v, 0.0)[:, None]
    return Profiles1D(L, np.where(L > 0, v, 0.0), dur, np.zeros_like(dur), np.zeros_like(dur))
