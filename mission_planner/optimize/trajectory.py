"""(P3-2): trajectory and slot lengths by SCA and the quadratic transform (paper §III-C).

For fixed schedule s and power p, around the current point (q^r, δ^r):

    max  r_min
    s.t. Σ_n s_k[n] f_k[n] / N ≥ r_min                                      (30)
         f_k[n] = 2λ √(log2(Ã + ρp̃) + γ1) − λ²/δ̃ + 2μ √(log2 B̃ + γ2) − μ²/δ̃ − δ̃(γ1 + γ2)   (27)
         Ã = 2(q^r − w)ᵀ(q − q^r) + ‖q^r − w‖² + H̃²                          (22)
         B̃ = (2D − H̃² − ‖q − w‖²) / D²,   D = ‖q^r − w‖² + H̃²                  (23)
         ‖q[n] − q[n−1]‖ ≤ Ṽ δ̃[n],  Σ δ̃ = N,  δ̃ > 0,  q[0] = q[N]             (1)–(4)
         in wind w̃ also ‖q[n] − q[n−1] − w̃ δ̃[n]‖ ≤ Ṽ δ̃[n]  (the air-frame limit, :mod:`.scaled`)
         Σ δ̃ p̃ / N ≤ 1                                                       (7)
         proposed:     G_m(q[n]) ≥ R̃² + (Ṽδ̃[n]/2)²  and  G_m(q[n−1]) ≥ R̃² + (Ṽδ̃[n]/2)²   (6-1)
         conventional: G_m(q[n]) ≥ R̃²                                                   (5)
         G_m(q) = 2(q^r − c_m)ᵀ(q − q^r) + ‖q^r − c_m‖²                       (21)
         tangent:      u·q[n] ≥ u·c_m + R̃  and  u·q[n−1] ≥ u·c_m + R̃
         polygon part P, proposed and tangent: u·q[n] ≥ h_P(u) + b̃  and  u·q[n−1] ≥ h_P(u) + b̃
         polygon part P, conventional:         u·q[n] ≥ h_P(u) + b̃

Separating lines: u is the unit direction from the disc's centre, or from the convex part's
closest point, to the closest point of the current leg q^r[n−1]→q^r[n] (to q^r[n] alone for
conventional); h_P(u) = max_{v∈P} u·v is the part's support function and b̃ the buffer plus
margin. Both ends beyond one line put the whole leg beyond it, so every leg the rows accept keeps
R̃ from the centre, or b̃ from the part, whatever δ̃ (unlike (6-1)). That u maximises the leg's
least margin over the line, which is the leg's distance at q^r: the current point stays feasible
and SCA stays monotone. Every obstacle gets its rows in every slot: leaving out those beyond
reach of one trust-region step (√2 × TRUST_REGION) saved nothing measurable (8 polygon sites).

The average-power constraint (7) contains δ, which this block moves, so it is kept here although
the paper's list for (P3-2) omits it. λ, μ are set in closed form ((28), (29)) before each solve.
Positions q̃[1..N] are the variable; q̃[0] is q̃[N] (closed cycle). Units: see :mod:`.scaled`.

Size: only the ``terms`` GNs with the largest s_k[n] get a rate term in slot n. With a binary
schedule one term is exact and 20-40 % faster; while the schedule is relaxed, two terms (see
:data:`RELAXED_TERMS`) keep the surrogate tight at the current point, as SCA needs (with one,
a quarter of the steps on the benchmark sites lowered the objective and were thrown away);
the terms dropped are non-negative rates, so it stays a lower bound.

:class:`TrajectoryProblem` assembles the conic form for Clarabel directly (no cvxpy compile; its
size grows with the non-zeros: J·N rate terms, M·N zone rows, 2·O·N separating rows);
:class:`~.trajectory_model.TrajectoryModel` states the same problem in cvxpy, from the same
:func:`sca_point`, as the readable model and test oracle.

The shifts γ1, γ2 in (27) only keep its square roots real: with λ, μ by (28), (29) each term
equals the rate whatever they are, so they leave (P0) and its optima as they are. They set how
much the surrogate bends away from q^r, though: in δ̃ about 2(log2 SNR + γ1 + γ2)/δ̃, which with
the paper's γ1 = γ2 = 100 lets a step move each slot length by well under 1 % of T/N. So by
default (``PlannerOptions.gamma`` None) each term gets its own shifts at each SCA point, the
smallest that leave both square roots' arguments :data:`QT_HEADROOM` there (:func:`qt_shifts`);
the subproblem's cones keep them non-negative over the step. SCA stays monotone (each
subproblem is tight at its own q^r). Against the paper's γ, over the two samples, ten random
and three polygon sites, both schemes: paper model min rate +8.3 % on average (+3.6 % to
+21.5 %, in 8 % less CPU time); vehicle model +5.8 % (−4.7 % to +68 %, the speed search
lands elsewhere). See the README's *Speed and optima*.

The logarithms in (27) are bounded below once more, by ln z ≥ ln z⁰ + 1 − z⁰/z (z⁰: the value
at q^r), for z = Ã + ρp̃ and z = D²B̃. The bound is concave in q and tight at q^r with the same
gradient, so SCA keeps its guarantees (monotone, limit points that are KKT points of the same
problem), and it needs second-order cones only. With exponential cones for ln z, Clarabel took
about 36 interior-point steps per (P3-2) solve; with this bound, about 18, each about half as
long. Its curvature at q^r is twice the logarithm's, so single steps are a little shorter; over
the ten benchmark sites, both schemes, the mean min rate was the same to 1e-4 bps/Hz.

Conic form, per slot n and term i = (j, n) serving GN k(i) (all rotated second-order cones):

    u1_i (Ã_i + ρp̃_n) ≥ 1,  u2_i D²B̃_i ≥ 1                             (u ≥ 1/z)
    t1_i² ≤ γ1 + (ln z⁰_i + 1 − z⁰_i u1_i) / ln 2                      (z⁰ = Ã + ρp̃ at q^r)
    t2_i² ≤ γ2 − 2 log2 D_i + (ln D_i + 1 − D_i u2_i) / ln 2           (D²B̃ = D at q^r)
    ι_n δ̃_n ≥ 1 (ι = 1/δ̃),  σ_n ≥ ‖q[n]‖² (in B̃),  e_n ≥ δ̃_n² (in (6-1))
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mission_planner.optimize import conic
from mission_planner.optimize.scaled import Scaled
from validator.errors import InputError
from validator.geometry import segment_point_closest_fraction
from validator.zones import leg_separation, support_m

LN2 = float(np.log(2.0))
TRUST_REGION = 1.0  # largest move of a waypoint per SCA step, per axis, in 100 m
MIN_SLOT = 1e-2  # smallest δ̃ (fraction of T/N): δ[n] > 0 (1)
RELAXED_TERMS = 2  # rate terms per slot while the schedule is fractional (1 once binary)
# The square roots' arguments in (27) at the SCA point with per-term shifts (bits). 1, 2 and 4
# gave +7.0 %, +6.8 % and +5.1 % over the paper's γ on 30 random paper-default sites (min rate,
# paper model); 2 leaves a step room to halve Ã + ρp̃ or D²B̃ and did best in vehicle mode.
QT_HEADROOM = 2.0


@dataclass(frozen=True)
class TrajectoryStep:
    q: NDArray[np.float64]  # (N, 2) positions of slots 1..N
    delta: NDArray[np.float64]  # (N,)
    r_min: float  # the surrogate's optimum


@dataclass(frozen=True)
class ScaPoint:
    """The surrogate's coefficients at (q^r, δ^r) for J rate terms per slot, each (J, N)."""

    top: NDArray[np.int64]  # GN k(j, n) of each term
    ax: NDArray[np.float64]  # 2 (q^r − w)_x
    ay: NDArray[np.float64]
    a0: NDArray[np.float64]  # constant part of Ã + ρ p̃
    a_ref: NDArray[np.float64]  # Ã + ρ p̃ at q^r
    bx: NDArray[np.float64]  # 2 w_x
    by: NDArray[np.float64]
    b0: NDArray[np.float64]  # 2D − H̃² − ‖w‖²
    b_ref: NDArray[np.float64]  # D²B̃ at q^r, which is D
    ashift: NDArray[np.float64]  # γ1 + (ln Ã⁰ + 1) / ln 2 (Ã⁰ = a_ref)
    bshift: NDArray[np.float64]  # γ2 − 2 log2 D + (ln D + 1) / ln 2
    w_lambda: NDArray[np.float64]  # 2 s λ / N
    w_mu: NDArray[np.float64]  # 2 s μ / N
    w_inv: NDArray[np.float64]  # s (λ² + μ²) / N
    w_lin: NDArray[np.float64]  # s (γ1 + γ2) / N
    gx: NDArray[np.float64]  # (M, N) 2 (q^r − c)_x
    gy: NDArray[np.float64]
    g0: NDArray[np.float64]  # ‖c‖² − ‖q^r‖² − R̃²
    ux: NDArray[np.float64]  # (O, N) separating line u·q ≥ h of obstacle o for leg n
    uy: NDArray[np.float64]
    h: NDArray[np.float64]  # h_P(u) + b̃, or u·c + R̃


