"""(P2): transmit power for a fixed schedule, trajectory and slot lengths (paper §III-B).

    max  r_min
    s.t. Σ_n s_k[n] δ[n] log2(1 + ρ p̃[n] / d̃_k[n]²) / T ≥ r_min,
         Σ_n δ[n] p̃[n] / T ≤ 1,   0 ≤ p̃[n] ≤ P_peak / P_avg

in units of P_avg (p̃ = p / P_avg); ρ/d̃² is the normalised channel gain over noise.

:class:`PowerProblem` assembles the conic form for Clarabel directly, a term per (slot, GN
served) with u ≤ ln(1 + g p̃) as (u, 1, 1 + g p̃) ∈ K_exp; :class:`PowerModel` states it in cvxpy
as the readable model and test oracle.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from mission_planner.optimize import conic


def _terms(
    schedule: NDArray[np.float64], delta: NDArray[np.float64], terms: int
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """GN of each of the ``terms`` rate terms per slot (J, N) and its weight s δ̃ / (N ln 2)."""
    n = schedule.shape[1]
    cols = np.arange(n)
    top = np.argsort(-schedule, axis=0, kind="stable")[:terms]
    weight = np.maximum(schedule[top, cols], 0.0) * delta[None, :] / (n * np.log(2.0))
    return top, weight


class PowerProblem:
    """(P2) for K GNs and N slots, assembled for Clarabel; :meth:`solve` re-solves.

    With ``terms`` = 1 only the GN a slot serves gets a rate term (exact for a binary schedule,
    N exponential cones instead of K·N); with ``terms`` = K every GN does.
    """

    def __init__(self, num_gns: int, num_slots: int, terms: int) -> None:
        k, n, j = num_gns, num_slots, terms
        self.shape = (k, n, j)
        # Variables: p̃ (N), u (J, N), r_min.
        self.p = np.arange(n)
        self.u = n + np.arange(j * n).reshape(j, n)
        self.r = n + j * n

    def solve(
        self,
        gain: NDArray[np.float64],
        schedule: NDArray[np.float64],
        delta: NDArray[np.float64],
        peak: float,
    ) -> NDArray[np.float64] | None:
        """Power (N,) in units of P_avg for gains (K, N), or None when the solver fails."""
        k, n, j = self.shape
        top, weight = _terms(schedule, delta, j)
        form = conic.ConicForm(self.r + 1)
        form.c[self.r] = -1.0  # max r_min
        # Σ_n s δ̃ log(1 + g p̃) / (N ln 2) − r_min ≥ 0, a term in its GN's row only.
        form.nonneg(
            np.zeros(k), (self.r, -1.0), entries=(top.ravel(), self.u.ravel(), weight.ravel())
        )
        form.nonneg([1.0], entries=(np.zeros(n, dtype=np.int64), self.p, -delta / n))  # (7)
        form.nonneg(np.full(n, peak), (self.p, -1.0))  # (8)
        form.nonneg(np.zeros(n), (self.p, 1.0))
        # u ≤ ln(1 + g p̃): (u, 1, 1 + g p̃) ∈ K_exp.
        slot_p = np.broadcast_to(self.p, (j, n)).reshape(-1, 1)
        form.exp(
            np.tile([0.0, 1.0, 1.0], (j * n, 1)),
            (self.u.reshape(-1, 1), [1.0, 0.0, 0.0]),
            (slot_p, gain[top, np.arange(n)].reshape(-1, 1) * np.array([0.0, 0.0, 1.0])),
        )
        x = form.solve()
        return None if x is None else np.asarray(np.clip(x[self.p], 0.0, None), dtype=float)


class PowerModel:
    """(P2) in cvxpy for K GNs and N slots, built once: the model and test oracle of
    :class:`PowerProblem`.

    With ``terms`` = 1 only the GN a slot serves gets a rate term (exact for a binary schedule,
    N exponential cones instead of K·N); with ``terms`` = K every GN does.
    """

    def __init__(self, num_gns: int, num_slots: int, terms: int) -> None:
        import cvxpy as cp

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
        top, weight = _terms(schedule, delta, j)
        route = np.zeros((k, j, n))
        route[top, np.arange(j)[:, None], cols[None, :]] = weight
        self.gain.value = gain[top, cols]
        self.weight.value = route.reshape(k, j * n)
        self.delta.value = delta / n
        self.peak.value = peak
        if not conic.solve(self.problem) or self.p.value is None:
            return None
        return np.asarray(np.clip(self.p.value, 0.0, None), dtype=float)


@functools.lru_cache(maxsize=16)
def power_problem(num_gns: int, num_slots: int, terms: int) -> PowerProblem:
    """(P2) for this shape, shared by every site of that shape in the process."""
    return PowerProblem(num_gns, num_slots, terms)
