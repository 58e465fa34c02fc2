"""(P3-2): trajectory and slot lengths by SCA and the quadratic transform (paper §III-C).

For fixed schedule s and power p, around the current point (q^r, δ^r):

    max  r_min
    s.t. Σ_n s_k[n] f_k[n] / N ≥ r_min                                      (30)
         f_k[n] = 2λ √(log2(Ã + ρp̃) + γ1) − λ²/δ̃ + 2μ √(log2 B̃ + γ2) − μ²/δ̃ − δ̃(γ1 + γ2)   (27)
         Ã = 2(q^r − w)ᵀ(q − q^r) + ‖q^r − w‖² + H̃²                          (22)
         B̃ = (2D − H̃² − ‖q − w‖²) / D²,   D = ‖q^r − w‖² + H̃²                  (23)
         ‖q[n] − q[n−1]‖ ≤ Ṽ δ̃[n],  Σ δ̃ = N,  δ̃ > 0,  q[0] = q[N]             (1)–(4)
         Σ δ̃ p̃ / N ≤ 1                                                       (7)
         proposed:     G_m(q[n]) ≥ R̃² + (Ṽδ̃[n]/2)²  and  G_m(q[n−1]) ≥ R̃² + (Ṽδ̃[n]/2)²   (6-1)
         conventional: G_m(q[n]) ≥ R̃²                                                   (5)
         G_m(q) = 2(q^r − c_m)ᵀ(q − q^r) + ‖q^r − c_m‖²                       (21)

The average-power constraint (7) contains δ, which this block moves, so it is kept here although
the paper's list for (P3-2) omits it. λ, μ are set in closed form ((28), (29)) before each solve.
Positions q̃[1..N] are the variable; q̃[0] is q̃[N] (closed cycle). Units: see :mod:`.scaled`.
"""

from __future__ import annotations

from dataclasses import dataclass

import cvxpy as cp
import numpy as np
from numpy.typing import NDArray

from mission_planner.optimize.scaled import Scaled, distance_sq

LN2 = float(np.log(2.0))
MIN_SLOT = 1e-2  # smallest δ̃ (fraction of T/N): δ[n] > 0 (1)


@dataclass(frozen=True)
class TrajectoryStep:
    q: NDArray[np.float64]  # (N, 2) positions of slots 1..N
    delta: NDArray[np.float64]  # (N,)


def _rows(x: cp.Expression, k: int, n: int) -> cp.Expression:
    """Broadcast an (N,) expression into (K, N)."""
    return np.ones((k, 1)) @ cp.reshape(x, (1, n), order="C")


