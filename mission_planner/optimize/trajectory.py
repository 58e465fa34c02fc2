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

Size: only the ``terms`` GNs with the largest s_k[n] get a rate term in slot n. With a binary
schedule one term is exact and 20-40 % faster; while the schedule is relaxed, two terms (see
:data:`RELAXED_TERMS`) keep the surrogate tight at the current point, as SCA needs (with one,
a quarter of the steps on the benchmark sites lowered the objective and were thrown away);
the terms dropped are non-negative rates, so it stays a lower bound. Everything that
depends on the site enters through parameters, so one compiled problem serves every site of
the same shape (N, K, M, scheme) — see :func:`trajectory_problem`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import cvxpy as cp
import numpy as np
from numpy.typing import NDArray

from mission_planner.optimize import conic
from mission_planner.optimize.scaled import Scaled

LN2 = float(np.log(2.0))
TRUST_REGION = 1.0  # largest move of a waypoint per SCA step, per axis, in 100 m
MIN_SLOT = 1e-2  # smallest δ̃ (fraction of T/N): δ[n] > 0 (1)
RELAXED_TERMS = 2  # rate terms per slot while the schedule is fractional (1 once binary)


@dataclass(frozen=True)
class TrajectoryStep:
    q: NDArray[np.float64]  # (N, 2) positions of slots 1..N
    delta: NDArray[np.float64]  # (N,)


def _rows(x: cp.Expression, rows: int, n: int) -> cp.Expression:
    """Broadcast an (N,) expression into (rows, N)."""
    return np.ones((rows, 1)) @ cp.reshape(x, (1, n), order="C")


