"""Over-relaxed SCA steps: a line search along each (P3-2) step on the exact objective.

The quadratic transform's surrogate (27) bends down in δ̃ with curvature 2(λ² + μ²)/δ̃³, which
(28), (29) make about 2(log2 SNR + γ1 + γ2)/δ̃, although the exact rate is linear in δ̃: a step
stops short of where the exact objective still rises. With the paper's γ1 = γ2 = 100 a step
moved each slot length by well under 1 % of T/N and Algorithm 1 crept (issue 15); the per-term
shifts (:func:`.trajectory.qt_shifts`) cut that curvature, and this search still adds to them.

Along the step's direction the exact objective usually keeps rising, so after each accepted step
q^r → q̂ the points q^r + α (q̂ − q^r) for α in :data:`STEP_MULTIPLES` are tried in order, each
with its slot lengths made flyable (:func:`flyable_slots`) and power scaled into the budget,
and the best one that raises the exact min rate and meets (P3-2)'s exact constraints
(:func:`feasible`) is kept. Only improvements are kept, so the objective still
rises monotonically and Algorithm 1 converges as before; the extra cost is a few objective
evaluations per iteration, no conic solves.

Measured (paper model, 30 iterations): with the paper's γ, the min rate rose on all 22 plans
of the sample and ten benchmark sites, both schemes, by 0.5 % on average (+0.05 % to +1.6 %);
with the per-term shifts, on 30 random paper-default sites, from +5.5 % to +6.7 % above the
independent reference (``benchmarks/bench_optima.py``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from mission_planner.optimize.scaled import Scaled, min_rate
from mission_planner.optimize.trajectory import MIN_SLOT, separating_lines

# Multiples of the SCA step tried in turn; the search stops at the first that is infeasible or
# no better than the best so far.
STEP_MULTIPLES = (1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0)


def flyable_slots(
    sc: Scaled, q: NDArray[np.float64], delta: NDArray[np.float64]
) -> NDArray[np.float64] | None:
    """Slot lengths close to ``delta`` in which every leg of ``q`` is flown at top speed at most
    (‖q[n] − q[n−1]‖ ≤ Ṽ δ̃[n], in wind in the air frame too, δ̃ ≥ MIN_SLOT, Σ δ̃ = N): the
    short slots are raised to what their leg needs and the time is taken from the others in
    proportion to their spare time. None when the legs need more than N in all."""
    n = sc.num_slots
    prev = np.r_[n - 1, np.arange(n - 1)]
    legs = q - q[prev]
    need = np.maximum(np.linalg.norm(legs, axis=1) / sc.leg_speed(legs), MIN_SLOT)
    if not np.all(np.isfinite(need)):
        return None
    if float(np.sum(need)) >= n:
        return None
    d = np.maximum(delta, need)
    # Each pass removes the excess from the spare time; slots that hit their need drop out.
    for _ in range(n):
        excess = float(np.sum(d)) - n
        if excess <= 0.0:
            break
        spare = d - need
        d = np.maximum(d - excess * spare / float(np.sum(spare)), need)
    return np.asarray(d * (n / np.sum(d)), dtype=float)


def feasible(
    sc: Scaled,
    q: NDArray[np.float64],
    delta: NDArray[np.float64],
    power: NDArray[np.float64],
    scheme: str,
) -> bool:
    """Whether (q, δ̃, p̃) meets (P3-2)'s constraints in their exact, not linearised, form:
    Σ δ̃ = N, δ̃ ≥ MIN_SLOT, ‖q[n] − q[n−1]‖ ≤ Ṽ δ̃[n] (1) and Σ δ̃ p̃ / N ≤ 1 (7), each to a
    relative 1e-7 (the solver's tolerance), and the ``scheme``'s zone rule exactly ((6-1) at
    both ends of each leg, (5), or the separating lines).

    SCA iterates meet them (each linearised row is tighter than the exact one), and a point
    that meets them keeps the next SCA subproblem feasible: its rows are exact there.
    """
    n = sc.num_slots
    prev = np.r_[n - 1, np.arange(n - 1)]
    tol = 1e-7
    if abs(float(np.sum(delta)) - n) > tol * n or np.any(delta < MIN_SLOT):
        return False
    if np.any(np.linalg.norm(q - q[prev], axis=1) > sc.speed * delta * (1.0 + tol)):
        return False
    if np.any(sc.air_excess(q - q[prev], delta) > tol * sc.speed * delta):
        return False
    if float(delta @ power) / n > 1.0 + tol:
        return False
    if sc.num_nfzs and scheme in ("proposed", "conventional"):
        dist_sq = np.sum((q[None, :, :] - sc.nfz[:, None, :]) ** 2, axis=-1)  # (M, N)
        need = (sc.radius**2)[:, None]  # (M, 1), or (M, N) below
        if scheme == "proposed":  # (6-1) at q[n] and q[n−1] with leg n's length Ṽ δ̃[n]
            need = need + ((sc.speed * delta / 2) ** 2)[None, :]
            if np.any(dist_sq[:, prev] < need):
                return False
        if np.any(dist_sq < need):
            return False
    _, _, slack = separating_lines(sc, q, scheme)
    return not np.any(slack < 0.0)


def overrelax(
    sc: Scaled,
    scheme: str,
    start: tuple[NDArray[np.float64], NDArray[np.float64]],
    step: tuple[NDArray[np.float64], NDArray[np.float64]],
    power: NDArray[np.float64],
    s: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The best of the accepted SCA ``step`` (q̂, δ̂) from ``start`` (q^r, δ^r) and its
    over-relaxations (module docstring) for schedule ``s`` and power ``power``: (q, δ̃, p̃)."""
    (q0, d0), (q1, d1) = start, step
    best = (min_rate(sc, q1, d1, power, s), q1, d1, power)
    for alpha in STEP_MULTIPLES:
        q = q0 + alpha * (q1 - q0)
        d = flyable_slots(sc, q, d0 + alpha * (d1 - d0))
        if d is None:
            break
        p = power / max(1.0, float(d @ power) / sc.num_slots)  # within (7) again
        if not feasible(sc, q, d, p, scheme):
            break
        rate = min_rate(sc, q, d, p, s)
        if rate <= best[0]:
            break
        best = (rate, q, d, p)
    return best[1], best[2], best[3]
