"""The hand-assembled conic forms agree with their cvxpy models on random instances.

The cvxpy statements (``*Model``) are the readable models; the planner solves the directly
assembled forms (``*Problem``). Both are solved by Clarabel to 1e-7, so their optima agree to
about that; optimal points need not be unique (a max-min leaves slack GNs free), so the
objective evaluated at each solution is compared (for (P3-2) the surrogate, by
:func:`_surrogate_min`: cvxpy's own r_min can sit up to 4e-5 below what its point attains),
and each direct solution is checked against the model's constraints.
"""

from __future__ import annotations

import numpy as np
import pytest

from mission_planner.optimize.initial import initial_tour
from mission_planner.optimize.power import PowerModel, PowerProblem
from mission_planner.optimize.scaled import min_rate, scale_site
from mission_planner.optimize.scheduling import SchedulingModel, SchedulingProblem
from mission_planner.optimize.trajectory import (
    LN2,
    MIN_SLOT,
    QT_HEADROOM,
    TRUST_REGION,
    TrajectoryProblem,
    qt_shifts,
    sca_point,
)
from mission_planner.optimize.trajectory_model import TrajectoryModel
from mission_planner.study.sites import random_polygon_site, random_site

TOL = 2e-6  # both optima to Clarabel's 1e-7 gap, on objectives of order 1
# cvxpy's statement of (P3-2) (sqrt of inv_pos) solves less accurately than the direct form:
# its points fall short of the direct optimum by up to 3e-6 (polygon sites).
TRAJ_TOL = 1e-5


def _random_point(seed: int, slots: int = 24, gamma: float | None = None):
    site = random_site(seed, slots=slots)
    sc = scale_site(site, 0.02, gamma)
    q, delta = initial_tour(sc)
    rng = np.random.default_rng(seed)
    s = rng.dirichlet(np.ones(sc.num_gns), size=sc.num_slots).T
    power = rng.uniform(0.5, 1.0, sc.num_slots)
    return sc, q, delta, power, s


def _surrogate_min(sc, point, power, s, terms, q, delta):
    """min over GNs of (30)'s left side, the surrogate (27) with ln z ≥ ln z⁰ + 1 − z⁰/z, at
    (q, δ̃), linearised at ``point`` (q^r, δ^r); written from trajectory.py's docstring."""
    pt = sca_point(sc, *point, power, s, terms)
    slot = np.broadcast_to(np.arange(sc.num_slots), pt.top.shape)
    qx, qy = q[slot, 0], q[slot, 1]
    a = pt.a0 + pt.ax * qx + pt.ay * qy
    b = pt.b0 + pt.bx * qx + pt.by * qy - (qx**2 + qy**2)
    f = (pt.w_lambda * np.sqrt(pt.ashift - pt.a_ref / (a * LN2))
         + pt.w_mu * np.sqrt(pt.bshift - pt.b_ref / (b * LN2))
         - pt.w_inv / delta[slot] - pt.w_lin * delta[slot])
    per_gn = np.zeros(sc.num_gns)
    np.add.at(per_gn, pt.top, f)
    return float(np.min(per_gn))


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("scheme", ["proposed", "conventional"])
@pytest.mark.parametrize("terms", [1, 2])
@pytest.mark.parametrize("gamma", [None, 100.0])  # per-term shifts, the paper's
def test_trajectory_form_agrees_with_model(
    seed: int, scheme: str, terms: int, gamma: float | None
) -> None:
    sc, q, delta, power, s = _random_point(seed, gamma=gamma)
    shape = (sc.num_slots, sc.num_gns, sc.num_nfzs, scheme, terms)
    direct = TrajectoryProblem(*shape).solve(sc, q, delta, power, s)
    oracle = TrajectoryModel(*shape).solve(sc, q, delta, power, s)
    assert direct is not None and oracle is not None
    at_direct = _surrogate_min(sc, (q, delta), power, s, terms, direct.q, direct.delta)
    at_oracle = _surrogate_min(sc, (q, delta), power, s, terms, oracle.q, oracle.delta)
    assert at_direct == pytest.approx(at_oracle, abs=TRAJ_TOL)
    assert direct.r_min == pytest.approx(at_direct, abs=TOL)  # the optimum it reports is real
    # The direct step is feasible for (1)-(4), (7) and the trust region as the model states them.
    prev = np.r_[sc.num_slots - 1, np.arange(sc.num_slots - 1)]
    legs = np.linalg.norm(direct.q - direct.q[prev], axis=1)
    assert np.all(legs <= sc.speed * direct.delta + 1e-6)
    assert np.sum(direct.delta) == pytest.approx(sc.num_slots, abs=1e-6)
    assert np.all(direct.delta >= MIN_SLOT - 1e-7)
    assert power @ direct.delta / sc.num_slots <= 1 + 1e-6
    assert np.all(np.abs(direct.q - q) <= TRUST_REGION + 1e-6)
    # The surrogate is a lower bound of the exact rate: the step's exact min rate reaches it.
    assert min_rate(sc, direct.q, direct.delta, power, s) >= direct.r_min - 1e-6


