"""(P2): transmit power for a fixed schedule, trajectory and slot lengths (paper §III-B).

    max  r_min
    s.t. Σ_n s_k[n] δ[n] log2(1 + ρ p̃[n] / d̃_k[n]²) / T ≥ r_min,
         Σ_n δ[n] p̃[n] / T ≤ 1,   0 ≤ p̃[n] ≤ P_peak / P_avg

in units of P_avg (p̃ = p / P_avg); ρ/d̃² is the normalised channel gain over noise.
"""

from __future__ import annotations

import functools

import cvxpy as cp
import numpy as np
from numpy.typing import NDArray

from mission_planner.optimize import conic


class PowerProblem:
    """(P2) for K GNs and N slots, built once; :meth:`solve` re-solves with new values.

    With ``terms`` = 1 only the GN a slot serves gets a rate term (exact for a binary schedule,
    N exponential cones instead of K·N); with ``terms`` = K every GN does.
    """

    def __init__(self, num_gns: int, num_slots: int, terms: int) -> None:
        k, n, j = num_gns, num_slots, terms
        self.shape = (k, n, j)
        self.p = cp.Variable(n, nonneg=True)
        self.u = cp.Variable((j, n))
        self.r_min = cp.Variable()
        self.gain = cp.Parameter((j, n), nonneg=True)  # ρ / d̃² of the GN of each term
        self.weight = cp.Parameter((k, j * n), nonneg=True)  # s δ̃ / (N ln 2), routed to its GN
        self.delta = cp.Parameter(n, nonneg=True)  # δ̃ / N
        self.peak = cp.Parameter(nonneg=True)  # P_peak / P_avg
        p_rows = np.ones((j, 1)) @ cp.reshape(self.p, (1, n), order="C")
        constraints = [
            self.u <= cp.log(1 + cp.multiply(self.gain, p_rows)),
            self.weight @ cp.reshape(self.u, (j * n,), order="C") >= self.r_min,
            self.delta @ self.p <= 1,
            self.p <= self.peak,
        ]
        self.problem = cp.Problem(cp.Maximize(self.r_min), constraints)
        assert self.problem.is_dpp()

    def solve(
        self,
        gain: NDArray[np.float64],
        schedule: NDArray[np.float64],
        delta: NDArray[np.float64],
        peak: float,
    ) -> NDArray[np.float64] | None:
        """Power (N,) in units of P_avg for gains (K, N), or None when the solver fails."""
        k, n, j = self.shape
        cols = np.arange(n)
        top = np.argsort(-schedule, axis=0, kind="stable")[:j]  # (J, N) GN of each term
        route = np.zeros((k, j, n))
        route[top, np.arange(j)[:, None], cols[None, :]] = (
            np.maximum(schedule[top, cols], 0.0) * delta[None, :] / (n * np.log(2.0))
        )
        self.gain.value = gain[top, cols]
        self.weight.value = route.reshape(k, j * n)
        self.delta.value = delta / n
        self.peak.value = peak
        if not conic.solve(self.problem) or self.p.value is None:
            return None
        return np.asarray(np.clip(self.p.value, 0.0, None), dtype=float)


@functools.lru_cache(maxsize=16)
def power_problem(num_gns: int, num_slots: int, terms: int) -> PowerProblem:
    """The compiled (P2) for this shape, shared by every site of that shape in the process."""
    return PowerProblem(num_gns, num_slots, terms)
