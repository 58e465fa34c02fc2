"""Algorithm 1: block coordinate descent over trajectory/slots, scheduling and power.

Each iteration r: update λ, μ ((28), (29)) and solve (P3-2) for (Q, Δ), then search further
along that step on the exact objective (:mod:`.overrelax`; ``PlannerOptions.overrelax``);
solve (P1-2) for S; η ← min(κη, η_max); solve (P2) for P. Stop when the exact objective
changes by less than ε and the schedule is binary. Then the schedule is rounded (one GN per
slot), power is re-optimised for it, and the min rate is recomputed from the exact rate
formula.

With ``dynamics="vehicle"`` the optimised path is then re-timed as a multicopter flies it
(:mod:`.retime`), and schedule and power are optimised again on that timing; :mod:`.flyable`
searches the planning top speed for that.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from mission_planner.optimize.initial import initial_tour
from mission_planner.optimize.overrelax import overrelax
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
from mission_planner.optimize.solution import Solution, VehicleTiming
from mission_planner.optimize.trajectory import RELAXED_TERMS, trajectory_problem
from validator.site import Site

Progress = Callable[[int, float], None]
DYNAMICS = ("none", "vehicle")
# Algorithm 1's starting schedules: each slot to its nearest GN, or every GN a 1/K share.
START_SCHEDULES = ("nearest", "shares")
# The families of paths the "vehicle" search plans in wind (PlannerOptions.wind_paths).
WIND_PATHS = ("air-frame", "still-air")


@dataclass(frozen=True)
class PlannerOptions:
    """Algorithm 1's constants (paper defaults) and our numerical choices.

    ``gamma``: the quadratic transform's γ1 = γ2 in SI units, 100.0 as in the paper; None (the
    default) shifts each rate term's square roots to :data:`.trajectory.QT_HEADROOM` at each
    SCA point instead (:func:`.trajectory.qt_shifts`), which leaves (P0) as it is and moves
    the slot lengths much further per step.

    ``eta_scale`` "per-period" weighs the scheduling penalty against T·r_min (η/T), "literal"
    uses the paper's η as written. ``nfz_margin_m`` is added to every (buffered) NFZ radius so
    that solver tolerance and MAVLink's int32 1e-7° rounding (≤ 0.8 cm) never cost clearance.

    ``dynamics`` "vehicle" (the default, as ``plan-mission``'s) re-times
    the optimised path with the site's ``max_accel`` / ``max_jerk`` as ``autopilot``
    ("ardupilot" or "px4") flies it (:mod:`.retime`), with the autopilot parameters
    ``timing_params`` the plan will set (autopilot units, e.g. PX4's NAV_ACC_RAD); when the
    moves then overrun T, the path is planned again for a lower effective top speed, up to
    ``retime_attempts`` times. ``pass_through_corners``: ArduCopter flies through the corners
    whose turn keeps the buffer instead of stopping at every waypoint (:mod:`.corners`).
    ``start_schedules``: Algorithm 1 runs from each of these starting schedules
    (:data:`START_SCHEDULES`) and the best min rate is kept (with dynamics "vehicle", the best
    after re-timing); the schedule a start gives locks in early (once power equalises the
    rates, no slot can change GN alone), so a second start finds better optima on some sites
    at twice the CPU time. With one start, in wind, the still-air family of the "vehicle"
    search tries the other start's first candidate too and goes on from it where that one
    is clearly better (:func:`.flyable._still_start`). ``overrelax``: each accepted (P3-2)
    step is followed by a line search along it on the exact objective (:mod:`.overrelax`):
    the surrogate bends down in δ, so a step stops short of where the exact rate still
    rises. It applies to the paper's model ("none"); the "vehicle" search plans its
    candidates without it.
    ``search_ahead``: the "vehicle" search evaluates its likely next candidate in a spare
    thread while the current one runs (:mod:`.flyable`); the plan is the same either way.
    ``wind_paths``: in wind (the site's ``wind``), the "vehicle" search plans these families
    of paths (:data:`WIND_PATHS`), each with its own top-speed search, and keeps the one that
    flies best: "air-frame" (Algorithm 1 with the air-frame cone) and "still-air" (the
    still-air path re-timed in the wind). Neither wins everywhere: at the berth's 12.5 m
    buffer the still-air paths planned up to 36 % more on realistic.yaml and site-d, the
    air-frame ones up to 13 % more on site-c (:mod:`.flyable`). ``first_fit``: the "vehicle"
    search ends at the first planning speed whose moves fit T, not the best one: for a plan
    only looked at, never flown (the GPS-loss berth's probe, :mod:`mission_planner.pipeline`).
    "none" is the paper's kinematic model (top speed only): the
    studies reproducing the paper's figures use it (:data:`PAPER_OPTIONS`).
    """

    gamma: float | None = None
    eta_initial: float = 1.0
    kappa: float = 1.2
    eta_max: float = 1e6
    epsilon: float = 1e-4
    max_iterations: int = 30
    eta_scale: str = "per-period"
    binary_tolerance: float = 1e-3
    nfz_margin_m: float = 0.02
    dynamics: str = "vehicle"
    retime_attempts: int = 8
    autopilot: str = "ardupilot"
    timing_params: Mapping[str, float] = field(default_factory=dict)
    pass_through_corners: bool = True
    start_schedules: tuple[str, ...] = ("nearest",)
    overrelax: bool = True
    search_ahead: bool = True
    wind_paths: tuple[str, ...] = ("air-frame", "still-air")
    first_fit: bool = False


PAPER_OPTIONS = PlannerOptions(dynamics="none")  # the paper's model, for its figures


@dataclass
class _State:
    """The optimiser's variables in scaled units (see :mod:`.scaled`)."""

    q: NDArray[np.float64]  # (N, 2) slots 1..N
    delta: NDArray[np.float64]  # (N,)
    s: NDArray[np.float64]  # (K, N) relaxed schedule
    power: NDArray[np.float64]  # (N,)
    history: list[float] = field(default_factory=list)
    iterations: int = 0


def _binary_gap(s: NDArray[np.float64]) -> float:
    return float(np.max(np.minimum(s, 1.0 - s)))


def _initial_schedule(
    sc: Scaled, q: NDArray[np.float64], start: str = "nearest"
) -> NDArray[np.float64]:
    """Each slot to the nearest GN: the tour's natural service order (``start`` "shares":
    every GN a 1/K share of every slot instead).

    A GN left with (almost) no slot would pin the min rate at zero, and the scheduling penalty
    then outweighs the gain of giving all starved GNs slots at once; so if nearest-GN leaves
    any GN fewer than N/(4K) slots, the cycle is cut into K equal blocks instead.
    """
    k, n = sc.num_gns, sc.num_slots
    if start == "shares":
        return np.full((k, n), 1.0 / k)
    nearest = np.argmin(distance_sq(sc, q), axis=0)
    if np.min(np.bincount(nearest, minlength=k)) < max(1, n // (4 * k)):
        nearest = np.minimum(np.arange(n) * k // n, k - 1)
    s = np.zeros((k, n))
    s[nearest, np.arange(n)] = 1.0
    return s


def plan_paper(
    site: Site, scheme: str, opt: PlannerOptions, progress: Progress | None, started: float
) -> Solution:
    """Algorithm 1 on the paper's kinematic model (``dynamics="none"``), from each start."""
    sc = scale_site(site, opt.nfz_margin_m, opt.gamma)
    return _solution(site, scheme, sc, _best_start(sc, scheme, opt, progress), started)


def _best_start(
    sc: Scaled, scheme: str, opt: PlannerOptions, progress: Progress | None
) -> _State:
    """Of :func:`_start_states`, the best min rate (the first start on a tie)."""
    states = _start_states(sc, scheme, opt, progress)
    rates = [min_rate(sc, st.q, st.delta, st.power, st.s) for st in states]
    return states[int(np.argmax(rates))]  # argmax: the first of equal rates


def _start_states(
    sc: Scaled, scheme: str, opt: PlannerOptions, progress: Progress | None
) -> list[_State]:
    """Algorithm 1 from each of ``opt.start_schedules``, finished (:func:`_finish`).

    Several starts run in threads: Clarabel, most of a run's time, releases the GIL, so a
    second start costs little wall time where a second core is free (the runs share nothing,
    so the result is the same as one after the other). ``progress`` follows the first start.
    """
    starts = opt.start_schedules

    def run(i: int) -> _State:
        return _finish(sc, _algorithm1(sc, scheme, opt, progress if i == 0 else None, starts[i]))

    if len(starts) == 1:
        return [run(0)]
    with ThreadPoolExecutor(max_workers=len(starts)) as pool:
        return list(pool.map(run, range(len(starts))))


def _algorithm1(
    sc: Scaled, scheme: str, opt: PlannerOptions, progress: Progress | None,
    start: str = "nearest",
) -> _State:
    """The BCD loop of Algorithm 1 from the initial tour and the ``start`` schedule; returns
    the relaxed final state."""
    n = sc.num_slots
    q, delta = initial_tour(sc)
    # Uniform power just inside the budget: (7) then leaves (P3-2) free to move δ at first, and
    # it does not coincide with Σδ = T (which would leave the solver no interior point).
    state = _State(q, delta, _initial_schedule(sc, q, start), np.full(n, 1.0 - 1e-3))

    def trajectory_step(st: _State) -> None:
        terms = 1 if _binary_gap(st.s) < 1e-6 else RELAXED_TERMS
        traj = trajectory_problem(n, sc.num_gns, sc.num_nfzs, scheme, terms)
        step = traj.solve(sc, st.q, st.delta, st.power, st.s)
        objective = min_rate(sc, st.q, st.delta, st.power, st.s)
        if step is not None:
            new_delta = _renormalise(step.delta, n)
            if min_rate(sc, step.q, new_delta, st.power, st.s) >= objective - 1e-9:
                if opt.overrelax:
                    st.q, st.delta, st.power = overrelax(
                        sc, scheme, (st.q, st.delta), (step.q, new_delta), st.power, st.s
                    )
                else:
                    st.q, st.delta = step.q, new_delta

    _descend(sc, state, opt, progress, trajectory_step)
    return state


def _descend(
    sc: Scaled,
    state: _State,
    opt: PlannerOptions,
    progress: Progress | None,
    trajectory_step: Callable[[_State], None] | None,
) -> None:
    """Iterate (P3-2) (if given), (P1-2) and (P2) until the objective settles."""
    sched = scheduling_problem(sc.num_gns, sc.num_slots)
    eta = opt.eta_initial
    eta_div = sc.period_s if opt.eta_scale == "per-period" else 1.0
    objective = min_rate(sc, state.q, state.delta, state.power, state.s)
    state.history.append(objective)
    for _ in range(opt.max_iterations):
        if trajectory_step is not None:
            trajectory_step(state)
        s_new = sched.solve(
            slot_rates(sc, state.q, state.delta, state.power), state.s, eta / eta_div
        )
        if s_new is not None:
            state.s = s_new
        eta = min(opt.kappa * eta, opt.eta_max)
        p_new = _power_step(sc, state, state.s)
        if p_new is not None:
            state.power = p_new
        new_objective = min_rate(sc, state.q, state.delta, state.power, state.s)
        state.history.append(new_objective)
        state.iterations += 1
        if progress is not None:
            progress(state.iterations, new_objective)
        done = (
            abs(new_objective - objective) < opt.epsilon
            and _binary_gap(state.s) < opt.binary_tolerance
        )
        objective = new_objective
        if done:
            break


def _power_step(sc: Scaled, state: _State, s: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """(P2) for schedule ``s`` at the current trajectory, within the power budget exactly."""
    # A schedule binary to solver precision needs only the served GN's rate term per slot.
    binary = _binary_gap(s) < 1e-6
    pwr = power_problem(sc.num_gns, sc.num_slots, 1 if binary else sc.num_gns)
    p_new = pwr.solve(sc.rho / distance_sq(sc, state.q), s, state.delta, sc.peak)
    return None if p_new is None else _within_budget(p_new, state.delta, sc.peak)


def _finish(sc: Scaled, state: _State) -> _State:
    """One GN per slot (the largest share), power re-optimised for that binary schedule."""
    schedule = np.argmax(state.s, axis=0)
    binary = np.zeros_like(state.s)
    binary[schedule, np.arange(sc.num_slots)] = 1.0
    p_new = _power_step(sc, state, binary)
    if p_new is not None and min_rate(sc, state.q, state.delta, p_new, binary) >= min_rate(
        sc, state.q, state.delta, state.power, binary
    ):
        state.power = p_new
    state.s = binary
    return state


def _solution(
    site: Site, scheme: str, sc: Scaled, state: _State, started: float,
    timing: VehicleTiming | None = None,
) -> Solution:
    trajectory = np.vstack([state.q[-1], state.q]) * LENGTH_UNIT_M
    return Solution(
        site=site,
        scheme=scheme,
        trajectory_m=trajectory,
        delta_s=state.delta * sc.slot_s,
        power_w=state.power * site.p_avg_w,
        schedule=np.argmax(state.s, axis=0).astype(np.int64),
        iterations=state.iterations,
        solve_seconds=time.perf_counter() - started,
        history=state.history,
        timing=timing,
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