@pytest.mark.parametrize("scheme", ["proposed", "conventional", "tangent"])
def test_trajectory_form_agrees_with_model_with_separating_lines(scheme: str) -> None:
    # Separating lines: polygon parts (every scheme) and circles (tangent).
    for site in (random_polygon_site(3, slots=24, buffer_m=2.0), random_site(5, slots=24)):
        sc = scale_site(site, 0.02)
        q, delta = initial_tour(sc)
        rng = np.random.default_rng(3)
        s = rng.dirichlet(np.ones(sc.num_gns), size=sc.num_slots).T
        power = rng.uniform(0.5, 1.0, sc.num_slots)
        shape = (sc.num_slots, sc.num_gns, sc.num_nfzs, scheme, 2)
        direct = TrajectoryProblem(*shape).solve(sc, q, delta, power, s)
        oracle = TrajectoryModel(*shape, num_parts=len(sc.parts)).solve(sc, q, delta, power, s)
        assert direct is not None and oracle is not None
        at_direct = _surrogate_min(sc, (q, delta), power, s, 2, direct.q, direct.delta)
        at_oracle = _surrogate_min(sc, (q, delta), power, s, 2, oracle.q, oracle.delta)
        assert at_direct == pytest.approx(at_oracle, abs=TRAJ_TOL)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("gamma", [None, 100.0])
def test_surrogate_is_tight_at_the_sca_point(seed: int, gamma: float | None) -> None:
    # SCA needs the surrogate to equal the exact rate at q^r (with one term per slot and a
    # binary schedule, where dropping terms loses nothing): the log bound and shifts included.
    sc, q, delta, power, s = _random_point(seed, gamma=gamma)
    binary = (s == s.max(axis=0)).astype(float)
    assert _surrogate_min(sc, (q, delta), power, binary, 1, q, delta) == pytest.approx(
        min_rate(sc, q, delta, power, binary), rel=1e-9
    )


def test_trajectory_form_keeps_every_leg_outside_the_zones() -> None:
    sc, q, delta, power, s = _random_point(4)
    step = TrajectoryProblem(sc.num_slots, sc.num_gns, sc.num_nfzs, "proposed", 2).solve(
        sc, q, delta, power, s
    )
    assert step is not None
    prev = np.r_[sc.num_slots - 1, np.arange(sc.num_slots - 1)]
    # (6-1): ‖q − c‖² ≥ G_m(q) ≥ R̃² + (Ṽδ̃/2)² at both ends of every leg.
    for c, r in zip(sc.nfz, sc.radius, strict=True):
        need = r**2 + (sc.speed * step.delta / 2) ** 2 - 1e-6
        assert np.all(np.sum((step.q - c) ** 2, axis=1) >= need)
        assert np.all(np.sum((step.q[prev] - c) ** 2, axis=1) >= need)


def _power_objective(p, gain, s, delta):
    n = s.shape[1]
    return float(np.min(np.sum(s * delta * np.log2(1 + gain * p), axis=1) / n))


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
@pytest.mark.parametrize("terms", [1, 4])
def test_power_form_agrees_with_model(seed: int, terms: int) -> None:
    rng = np.random.default_rng(seed)
    k, n = 4, 30
    gain = rng.uniform(1.0, 100.0, (k, n))
    s = rng.dirichlet(np.ones(k), size=n).T
    if terms == 1:  # one term is exact for a binary schedule
        s = (s == s.max(axis=0)).astype(float)
    delta = rng.uniform(0.5, 1.5, n)
    delta *= n / delta.sum()
    direct = PowerProblem(k, n, terms).solve(gain, s, delta, 4.0)
    oracle = PowerModel(k, n, terms).solve(gain, s, delta, 4.0)
    assert direct is not None and oracle is not None
    assert _power_objective(direct, gain, s, delta) == pytest.approx(
        _power_objective(oracle, gain, s, delta), abs=TOL
    )
    assert np.all(direct <= 4.0 + 1e-7) and delta @ direct / n <= 1 + 1e-6


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_scheduling_form_agrees_with_model(seed: int) -> None:
    rng = np.random.default_rng(seed)
    k, n = 4, 30
    rates = rng.uniform(0.0, 0.1, (k, n))
    s_prev = rng.dirichlet(np.ones(k), size=n).T
    direct = SchedulingProblem(k, n).solve(rates, s_prev, 0.02)
    oracle = SchedulingModel(k, n).solve(rates, s_prev, 0.02)
    assert direct is not None and oracle is not None

    def objective(s):
        penalty = np.sum(np.maximum(s * (1 - 2 * s_prev) + s_prev**2, 0.0))
        return float(np.min(np.sum(rates * s, axis=1))) - 0.02 * penalty

    assert objective(direct) == pytest.approx(objective(oracle), abs=TOL)
    assert np.all(direct.sum(axis=0) <= 1 + 1e-7)


def test_per_term_shifts_leave_every_square_root_the_headroom_at_the_sca_point() -> None:
    sc, q, delta, power, s = _random_point(1)
    pt = sca_point(sc, q, delta, power, s, 2)
    w = sc.gn[pt.top]
    d2 = np.sum((q[None] - w) ** 2, axis=-1) + sc.height**2
    gamma1, gamma2 = qt_shifts(sc, np.log2(d2 + sc.rho * power), -np.log2(d2))
    assert np.allclose(np.log2(d2 + sc.rho * power) + gamma1, QT_HEADROOM)
    assert np.allclose(np.log2(1.0 / d2) + gamma2, QT_HEADROOM)


def test_a_fixed_gamma_is_the_papers_in_si_units() -> None:
    # log2(σ² A + β0 p) + γ1 as the paper writes it, against the scaled form at one point.
    site = random_site(2, slots=24)
    sc = scale_site(site, 0.02, 100.0)
    d_m, p_w = 137.0, 0.05
    paper = np.log2(site.noise_w * d_m**2 + site.beta0 * p_w) + 100.0
    d_s, p_s = d_m / 100.0, p_w / site.p_avg_w
    gamma1, _ = qt_shifts(sc, np.log2(d_s**2 + sc.rho * p_s), 0.0)
    assert np.log2(d_s**2 + sc.rho * p_s) + gamma1 == pytest.approx(paper, rel=1e-12)
