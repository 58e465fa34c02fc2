"""(P3-2) stated in cvxpy: the readable model of :mod:`.trajectory`'s conic form, and its test
oracle (``tests/mission_planner/test_conic_forms.py``). The planner never imports it (nor cvxpy).
"""

from __future__ import annotations

import cvxpy as cp
import numpy as np
from numpy.typing import NDArray

from mission_planner.optimize import conic
from mission_planner.optimize.scaled import Scaled
from mission_planner.optimize.trajectory import (
    LN2,
    MIN_SLOT,
    TRUST_REGION,
    TrajectoryStep,
    sca_point,
)


class TrajectoryModel:
    """(P3-2) in cvxpy (DPP, built once for a shape): the readable model and the test oracle of
    :class:`~.trajectory.TrajectoryProblem`. Dense parameter blocks make its compiled form grow with
    products of N, K and M (6.6 GB at N = 200, K = 10, M = 10), so the planner does not use it.
    """

    def __init__(
        self, num_slots: int, num_gns: int, num_nfzs: int, scheme: str, terms: int = 1,
        num_parts: int = 0, wind: bool = False,
    ) -> None:
        def rows(x: cp.Expression, count: int) -> cp.Expression:
            """Broadcast an (N,) expression into (count, N)."""
            return np.ones((count, 1)) @ cp.reshape(x, (1, n), order="C")

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
        u1 = cp.Variable((j, n))
        u2 = cp.Variable((j, n))

        # Site constants.
        self.speed = cp.Parameter(nonneg=True)  # Ṽ
        # Term (j, n) serves GN k(j, n); the SCA point q^r and that GN enter through these.
        self.ax = cp.Parameter((j, n))  # 2 (q^r − w)_x
        self.ay = cp.Parameter((j, n))
        self.a0 = cp.Parameter((j, n))  # constant part of Ã + ρ p̃
        self.a_ref = cp.Parameter((j, n), nonneg=True)  # Ã + ρ p̃ at q^r
        self.bx = cp.Parameter((j, n))  # 2 w_x
        self.by = cp.Parameter((j, n))
        self.b0 = cp.Parameter((j, n))  # 2D − H̃² − ‖w‖²
        self.b_ref = cp.Parameter((j, n), nonneg=True)  # D²B̃ at q^r, which is D
        self.ashift = cp.Parameter((j, n))  # γ1 + (ln Ã⁰ + 1) / ln 2
        self.bshift = cp.Parameter((j, n))  # γ2 − 2 log2 D + (ln D + 1) / ln 2
        # QT weights, already multiplied by s / N and routed to their GN's row.
        self.w_lambda = cp.Parameter((k, j * n), nonneg=True)  # 2 s λ / N
        self.w_mu = cp.Parameter((k, j * n), nonneg=True)  # 2 s μ / N
        self.w_inv = cp.Parameter((k, n), nonneg=True)  # Σ s (λ² + μ²) / N
        self.w_lin = cp.Parameter((k, n))  # Σ s (γ1 + γ2) / N (per-term shifts: either sign)
        self.power = cp.Parameter(n, nonneg=True)  # p̃ / N
        self.q_ref = cp.Parameter((n, 2))  # q^r

        qx = rows(self.q[:, 0], j)
        qy = rows(self.q[:, 1], j)
        a_lb = cp.multiply(self.ax, qx) + cp.multiply(self.ay, qy) + self.a0
        q_sq = rows(cp.sum(cp.square(self.q), axis=1), j)
        b_arg = cp.multiply(self.bx, qx) + cp.multiply(self.by, qy) + self.b0 - q_sq
        f_sum = (
            self.w_lambda @ cp.reshape(t1, (j * n,), order="C")
            + self.w_mu @ cp.reshape(t2, (j * n,), order="C")
            - self.w_inv @ self.inv_delta
            - self.w_lin @ self.delta
        )
        constraints = [
            # ln z ≥ ln z⁰ + 1 − z⁰ u with u ≥ 1/z; the constant part is in the shifts.
            u1 >= cp.inv_pos(a_lb),
            u2 >= cp.inv_pos(b_arg),
            t1 <= cp.sqrt(self.ashift - cp.multiply(self.a_ref, u1) / LN2),
            t2 <= cp.sqrt(self.bshift - cp.multiply(self.b_ref, u2) / LN2),
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
        self.wind = cp.Parameter(2) if wind else None  # w̃, the air's move per unit slot
        if self.wind is not None:  # the top speed holds in the air frame
            air_move = cp.reshape(self.delta, (n, 1), order="C") @ cp.reshape(
                self.wind, (1, 2), order="C")
            constraints.append(cp.SOC(self.speed * self.delta,
                                      (self.q - self.q[prev] - air_move).T, axis=0))
        if m:
            self.gx = cp.Parameter((m, n))  # 2 (q^r − c)_x
            self.gy = cp.Parameter((m, n))
            self.g0 = cp.Parameter((m, n))  # ‖c‖² − ‖q^r‖² − R̃²
            mx = rows(self.q[:, 0], m)
            my = rows(self.q[:, 1], m)
            g_lb = cp.multiply(self.gx, mx) + cp.multiply(self.gy, my) + self.g0
            if scheme == "proposed":
                self.half_speed_sq = cp.Parameter(nonneg=True)  # (Ṽ/2)²
                half_leg2 = self.half_speed_sq * rows(cp.square(self.delta), m)
                constraints += [g_lb >= half_leg2, g_lb[:, prev] >= half_leg2]
            elif scheme == "conventional":
                constraints += [g_lb >= 0]
        num_lines = num_parts + (m if scheme == "tangent" else 0)
        self.num_lines = num_lines
        if num_lines:
            self.ux = cp.Parameter((num_lines, n))  # separating line u·q ≥ h per obstacle, leg
            self.uy = cp.Parameter((num_lines, n))
            self.h = cp.Parameter((num_lines, n))
            ox = rows(self.q[:, 0], num_lines)
            oy = rows(self.q[:, 1], num_lines)
            ends = [np.arange(n)] if scheme == "conventional" else [np.arange(n), prev]
            constraints += [
                cp.multiply(self.ux, ox[:, e]) + cp.multiply(self.uy, oy[:, e]) >= self.h
                for e in ends
            ]
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
        pt = sca_point(sc, q, delta, power, s, j, self.scheme)
        cols = np.arange(n)
        route = np.zeros((k, j, n))  # term (j, n) to its GN's row
        route[pt.top, np.arange(j)[:, None], cols[None, :]] = 1.0
        self.speed.value = sc.speed
        if self.wind is not None:
            self.wind.value = np.zeros(2) if sc.wind is None else sc.wind
        for name in ("ax", "ay", "a0", "a_ref", "bx", "by", "b0", "b_ref", "ashift", "bshift"):
            getattr(self, name).value = getattr(pt, name)
        self.w_lambda.value = (route * pt.w_lambda[None]).reshape(k, j * n)
        self.w_mu.value = (route * pt.w_mu[None]).reshape(k, j * n)
        self.w_inv.value = np.sum(route * pt.w_inv[None], axis=1)
        self.w_lin.value = np.sum(route * pt.w_lin[None], axis=1)
        self.power.value = power / n
        self.q_ref.value = q
        if m:
            self.gx.value, self.gy.value, self.g0.value = pt.gx, pt.gy, pt.g0
            if self.scheme == "proposed":
                self.half_speed_sq.value = (sc.speed / 2) ** 2
        if self.num_lines:
            self.ux.value, self.uy.value, self.h.value = pt.ux, pt.uy, pt.h
        if not conic.solve(self.problem) or self.q.value is None:
            return None
        return TrajectoryStep(
            np.asarray(self.q.value, dtype=float),
            np.asarray(self.delta.value, dtype=float),
            float(self.r_min.value or 0.0),
        )
