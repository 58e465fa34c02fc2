"""Algorithm 1: block coordinate descent over trajectory/slots, scheduling and power.

Each iteration r: update λ, μ ((28), (29)) and solve (P3-2) for (Q, Δ); solve (P1-2) for S;
η ← min(κη, η_max); solve (P2) for P. Stop when the exact objective changes by less than ε
and the schedule is binary. Then the schedule is rounded (one GN per slot), power is
re-optimised for it, and the min rate is recomputed from the exact rate formula.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mission_planner.optimize.initial import initial_tour
from mission_planner.optimize.power import power_problem
from mission_planner.optimize.scaled import (
    LENGTH_UNIT_M,
    Scaled,
    distance_sq,
    min_rate,
    scale_site,
    slot_rates,
)
from mission_planner.optimize.scheduling import scheduling_problem
from mission_planner.optimize.solution import SCHEMES, Solution
from mission_planner.optimize.trajectory import trajectory_problem
from validator.errors import InputError
from validator.site import Site

Progress = Callable[[int, float], None]


@dataclass(frozen=True)
class PlannerOptions:
    """Algorithm 1's constants (paper defaults) and our numerical choices.

    ``eta_scale`` "per-period" weighs the scheduling penalty against T·r_min (η/T), "literal"
    uses the paper's η as written. ``nfz_margin_m`` is added to every (buffered) NFZ radius so
    that solver tolerance and MAVLink's int32 1e-7° rounding (≤ 0.8 cm) never cost clearance.
    """

    gamma: float = 100.0
    eta_initial: float = 1.0
    kappa: float = 1.2
    eta_max: float = 1e6
    epsilon: float = 1e-4
    max_iterations: int = 40
    eta_scale: str = "per-period"
    binary_tolerance: float = 1e-3
    nfz_margin_m: float = 0.02


def _binary_gap(s: NDArray[np.float64]) -> float:
    return float(np.max(np.minimum(s, 1.0 - s)))


def _initial_schedule(sc: Scaled, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Each slot to the nearest GN: the tour's natural service order.

    A GN left with (almost) no slot would pin the min rate at zero, and the scheduling penalty
    then outweighs the gain of giving all starved GNs slots at once; so if nearest-GN leaves
    any GN fewer than N/(4K) slots, the cycle is cut into K equal blocks instead.
    """
    k, n = sc.num_gns, sc.num_slots
    nearest = np.argmin(distance_sq(sc, q), axis=0)
    if np.min(np.bincount(nearest, minlength=k)) < max(1, n // (4 * k)):
        nearest = np.minimum(np.arange(n) * k // n, k - 1)
    s = np.zeros((k, n))
    s[nearest, np.arange(n)] = 1.0
    return s


def plan(
    site: Site,
    scheme: str = "proposed",
    *,
    options: PlannerOptions | None = None,
    progress: Progress | None = None,
) -> Solution:
    """Optimise a service cycle for ``site`` with the ``proposed`` or ``conventional`` NFZ rule.

    Deterministic: the same site and options give the same solution.
    """
    if scheme not in SCHEMES:
        raise InputError(f"scheme: expected one of {', '.join(SCHEMES)}, got {scheme!r}")
    opt = options or PlannerOptions()
    if opt.eta_scale not in ("per-period", "literal"):
        raise InputError(f"eta_scale: expected 'per-period' or 'literal', got {opt.eta_scale!r}")
    started = time.perf_counter()
    sc = scale_site(site, opt.nfz_margin_m, opt.gamma)
    n = sc.num_slots

    traj = trajectory_problem(n, sc.num_gns, sc.num_nfzs, scheme)
    sched = scheduling_problem(sc.num_gns, n)
    pwr = power_problem(sc.num_gns, n)

    q, delta = initial_tour(sc)
    s = _initial_schedule(sc, q)
    # Uniform power just inside the budget: (7) then leaves (P3-2) free to move δ at first, and
    # it does not coincide with Σδ = T (which would leave the solver no interior point).
    power = np.full(n, 1.0 - 1e-3)
    eta = opt.eta_initial
    eta_div = site.period_s if opt.eta_scale == "per-period" else 1.0

    objective = min_rate(sc, q, delta, power, s)
    history = [objective]
    iterations = 0
    for iterations in range(1, opt.max_iterations + 1):
        step = traj.solve(sc, q, delta, power, s)
        if step is not None and min_rate(sc, step.q, step.delta, power, s) >= objective - 1e-9:
            q, delta = step.q, _renormalise(step.delta, n)
        s_new = sched.solve(slot_rates(sc, q, delta, power), s, eta / eta_div)
        if s_new is not None:
            s = s_new
        eta = min(opt.kappa * eta, opt.eta_max)
        p_new = pwr.solve(sc.rho / distance_sq(sc, q), s, delta, sc.peak)
        if p_new is not None:
            power = _within_budget(p_new, delta, sc.peak)
        new_objective = min_rate(sc, q, delta, power, s)
        history.append(new_objective)
        if progress is not None:
            progress(iterations, new_objective)
        done = (
            abs(new_objective - objective) < opt.epsilon and _binary_gap(s) < opt.binary_tolerance
        )
        objective = new_objective
        if done:
            break

    schedule = np.argmax(s, axis=0).astype(np.int64)
    binary = np.zeros_like(s)
    binary[schedule, np.arange(n)] = 1.0
    p_final = pwr.solve(sc.rho / distance_sq(sc, q), binary, delta, sc.peak)
    if p_final is not None and min_rate(
        sc, q, delta, _within_budget(p_final, delta, sc.peak), binary
    ) >= min_rate(sc, q, delta, power, binary):
        power = _within_budget(p_final, delta, sc.peak)

    trajectory = np.vstack([q[-1], q]) * LENGTH_UNIT_M
    return Solution(
        site=site,
        scheme=scheme,
        trajectory_m=trajectory,
        delta_s=delta * sc.slot_s,
        power_w=power * site.p_avg_w,
        schedule=schedule,
        iterations=iterations,
        solve_seconds=time.perf_counter() - started,
        history=history,
    )


def _renormalise(delta: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """Slot lengths with Σ δ̃ = N exactly (the solver meets it to ~1e-9)."""
    return np.asarray(delta * (n / np.sum(delta)), dtype=float)


def _within_budget(
    p: NDArray[np.float64], delta: NDArray[np.float64], peak: float
) -> NDArray[np.float64]:
    """Clip solver noise so that peak (8) and average (7) power hold exactly."""
    p = np.clip(p, 0.0, peak)
    avg = float(delta @ p) / delta.size
    return p / avg if avg > 1.0 else p
