"""(P1-2): relaxed scheduling with the penalty convex-concave procedure (paper §III-A).

    max  r_min − η_w Σ φ_k[n]
    s.t. Σ_k s_k[n] ≤ 1,  0 ≤ s ≤ 1,  Σ_n s_k[n] R_k[n] ≥ r_min,
         s (1 − 2 s^r) + (s^r)² ≤ φ,  φ ≥ 0

R_k[n] = δ[n] log2(1 + h_k[n] p[n] / σ²) / T are the exact rate terms at the current point.
The paper's penalty weight is η; the default weighs it against T·r_min, i.e. η_w = η / T,
because a rate in bps/Hz is too small for η¹ = 1 to leave the schedule free to move.

:class:`SchedulingProblem` assembles this linear program for Clarabel directly;
:class:`SchedulingModel` states it in cvxpy as the readable model and test oracle.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from mission_planner.optimize import conic


class SchedulingProblem:
    """(P1-2) for K GNs and N slots, assembled for Clarabel; :meth:`solve` re-solves."""

    def __init__(self, num_gns: int, num_slots: int) -> None:
        k, n = num_gns, num_slots
        self.shape = (k, n)
        # Variables: s (K, N), φ (K, N), r_min.
        self.s = np.arange(k * n).reshape(k, n)
        self.phi = k * n + self.s
        self.r = 2 * k * n

    def solve(
        self, rates: NDArray[np.float64], s_prev: NDArray[np.float64], eta_weight: float
    ) -> NDArray[np.float64] | None:
        """New relaxed schedule (K, N), or None when the solver fails."""
        k, n = self.shape
        form = conic.ConicForm(self.r + 1)
        form.c[self.r] = -1.0  # max r_min − η Σ φ
        form.c[self.phi.ravel()] = eta_weight
        slot_rows = np.broadcast_to(np.arange(n), (k, n)).ravel()
        form.nonneg(np.ones(n), entries=(slot_rows, self.s.ravel(), -np.ones(k * n)))  # Σ_k s ≤ 1
        form.nonneg(np.ones((k, n)), (self.s, -1.0))  # s ≤ 1
        form.nonneg(np.zeros((k, n)), (self.s, 1.0))
        form.nonneg(np.zeros((k, n)), (self.phi, 1.0))
        gn_rows = np.broadcast_to(np.arange(k)[:, None], (k, n)).ravel()
        form.nonneg(  # Σ_n R s − r_min ≥ 0
            np.zeros(k),
            (self.r, -1.0),
            entries=(gn_rows, self.s.ravel(), np.maximum(rates, 0.0).ravel()),
        )
        # φ ≥ s (1 − 2 s^r) + (s^r)²: the concave penalty linearised at s^r.
        form.nonneg(-(s_prev**2), (self.phi, 1.0), (self.s, -(1.0 - 2.0 * s_prev)))
        x = form.solve()
        return None if x is None else np.asarray(np.clip(x[self.s], 0.0, 1.0), dtype=float)


class SchedulingModel:
    """(P1-2) in cvxpy for K GNs and N slots: the model and test oracle of
    :class:`SchedulingProblem`."""

    def __init__(self, num_gns: int, num_slots: int) -> None:
        import cvxpy as cp

        k, n = num_gns, num_slots
        self.s = cp.Variable((k, n), nonneg=True)
        self.phi = cp.Variable((k, n), nonneg=True)
        self.r_min = cp.Variable()
        self.rates = cp.Parameter((k, n), nonneg=True)
        self.lin = cp.Parameter((k, n))  # 1 − 2 s^r
        self.const = cp.Parameter((k, n), nonneg=True)  # (s^r)²
        self.eta = cp.Parameter(nonneg=True)
        constraints = [
            cp.sum(self.s, axis=0) <= 1,
            self.s <= 1,
            cp.sum(cp.multiply(self.rates, self.s), axis=1) >= self.r_min,
            cp.multiply(self.s, self.lin) + self.const <= self.phi,
        ]
        objective = cp.Maximize(self.r_min - self.eta * cp.sum(self.phi))
        self.problem = cp.Problem(objective, constraints)
        assert self.problem.is_dpp()

    def solve(
        self, rates: NDArray[np.float64], s_prev: NDArray[np.float64], eta_weight: float
    ) -> NDArray[np.float64] | None:
        """New relaxed schedule (K, N), or None when the solver fails."""
        self.rates.value = np.maximum(rates, 0.0)
        self.lin.value = 1.0 - 2.0 * s_prev
        self.const.value = s_prev**2
        self.eta.value = eta_weight
        if not conic.solve(self.problem) or self.s.value is None:
            return None
        return np.asarray(np.clip(self.s.value, 0.0, 1.0), dtype=float)


@functools.lru_cache(maxsize=16)
def scheduling_problem(num_gns: int, num_slots: int) -> SchedulingProblem:
    """(P1-2) for this shape, shared by every site of that shape in the process."""
    return SchedulingProblem(num_gns, num_slots)