class TrajectoryProblem:
    """(P3-2) built once for a shape; :meth:`solve` re-solves around a new point of any site."""

    def __init__(
        self, num_slots: int, num_gns: int, num_nfzs: int, scheme: str, terms: int = 1
    ) -> None:
        n, k, m = num_slots, num_gns, num_nfzs
        j = min(k, terms)
        self.shape = (n, k, m, j)
        prev = np.r_[n - 1, np.arange(n - 1)]
        self.q = cp.Variable((n, 2))
        self.delta = cp.Variable(n)
        self.inv_delta = cp.Variable(n)
        self.r_min = cp.Variable()
        t1 = cp.Variable((j, n), nonneg=True)
        t2 = cp.Variable((j, n), nonneg=True)

        # Site constants.
        self.speed = cp.Parameter(nonneg=True)  # Ṽ
        self.gamma1 = cp.Parameter(nonneg=True)
        # Term (j, n) serves GN k(j, n); the SCA point q^r and that GN enter through these.
        self.ax = cp.Parameter((j, n))  # 2 (q^r − w)_x
        self.ay = cp.Parameter((j, n))
        self.a0 = cp.Parameter((j, n))  # constant part of Ã + ρ p̃
        self.bx = cp.Parameter((j, n))  # 2 w_x
        self.by = cp.Parameter((j, n))
        self.b0 = cp.Parameter((j, n))  # 2D − H̃² − ‖w‖²
        self.bshift = cp.Parameter((j, n))  # γ2 − 2 log2 D
        # QT weights, already multiplied by s / N and routed to their GN's row.
        self.w_lambda = cp.Parameter((k, j * n), nonneg=True)  # 2 s λ / N
        self.w_mu = cp.Parameter((k, j * n), nonneg=True)  # 2 s μ / N
        self.w_inv = cp.Parameter((k, n), nonneg=True)  # Σ s (λ² + μ²) / N
        self.w_lin = cp.Parameter((k, n), nonneg=True)  # Σ s (γ1 + γ2) / N
        self.power = cp.Parameter(n, nonneg=True)  # p̃ / N
        self.q_ref = cp.Parameter((n, 2))  # q^r

        qx = _rows(self.q[:, 0], j, n)
        qy = _rows(self.q[:, 1], j, n)
        a_lb = cp.multiply(self.ax, qx) + cp.multiply(self.ay, qy) + self.a0
        q_sq = _rows(cp.sum(cp.square(self.q), axis=1), j, n)
        b_arg = cp.multiply(self.bx, qx) + cp.multiply(self.by, qy) + self.b0 - q_sq
        f_sum = (
            self.w_lambda @ cp.reshape(t1, (j * n,), order="C")
            + self.w_mu @ cp.reshape(t2, (j * n,), order="C")
            - self.w_inv @ self.inv_delta
            - self.w_lin @ self.delta
        )
        constraints = [
            t1 <= cp.sqrt(cp.log(a_lb) / LN2 + self.gamma1),
            t2 <= cp.sqrt(cp.log(b_arg) / LN2 + self.bshift),
            self.inv_delta >= cp.inv_pos(self.delta),
            f_sum >= self.r_min,
            cp.SOC(self.speed * self.delta, (self.q - self.q[prev]).T, axis=0),
            cp.sum(self.delta) == n,
            self.delta >= MIN_SLOT,
            self.power @ self.delta <= 1,
            # A trust region: the bounds are global, but without it the conic solver stalls on
            # steps of several hundred metres that the surrogate barely distinguishes.
            cp.abs(self.q - self.q_ref) <= TRUST_REGION,
        ]
        if m:
            self.gx = cp.Parameter((m, n))  # 2 (q^r − c)_x
            self.gy = cp.Parameter((m, n))
            self.g0 = cp.Parameter((m, n))  # ‖c‖² − ‖q^r‖² − R̃²
            mx = _rows(self.q[:, 0], m, n)
            my = _rows(self.q[:, 1], m, n)
            g_lb = cp.multiply(self.gx, mx) + cp.multiply(self.gy, my) + self.g0
            if scheme == "proposed":
                self.half_speed_sq = cp.Parameter(nonneg=True)  # (Ṽ/2)²
                half_leg2 = self.half_speed_sq * _rows(cp.square(self.delta), m, n)
                constraints += [g_lb >= half_leg2, g_lb[:, prev] >= half_leg2]
            else:
                constraints += [g_lb >= 0]
        self.scheme = scheme
        self.problem = cp.Problem(cp.Maximize(self.r_min), constraints)
        assert self.problem.is_dpp()

    def solve(
        self,
        sc: Scaled,
        q: NDArray[np.float64],
        delta: NDArray[np.float64],
        power: NDArray[np.float64],
        s: NDArray[np.float64],
    ) -> TrajectoryStep | None:
        """One SCA step from (q, δ) for schedule s (K, N) and power p̃ (N,); None on failure."""
        n, k, m, j = self.shape
        cols = np.arange(n)
        top = np.argsort(-s, axis=0, kind="stable")[:j]  # (J, N) GN of each term
        w = sc.gn[top]  # (J, N, 2)
        s_top = s[top, cols]  # (J, N)
        diff = q[None, :, :] - w  # q^r − w
        d2 = np.sum(diff * diff, axis=-1) + sc.height**2  # D
        self.speed.value = sc.speed
        self.gamma1.value = sc.gamma1
        self.ax.value = 2 * diff[..., 0]
        self.ay.value = 2 * diff[..., 1]
        self.a0.value = d2 - 2 * np.sum(diff * q[None], axis=-1) + sc.rho * power[None, :]
        self.bx.value = 2 * w[..., 0]
        self.by.value = 2 * w[..., 1]
        self.b0.value = 2 * d2 - sc.height**2 - np.sum(w * w, axis=-1)
        self.bshift.value = sc.gamma2 - 2 * np.log2(d2)
        # (28), (29): λ = δ √(log2(Ã + ρp̃) + γ1), μ = δ √(log2 B̃ + γ2) at q = q^r.
        lam = delta[None, :] * np.sqrt(np.log2(d2 + sc.rho * power[None, :]) + sc.gamma1)
        mu = delta[None, :] * np.sqrt(np.log2(1.0 / d2) + sc.gamma2)
        route = np.zeros((k, j, n))
        route[top, np.arange(j)[:, None], cols[None, :]] = s_top / n
        self.w_lambda.value = (2 * route * lam[None]).reshape(k, j * n)
        self.w_mu.value = (2 * route * mu[None]).reshape(k, j * n)
        self.w_inv.value = np.sum(route * (lam**2 + mu**2)[None], axis=1)
        self.w_lin.value = np.sum(route, axis=1) * (sc.gamma1 + sc.gamma2)
        self.power.value = power / n
        self.q_ref.value = q
        if m:
            cdiff = q[None, :, :] - sc.nfz[:, None, :]  # (M, N, 2)
            self.gx.value = 2 * cdiff[..., 0]
            self.gy.value = 2 * cdiff[..., 1]
            self.g0.value = (
                np.sum(sc.nfz**2, axis=1)[:, None]
                - np.sum(q**2, axis=1)[None, :]
                - (sc.radius**2)[:, None]
            )
            if self.scheme == "proposed":
                self.half_speed_sq.value = (sc.speed / 2) ** 2
        if not conic.solve(self.problem) or self.q.value is None:
            return None
        return TrajectoryStep(
            np.asarray(self.q.value, dtype=float), np.asarray(self.delta.value, dtype=float)
        )


@functools.lru_cache(maxsize=16)
def trajectory_problem(
    num_slots: int, num_gns: int, num_nfzs: int, scheme: str, terms: int = 1
) -> TrajectoryProblem:
    """The compiled (P3-2) for this shape, shared by every site of that shape in the process.

    cvxpy compiles a DPP problem once (about a second here); later solves only refill parameters.
    """
    return TrajectoryProblem(num_slots, num_gns, num_nfzs, scheme, terms)