class TrajectoryProblem:
    """(P3-2) built once for a scheme; :meth:`solve` re-solves around a new point."""

    def __init__(self, sc: Scaled, scheme: str) -> None:
        k, n, m = sc.num_gns, sc.num_slots, sc.num_nfzs
        self.sc = sc
        self.scheme = scheme
        prev = np.r_[n - 1, np.arange(n - 1)]
        self.q = cp.Variable((n, 2))
        self.delta = cp.Variable(n)
        self.inv_delta = cp.Variable(n)
        self.r_min = cp.Variable()
        t1 = cp.Variable((k, n), nonneg=True)
        t2 = cp.Variable((k, n), nonneg=True)

        # SCA point q^r enters through these (K, N) coefficient parameters.
        self.ax = cp.Parameter((k, n))  # 2 (q^r − w)_x
        self.ay = cp.Parameter((k, n))
        self.a0 = cp.Parameter((k, n))  # constant part of Ã + ρ p̃
        self.b0 = cp.Parameter((k, n), nonneg=True)  # 2D − H̃²
        self.bshift = cp.Parameter((k, n))  # γ2 − 2 log2 D
        # QT weights, already multiplied by s / N.
        self.w_lambda = cp.Parameter((k, n), nonneg=True)  # 2 s λ / N
        self.w_mu = cp.Parameter((k, n), nonneg=True)  # 2 s μ / N
        self.w_inv = cp.Parameter((k, n), nonneg=True)  # s (λ² + μ²) / N
        self.w_lin = cp.Parameter((k, n), nonneg=True)  # s (γ1 + γ2) / N
        self.power = cp.Parameter(n, nonneg=True)  # p̃ / N

        qx = _rows(self.q[:, 0], k, n)
        qy = _rows(self.q[:, 1], k, n)
        a_lb = cp.multiply(self.ax, qx) + cp.multiply(self.ay, qy) + self.a0
        dist2 = cp.reshape(
            cp.hstack([cp.sum(cp.square(self.q - sc.gn[j]), axis=1) for j in range(k)]),
            (k, n),
            order="C",
        )
        f_sum = (
            cp.sum(cp.multiply(self.w_lambda, t1), axis=1)
            + cp.sum(cp.multiply(self.w_mu, t2), axis=1)
            - self.w_inv @ self.inv_delta
            - self.w_lin @ self.delta
        )
        constraints = [
            t1 <= cp.sqrt(cp.log(a_lb) / LN2 + sc.gamma1),
            t2 <= cp.sqrt(cp.log(self.b0 - dist2) / LN2 + self.bshift),
            self.inv_delta >= cp.inv_pos(self.delta),
            f_sum >= self.r_min,
            cp.SOC(sc.speed * self.delta, (self.q - self.q[prev]).T, axis=0),
            cp.sum(self.delta) == n,
            self.delta >= MIN_SLOT,
            self.power @ self.delta <= 1,
        ]
        if m:
            self.gx = cp.Parameter((m, n))  # 2 (q^r − c)_x
            self.gy = cp.Parameter((m, n))
            self.g0 = cp.Parameter((m, n))  # ‖c‖² − ‖q^r‖²
            mx = np.ones((m, 1)) @ cp.reshape(self.q[:, 0], (1, n), order="C")
            my = np.ones((m, 1)) @ cp.reshape(self.q[:, 1], (1, n), order="C")
            g_lb = cp.multiply(self.gx, mx) + cp.multiply(self.gy, my) + self.g0
            r2 = (sc.radius**2)[:, None] * np.ones((1, n))
            if scheme == "proposed":
                half_leg2 = _rows(cp.square(self.delta), m, n) * (sc.speed / 2) ** 2
                constraints += [g_lb >= r2 + half_leg2, g_lb[:, prev] >= r2 + half_leg2]
            else:
                constraints += [g_lb >= r2]
        self.problem = cp.Problem(cp.Maximize(self.r_min), constraints)
        assert self.problem.is_dpp()

    def solve(
        self,
        q: NDArray[np.float64],
        delta: NDArray[np.float64],
        power: NDArray[np.float64],
        s: NDArray[np.float64],
    ) -> TrajectoryStep | None:
        """One SCA step from (q, δ) for schedule s (K, N) and power p̃ (N,); None on failure."""
        sc = self.sc
        n = sc.num_slots
        diff = q[None, :, :] - sc.gn[:, None, :]  # (K, N, 2) q^r − w
        d2 = distance_sq(sc, q)  # D
        self.ax.value = 2 * diff[..., 0]
        self.ay.value = 2 * diff[..., 1]
        self.a0.value = d2 - 2 * np.sum(diff * q[None, :, :], axis=-1) + sc.rho * power[None, :]
        self.b0.value = 2 * d2 - sc.height**2
        self.bshift.value = sc.gamma2 - 2 * np.log2(d2)
        # (28), (29): λ = δ √(log2(Ã + ρp̃) + γ1), μ = δ √(log2 B̃ + γ2) at q = q^r.
        lam = delta[None, :] * np.sqrt(np.log2(d2 + sc.rho * power[None, :]) + sc.gamma1)
        mu = delta[None, :] * np.sqrt(np.log2(1.0 / d2) + sc.gamma2)
        self.w_lambda.value = 2 * s * lam / n
        self.w_mu.value = 2 * s * mu / n
        self.w_inv.value = s * (lam**2 + mu**2) / n
        self.w_lin.value = s * (sc.gamma1 + sc.gamma2) / n
        self.power.value = power / n
        if sc.num_nfzs:
            cdiff = q[None, :, :] - sc.nfz[:, None, :]  # (M, N, 2)
            self.gx.value = 2 * cdiff[..., 0]
            self.gy.value = 2 * cdiff[..., 1]
            self.g0.value = np.sum(sc.nfz**2, axis=1)[:, None] - np.sum(q**2, axis=1)[None, :]
        try:
            self.problem.solve(solver=cp.CLARABEL)
        except cp.SolverError:
            return None
        if self.q.value is None or self.problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
            return None
        return TrajectoryStep(
            np.asarray(self.q.value, dtype=float), np.asarray(self.delta.value, dtype=float)
        )
