"""(P2): transmit power for a fixed schedule, trajectory and slot lengths (paper §III-B).

    max  r_min
    s.t. Σ_n s_k[n] δ[n] log2(1 + ρ p̃[n] / d̃_k[n]²) / T ≥ r_min,
         Σ_n δ[n] p̃[n] / T ≤ 1,   0 ≤ p̃[n] ≤ P_peak / P_avg

in units of P_avg (p̃ = p / P_avg); ρ/d̃² is the normalised channel gain over noise.
"""

from __future__ import annotations

import cvxpy as cp
import numpy as np
from numpy.typing import NDArray


class PowerProblem:
    """(P2) for K GNs and N slots, built once; :meth:`solve` re-solves with new values."""

    def __init__(self, num_gns: int, num_slots: int, peak: float) -> None:
        k, n = num_gns, num_slots
        self.p = cp.Variable(n, nonneg=True)
        self.u = cp.Variable((k, n))
        self.r_min = cp.Variable()
        self.gain = cp.Parameter((k, n), nonneg=True)  # ρ / d̃²
        self.weight = cp.Parameter((k, n), nonneg=True)  # s δ̃ / (N ln 2)
        self.delta = cp.Parameter(n, nonneg=True)  # δ̃ / N
        p_rows = np.ones((k, 1)) @ cp.reshape(self.p, (1, n), order="C")
        constraints = [
            self.u <= cp.log(1 + cp.multiply(self.gain, p_rows)),
            cp.sum(cp.multiply(self.weight, self.u), axis=1) >= self.r_min,
            self.delta @ self.p <= 1,
            self.p <= peak,
        ]
        self.problem = cp.Problem(cp.Maximize(self.r_min), constraints)
        assert self.problem.is_dpp()

    def solve(
        self, gain: NDArray[np.float64], schedule: NDArray[np.float64], delta: NDArray[np.float64]
    ) -> NDArray[np.float64] | None:
        """Power (N,) in units of P_avg, or None when the solver fails."""
        n = delta.size
        self.gain.value = gain
        self.weight.value = np.maximum(schedule, 0.0) * delta[None, :] / (n * np.log(2.0))
        self.delta.value = delta / n
        try:
            self.problem.solve(solver=cp.CLARABEL)
        except cp.SolverError:
            return None
        if self.p.value is None or self.problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
            return None
        return np.asarray(np.clip(self.p.value, 0.0, None), dtype=float)