def separating_lines(
    sc: Scaled, q: NDArray[np.float64], scheme: str
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Unit directions u (O, N, 2), offsets h (O, N) and the current slack (O, N) of the
    separating line of each obstacle o and leg n at q^r = ``q`` (module docstring).

    Obstacles: the polygon parts, then (``tangent`` only) the circles. ``conventional`` takes
    the line to the point q^r[n] instead of the leg.
    """
    n = sc.num_slots
    start = q if scheme == "conventional" else q[np.r_[n - 1, np.arange(n - 1)]]
    us, hs, slacks = [], [], []
    for part in sc.parts:
        u, gap = leg_separation(part, start, q)
        us.append(u)
        hs.append(support_m(part, u) + sc.clearance)
        slacks.append(gap - sc.clearance)
    if scheme == "tangent":
        for c, r in zip(sc.nfz, sc.radius, strict=True):
            t = segment_point_closest_fraction(start, q, c)
            d = start + t[:, None] * (q - start) - c
            dist = np.linalg.norm(d, axis=1)
            # A leg through the centre is never feasible; any line will do for it.
            d = np.where(dist[:, None] > 1e-12, d, [1.0, 0.0])
            u = d / np.linalg.norm(d, axis=1, keepdims=True)
            us.append(u)
            hs.append(u @ c + r)
            slacks.append(dist - r)
    if not us:
        return np.zeros((0, n, 2)), np.zeros((0, n)), np.zeros((0, n))
    return np.stack(us), np.stack(hs), np.stack(slacks)


def qt_shifts(
    sc: Scaled, log_a: NDArray[np.float64], log_b: NDArray[np.float64]
) -> tuple[NDArray[np.float64] | float, NDArray[np.float64] | float]:
    """γ1, γ2 of the rate terms whose logarithms at q^r are ``log_a`` = log2(Ã + ρp̃) and
    ``log_b`` = log2 B̃ (each (J, N)): the site's fixed shifts, or else per term the ones that
    make both square roots' arguments QT_HEADROOM at q^r (module docstring). A fixed γ that
    leaves an argument at or below zero is refused: (28), (29) would take its square root."""
    if sc.gamma1 is not None and sc.gamma2 is not None:
        if min(float(np.min(log_a)) + sc.gamma1, float(np.min(log_b)) + sc.gamma2) <= 0.0:
            raise InputError("gamma: too small for this site, a square root in (27) would be of "
                             "a negative number; leave it None for per-term shifts")
        return sc.gamma1, sc.gamma2
    return QT_HEADROOM - log_a, QT_HEADROOM - log_b


def sca_point(
    sc: Scaled,
    q: NDArray[np.float64],
    delta: NDArray[np.float64],
    power: NDArray[np.float64],
    s: NDArray[np.float64],
    terms: int,
    scheme: str = "proposed",
) -> ScaPoint:
    """(22), (23), (21) linearised at q^r = ``q``; λ, μ by (28), (29) at (q, δ); the
    separating lines of ``scheme`` at q^r."""
    n = sc.num_slots
    cols = np.arange(n)
    top = np.argsort(-s, axis=0, kind="stable")[: min(sc.num_gns, terms)]  # (J, N)
    w = sc.gn[top]  # (J, N, 2)
    s_top = s[top, cols] / n
    diff = q[None, :, :] - w  # q^r − w
    d2 = np.sum(diff * diff, axis=-1) + sc.height**2  # D
    a_ref = d2 + sc.rho * power[None, :]
    log_a, log_b = np.log2(a_ref), -np.log2(d2)  # log2(Ã + ρp̃), log2 B̃ at q = q^r
    gamma1, gamma2 = qt_shifts(sc, log_a, log_b)
    # (28), (29): λ = δ √(log2(Ã + ρp̃) + γ1), μ = δ √(log2 B̃ + γ2) at q = q^r.
    lam = delta[None, :] * np.sqrt(log_a + gamma1)
    mu = delta[None, :] * np.sqrt(log_b + gamma2)
    cdiff = q[None, :, :] - sc.nfz[:, None, :]  # (M, N, 2)
    u, h, _ = separating_lines(sc, q, scheme)
    return ScaPoint(
        top=top,
        ax=2 * diff[..., 0],
        ay=2 * diff[..., 1],
        a0=d2 - 2 * np.sum(diff * q[None], axis=-1) + sc.rho * power[None, :],
        a_ref=a_ref,
        bx=2 * w[..., 0],
        by=2 * w[..., 1],
        b0=2 * d2 - sc.height**2 - np.sum(w * w, axis=-1),
        b_ref=d2,
        ashift=gamma1 + (np.log(a_ref) + 1.0) / LN2,
        bshift=gamma2 - 2 * np.log2(d2) + (np.log(d2) + 1.0) / LN2,
        w_lambda=2 * s_top * lam,
        w_mu=2 * s_top * mu,
        w_inv=s_top * (lam**2 + mu**2),
        w_lin=s_top * (gamma1 + gamma2),
        gx=2 * cdiff[..., 0],
        gy=2 * cdiff[..., 1],
        g0=np.sum(sc.nfz**2, axis=1)[:, None] - np.sum(q**2, axis=1)[None, :]
        - (sc.radius**2)[:, None],
        ux=u[..., 0],
        uy=u[..., 1],
        h=h,
    )


TERM_VARS = ("t1", "t2", "u1", "u2")  # one per rate term (J, N); the others per slot


class TrajectoryProblem:
    """(P3-2) for a shape, assembled for Clarabel; :meth:`solve` re-solves around a new point.

    The variable layout and row structure depend on the shape only; each solve fills in the
    values of the current point (see the module docstring for the conic form).
    """

    def __init__(
        self, num_slots: int, num_gns: int, num_nfzs: int, scheme: str, terms: int = 1
    ) -> None:
        n, k, m = num_slots, num_gns, num_nfzs
        j = min(k, terms)
        self.shape = (n, k, m, j)
        self.scheme = scheme
        self.prev = np.r_[n - 1, np.arange(n - 1)]
        sizes = {"qx": n, "qy": n, "delta": n, "inv": n, "r": 1, "t1": j * n, "t2": j * n,
                 "u1": j * n, "u2": j * n, "sigma": n, "e": n if m and scheme == "proposed" else 0}
        ends = np.cumsum(list(sizes.values()))
        self.num_vars = int(ends[-1])
        # Column indices of each variable, terms as (J, N) arrays.
        self.col = {
            name: np.arange(end - size, end).reshape((j, n) if name in TERM_VARS else (-1,))
            for (name, size), end in zip(sizes.items(), ends, strict=True)
        }

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
        c, prev = self.col, self.prev
        form = conic.ConicForm(self.num_vars)
        form.c[c["r"]] = -1.0  # max r_min
        slot = np.broadcast_to(np.arange(n), (j, n))  # slot of each term
        one_row = np.zeros(n, dtype=np.int64)
        form.zero([-float(n)], entries=(one_row, c["delta"], np.ones(n)))  # Σ δ̃ = N
        # (30): Σ_n s f / N − r_min ≥ 0, one row per GN; a term enters its GN's row only.
        form.nonneg(
            np.zeros(k),
            (c["r"], -1.0),
            entries=(
                np.tile(pt.top.ravel(), 4),
                np.concatenate([c["t1"].ravel(), c["t2"].ravel(), c["inv"][slot].ravel(),
                                c["delta"][slot].ravel()]),
                np.concatenate([pt.w_lambda.ravel(), pt.w_mu.ravel(), -pt.w_inv.ravel(),
                                -pt.w_lin.ravel()]),
            ),
        )
        form.nonneg(np.full(n, -MIN_SLOT), (c["delta"], 1.0))  # δ̃ ≥ MIN_SLOT
        form.nonneg([1.0], entries=(one_row, c["delta"], -power / n))  # (7)
        # Trust region |q − q^r| ≤ TRUST_REGION per axis.
        for axis, name in enumerate(("qx", "qy")):
            form.nonneg(TRUST_REGION + q[:, axis], (c[name], -1.0))
            form.nonneg(TRUST_REGION - q[:, axis], (c[name], 1.0))
        form.nonneg(np.zeros((j, n)), (c["t1"], 1.0))
        form.nonneg(np.zeros((j, n)), (c["t2"], 1.0))
        if m:
            at_n = ((c["qx"][None], pt.gx), (c["qy"][None], pt.gy))
            if self.scheme == "proposed":
                # (6-1) at both ends of leg n: G_m(q[n]) − (Ṽ/2)² e_n ≥ 0, G_m(q[n−1]) likewise.
                e_term = (c["e"][None], np.full((m, n), -((sc.speed / 2) ** 2)))
                form.nonneg(pt.g0, *at_n, e_term)
                form.nonneg(
                    pt.g0[:, prev],
                    (c["qx"][prev][None], pt.gx[:, prev]),
                    (c["qy"][prev][None], pt.gy[:, prev]),
                    e_term,
                )
            elif self.scheme == "conventional":
                form.nonneg(pt.g0, *at_n)  # (5)
        # Separating lines (polygon parts; circles under tangent): u·q − h ≥ 0 at leg ends.
        if pt.h.size:
            ends = [np.arange(n)] if self.scheme == "conventional" else [np.arange(n), prev]
            for e in ends:
                form.nonneg(-pt.h, (c["qx"][e][None], pt.ux), (c["qy"][e][None], pt.uy))
        # (1): ‖q[n] − q[n−1]‖ ≤ Ṽ δ̃[n].
        form.soc(
            np.zeros((n, 3)),
            (c["delta"][:, None], [sc.speed, 0.0, 0.0]),
            (c["qx"][:, None], [0.0, 1.0, 0.0]),
            (c["qx"][prev][:, None], [0.0, -1.0, 0.0]),
            (c["qy"][:, None], [0.0, 0.0, 1.0]),
            (c["qy"][prev][:, None], [0.0, 0.0, -1.0]),
        )
        if sc.wind is not None:
            # In wind the top speed holds in the air: ‖q[n] − q[n−1] − w̃ δ̃[n]‖ ≤ Ṽ δ̃[n].
            wx, wy = float(sc.wind[0]), float(sc.wind[1])
            form.soc(
                np.zeros((n, 3)),
                (c["delta"][:, None], [sc.speed, -wx, -wy]),
                (c["qx"][:, None], [0.0, 1.0, 0.0]),
                (c["qx"][prev][:, None], [0.0, -1.0, 0.0]),
                (c["qy"][:, None], [0.0, 0.0, 1.0]),
                (c["qy"][prev][:, None], [0.0, 0.0, -1.0]),
            )
        # ι δ̃ ≥ 1: ‖(ι − δ̃, 2)‖ ≤ ι + δ̃.
        form.soc(
            np.tile([0.0, 0.0, 2.0], (n, 1)),
            (c["inv"][:, None], [1.0, 1.0, 0.0]),
            (c["delta"][:, None], [1.0, -1.0, 0.0]),
        )
        # t² ≤ z with z = shift − z⁰ u / ln 2: ‖(z − 1, 2t)‖ ≤ z + 1.
        bounds = (("t1", "u1", pt.a_ref.ravel(), pt.ashift.ravel()),
                  ("t2", "u2", pt.b_ref.ravel(), pt.bshift.ravel()))
        for t, u, ref, shift in bounds:
            form.soc(
                shift[:, None] * np.array([1.0, 1.0, 0.0]) + np.array([1.0, -1.0, 0.0]),
                (c[u].reshape(-1, 1), (-ref / LN2)[:, None] * np.array([1.0, 1.0, 0.0])),
                (c[t].reshape(-1, 1), [0.0, 0.0, 2.0]),
            )
        # σ ≥ ‖q‖²: ‖(σ − 1, 2qx, 2qy)‖ ≤ σ + 1.
        form.soc(
            np.tile([1.0, -1.0, 0.0, 0.0], (n, 1)),
            (c["sigma"][:, None], [1.0, 1.0, 0.0, 0.0]),
            (c["qx"][:, None], [0.0, 0.0, 2.0, 0.0]),
            (c["qy"][:, None], [0.0, 0.0, 0.0, 2.0]),
        )
        if m and self.scheme == "proposed":
            # e ≥ δ̃²: ‖(e − 1, 2δ̃)‖ ≤ e + 1.
            form.soc(
                np.tile([1.0, -1.0, 0.0], (n, 1)),
                (c["e"][:, None], [1.0, 1.0, 0.0]),
                (c["delta"][:, None], [0.0, 0.0, 2.0]),
            )
        # u1 Ã ≥ 1 (22), u2 D²B̃ ≥ 1 (23): ‖(u − z, 2)‖ ≤ u + z.
        qx_t, qy_t = c["qx"][slot].reshape(-1, 1), c["qy"][slot].reshape(-1, 1)
        sum_diff = np.array([1.0, -1.0, 0.0])
        form.soc(
            pt.a0.reshape(-1, 1) * sum_diff + np.array([0.0, 0.0, 2.0]),
            (c["u1"].reshape(-1, 1), [1.0, 1.0, 0.0]),
            (qx_t, pt.ax.reshape(-1, 1) * sum_diff),
            (qy_t, pt.ay.reshape(-1, 1) * sum_diff),
        )
        form.soc(
            pt.b0.reshape(-1, 1) * sum_diff + np.array([0.0, 0.0, 2.0]),
            (c["u2"].reshape(-1, 1), [1.0, 1.0, 0.0]),
            (qx_t, pt.bx.reshape(-1, 1) * sum_diff),
            (qy_t, pt.by.reshape(-1, 1) * sum_diff),
            (c["sigma"][slot].reshape(-1, 1), -sum_diff),
        )
        x = form.solve()
        if x is None:
            return None
        return TrajectoryStep(
            np.stack([x[c["qx"]], x[c["qy"]]], axis=1), x[c["delta"]], float(x[c["r"]][0])
        )


@functools.lru_cache(maxsize=16)
def trajectory_problem(
    num_slots: int, num_gns: int, num_nfzs: int, scheme: str, terms: int = 1
) -> TrajectoryProblem:
    """(P3-2) for this shape, shared by every site of that shape in the process."""
    return TrajectoryProblem(num_slots, num_gns, num_nfzs, scheme, terms)
