"""An independent, plain cvxpy + Clarabel implementation of the paper's Algorithm 1.

A yardstick for ``mission_planner.optimize`` (issue 15): it imports nothing from it. Each
subproblem is written as the paper writes it and rebuilt in cvxpy at every step:

- (P3-2) trajectory and slot lengths: SCA of (21)-(23), the quadratic transform (27) with
  λ, μ from (28), (29), NFZs by (6-1) ("proposed") or (5) ("conventional"); no trust region,
  and by default without the power budget (7), as the paper lists (P3-2)'s constraints;
- (P1-2) scheduling: the relaxed schedule with the penalty convex-concave procedure;
- (P2) power: concave, solved as it stands;
- η ← min(κη, η_max); stop after ``iterations`` or when the objective rises by less than ε
  with a binary schedule. Then one GN per slot (argmax), power re-optimised for it.

The start (Algorithm 1 line 2) is our own: a tour through the GNs (or a circle) laid outside
the expanded zones, every GN an equal share of every slot, uniform power.

Solver units keep every number O(1): lengths in 100 m, slot lengths in T/N (so Σδ̃ = N),
power in P_avg. Then δ[n]/T = δ̃[n]/N and log2(1 + β0 p/(σ² d²)) = log2(1 + ρ p̃/d̃²) with
ρ = β0 P_avg/(σ² (100 m)²). The paper's γ1 = γ2 = 100 belong to logarithms of SI quantities;
in solver units log2(σ² A + β0 p) = log2(Ã + ρ p̃) + c and log2(B/σ²) = log2 B̃ − c with
c = log2(σ² (100 m)²), so γ̃1 = γ1 + c and γ̃2 = γ2 − c give exactly the paper's surrogate.

Usage: ``reference_plan(site)`` returns a dict (SI units); ``check_plan(site, plan)`` its worst
constraint margins.
"""

from __future__ import annotations

import itertools
import time
import warnings
from dataclasses import dataclass
from typing import Any

import cvxpy as cp
import numpy as np
from numpy.typing import NDArray

from validator.geometry import leg_clearances
from validator.site import Site

Array = NDArray[np.float64]
UNIT_M = 100.0  # solver length unit
LN2 = float(np.log(2.0))
NFZ_MARGIN_M = 1e-3  # solver tolerance (~1e-6 m) must never cost the published radius
LAY_FACTOR = 1.1  # the initial tour keeps this multiple of the expanded radius
TOUR_SPEED_SHARE = 0.9  # the initial tour flies at most this share of V
P0_SHARE = 1 - 1e-3  # uniform initial power, in P_avg: (7) then is not parallel to Σδ = T


@dataclass(frozen=True)
class Units:
    """A site in solver units (see the module docstring)."""

    n: int
    gn: Array  # (K, 2), 100 m
    nfz: Array  # (M, 2), 100 m
    radius: Array  # (M,), 100 m, with NFZ_MARGIN_M
    h: float  # altitude, 100 m
    v: float  # distance per unit slot at top speed, 100 m
    rho: float
    peak: float  # P_peak / P_avg
    g1: float  # γ̃1
    g2: float  # γ̃2


def units(site: Site, gamma: float = 100.0) -> Units:
    """``site`` in solver units, NFZ radii with buffer and NFZ_MARGIN_M, γ̃ for ``gamma``."""
    c = float(np.log2(site.noise_w * UNIT_M**2))
    return Units(site.slots, site.gn_xy_m / UNIT_M, site.nfz_xy_m.reshape(-1, 2) / UNIT_M,
                 (site.nfz_radius_m + site.buffer_m + NFZ_MARGIN_M) / UNIT_M,
                 site.altitude_m / UNIT_M, site.max_speed_mps * site.period_s / site.slots / UNIT_M,
                 site.beta0 * site.p_avg_w / (site.noise_w * UNIT_M**2),
                 site.p_peak_w / site.p_avg_w, gamma + c, gamma - c)


def slot_rates(u: Units, q: Array, d: Array, p: Array) -> Array:
    """(K, N) exact δ̃ log2(1 + ρ p̃/d̃²)/N: GN k's average rate (bps/Hz) is Σ_n s_k[n]·this."""
    d2 = np.sum((q[None] - u.gn[:, None]) ** 2, axis=-1) + u.h**2
    return np.asarray(d[None] * np.log2(1.0 + u.rho * p[None] / d2) / u.n, dtype=float)


def objective(u: Units, q: Array, d: Array, p: Array, s: Array) -> float:
    """The objective of (P0), min_k r̄_k, for a possibly relaxed schedule (bps/Hz)."""
    return float(np.min(np.sum(s * slot_rates(u, q, d, p), axis=1)))


def _solve(prob: cp.Problem) -> bool:
    """Clarabel; a shorter interior-point step is the usual cure when it stalls."""
    for opts in ({}, {"max_step_fraction": 0.9}):
        try:
            with warnings.catch_warnings():  # "inaccurate" is fine: the exact objective judges
                warnings.simplefilter("ignore", UserWarning)
                prob.solve(solver=cp.CLARABEL, **opts)
        except cp.error.SolverError:
            continue
        if prob.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
            return True
    return False


def power_step(u: Units, q: Array, d: Array, s: Array) -> Array | None:
    """(P2): p̃ (N,) maximising min_k r̄_k under (7), (8); None if the solver fails."""
    gain = u.rho / (np.sum((q[None] - u.gn[:, None]) ** 2, axis=-1) + u.h**2)  # (K, N)
    p, r = cp.Variable(u.n, nonneg=True), cp.Variable()
    cons = [d @ p / u.n <= 1, p <= u.peak]
    for k in range(len(u.gn)):
        on = np.flatnonzero(s[k] > 1e-9)  # a zero weight adds nothing
        w = s[k, on] * d[on] / (u.n * LN2)
        cons.append(w @ cp.log(1 + cp.multiply(gain[k, on], p[on])) >= r if on.size else r <= 0)
    prob = cp.Problem(cp.Maximize(r), cons)
    return np.clip(p.value, 0.0, u.peak) if _solve(prob) and p.value is not None else None


def schedule_step(u: Units, rates: Array, s_r: Array, eta_w: float) -> Array | None:
    """(P1-2): relaxed schedule (K, N) for exact slot rates ``rates``, penalty weight η_w."""
    s, phi, r = cp.Variable(s_r.shape), cp.Variable(s_r.shape, nonneg=True), cp.Variable()
    cons = [s >= 0, s <= 1, cp.sum(s, axis=0) <= 1,
            cp.sum(cp.multiply(rates, s), axis=1) >= r,
            cp.multiply(s, 1 - 2 * s_r) + s_r**2 <= phi]  # s(1 − s) ≤ 0 linearised at s^r
    prob = cp.Problem(cp.Maximize(r - eta_w * cp.sum(phi)), cons)
    return np.clip(s.value, 0.0, 1.0) if _solve(prob) and s.value is not None else None


def trajectory_step(u: Units, qr: Array, dr: Array, p: Array, s: Array, scheme: str,
                    keep_power_budget: bool = True) -> tuple[Array, Array] | None:
    """(P3-2) around (q^r, δ^r) for fixed S, P: new (q (N, 2), δ̃ (N,)), or None.

    ``keep_power_budget``: add (7), which the paper's list for (P3-2) omits."""
    n = u.n
    prev = np.r_[n - 1, np.arange(n - 1)]  # q[0] = q[N] (4)
    q, d, r = cp.Variable((n, 2)), cp.Variable(n), cp.Variable()
    cons = [d >= 1e-3, cp.sum(d) == n,  # (1), (2)
            cp.norm(q - q[prev], axis=1) <= u.v * d]  # (3)
    if keep_power_budget:
        cons.append(d @ p / u.n <= 1)
    for c, rad in zip(u.nfz, u.radius, strict=True):
        # (21): G^LB_m[n], the tangent of ‖q[n] − c‖² at q^r[n]
        g = cp.sum(cp.multiply(2 * (qr - c), q - qr), axis=1) + np.sum((qr - c) ** 2, axis=1)
        if scheme == "proposed":  # (6-1) at both ends of leg n
            need = rad**2 + (u.v / 2) ** 2 * cp.square(d)
            cons += [g >= need, g[prev] >= need]
        else:  # (5)
            cons.append(g >= rad**2)
    inv_d = cp.inv_pos(d)
    for k, w in enumerate(u.gn):
        on = np.flatnonzero(s[k] > 1e-6)
        if not on.size:
            cons.append(r <= 0)
            continue
        qk, dk = q[on], d[on]
        d0 = np.sum((qr[on] - w) ** 2, axis=1) + u.h**2  # ‖q^r − w‖² + H²
        a_lb = cp.sum(cp.multiply(2 * (qr[on] - w), qk - qr[on]), axis=1) + d0  # (22)
        b_lb = 1 / d0 - (cp.sum(cp.square(qk - np.tile(w, (on.size, 1))), axis=1)
                         + u.h**2 - d0) / d0**2  # (23)
        x1 = cp.log(a_lb + u.rho * p[on]) / LN2 + u.g1
        x2 = cp.log(b_lb) / LN2 + u.g2
        lam = dr[on] * np.sqrt(np.log2(d0 + u.rho * p[on]) + u.g1)  # (28) at q^r
        mu = dr[on] * np.sqrt(np.log2(1 / d0) + u.g2)  # (29)
        f = (2 * cp.multiply(lam, cp.sqrt(x1)) - cp.multiply(lam**2, inv_d[on])
             + 2 * cp.multiply(mu, cp.sqrt(x2)) - cp.multiply(mu**2, inv_d[on])
             - (u.g1 + u.g2) * dk)  # (27)
        cons.append(s[k, on] @ f / n >= r)  # (30)
    prob = cp.Problem(cp.Maximize(r), cons)
    if not _solve(prob) or q.value is None or d.value is None:
        return None
    dv = np.maximum(d.value, 1e-3)
    return np.asarray(q.value, dtype=float), dv * (n / np.sum(dv))


def _push_out(pts: Array, centres: Array, lay: Array) -> Array:
    """Points moved radially onto the nearest ``lay`` circle when inside it (a few passes for
    overlapping circles)."""
    pts = pts.copy()
    for _ in range(20):
        moved = False
        for c, rad in zip(centres, lay, strict=True):
            off = pts - c
            dist = np.linalg.norm(off, axis=1)
            inside = dist < rad
            if np.any(inside):
                moved = True
                off[inside & (dist < 1e-9)] = [1.0, 0.0]
                pts[inside] = c + off[inside] * (rad / np.linalg.norm(off[inside], axis=1))[:, None]
        if not moved:
            break
    return pts


def initial(u: Units, shape: str = "tour") -> tuple[Array, Array]:
    """A feasible start (q (N, 2), δ̃ = 1): "tour" visits the GNs in the shortest order and
    hovers at them with the slots left over; "circle" is a circle round their centroid. Both
    keep LAY_FACTOR × the expanded radius (so (6-1) holds at δ̃ = 1) and fly ≤ 0.9 V."""
    n, k = u.n, len(u.gn)
    lay = LAY_FACTOR * np.sqrt(u.radius**2 + (u.v / 2) ** 2)
    hub = _push_out(u.gn.mean(axis=0, keepdims=True), u.nfz, lay)[0]
    for shrink in (1.0, 0.8, 0.6, 0.4, 0.2):
        if shape == "circle":
            rad = shrink * min(np.mean(np.linalg.norm(u.gn - hub, axis=1)),
                               TOUR_SPEED_SHARE * u.v * n / (2 * np.pi))
            ang = np.linspace(0, 2 * np.pi, 360, endpoint=False)
            stops = hub + rad * np.stack([np.cos(ang), np.sin(ang)], axis=1)
        else:  # the shortest visiting order, by brute force (K ≤ 8; else as listed)
            orders = itertools.permutations(range(1, k)) if k <= 8 else [tuple(range(1, k))]
            order = min(([0, *o] for o in orders),
                        key=lambda o: np.sum(np.linalg.norm(u.gn[o] - u.gn[np.roll(o, 1)], axis=1)))
            stops = _push_out(hub + shrink * (u.gn[order] - hub), u.nfz, lay)
        # Densify each leg to 0.5 m and push it out too: it then follows the circles' arcs.
        ring = np.vstack([stops, stops[:1]])
        pts: list[Array] = []
        at_stop: list[int] = []
        for a, b in itertools.pairwise(ring):
            at_stop.append(len(pts))
            steps = max(1, int(np.ceil(np.linalg.norm(b - a) / 0.005)))
            pts.extend(a + np.linspace(0, 1, steps, endpoint=False)[:, None] * (b - a))
        dense = _push_out(np.array(pts), u.nfz, lay)
        arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(np.vstack([dense, dense[:1]]), axis=0),
                                                 axis=1))]
        travel = int(np.ceil(arc[-1] / (TOUR_SPEED_SHARE * u.v)))
        if travel > n:
            continue
        if shape == "tour":  # the slots left over hover at the stops, evenly shared
            spare = np.array_split(np.arange(n - travel), len(at_stop))
            hover = [arc[i] for i, extra in zip(at_stop, spare, strict=True) for _ in extra]
            marks = np.sort(np.r_[np.arange(travel) * arc[-1] / max(travel, 1), hover])
        else:  # a circle flies all the time
            marks = np.arange(n) * arc[-1] / n
        closed = np.vstack([dense, dense[:1]])
        q = np.stack([np.interp(marks, arc, closed[:, 0]), np.interp(marks, arc, closed[:, 1])], 1)
        if _start_ok(u, q):
            return q, np.ones(n)
    return np.tile(hub, (n, 1)), np.ones(n)


def _start_ok(u: Units, q: Array) -> bool:
    legs = np.linalg.norm(q - np.roll(q, 1, axis=0), axis=1)
    dist = np.linalg.norm(q[:, None] - u.nfz[None], axis=-1) if len(u.nfz) else np.ones((1, 1))
    return bool(np.all(legs <= u.v) and np.all(dist >= np.sqrt(u.radius**2 + (u.v / 2) ** 2)))


def reference_plan(site: Site, scheme: str = "proposed", iterations: int = 40, *,
                   gamma: float = 100.0, eta_initial: float = 1.0, kappa: float = 1.2,
                   eta_max: float = 1e6, epsilon: float = 1e-4, eta_per_period: bool = True,
                   start: str = "tour", schedule0: str = "uniform", power0: str = "uniform",
                   keep_power_budget: bool = False, initial_m: tuple[Array, Array] | None = None,
                   ) -> dict[str, Any]:
    """Algorithm 1 on ``site``. Returns min_rate_bps_hz (exact, rounded schedule),
    trajectory_m (N+1, 2) m, delta_s (N,) s, power_w (N,) W, schedule (N,) GN index, history
    (objective per iteration, bps/Hz, relaxed schedule), relaxed_final (the last relaxed
    objective before rounding), binary_gap (max min(s, 1 − s) then), iterations, seconds.

    ``eta_per_period``: the penalty weighs Σφ against T·r_min (η/T), not against the average
    rate r_min (η literally): with bps/Hz rates of ~2, η¹ = 1 freezes the schedule.
    ``initial_m``: start from this (trajectory (N+1, 2) m, slot lengths (N,) s) instead of
    ``start`` ("tour" or "circle"); it must satisfy (1)-(4) and (6-1). ``schedule0``:
    "uniform" (1/K each) or "nearest" (each slot to its nearest GN); ``power0``: "uniform"
    (just under P_avg) or "p2" ((P2) for S⁰). The BCD is path-dependent: with "nearest" and
    "p2" every GN's rate is equalised at once, and no single slot can then move to another GN
    without lowering the min rate, so the schedule freezes where the start put it.
    ``keep_power_budget``: add the power budget (7) to (P3-2); with P fixed it forbids moving
    time to the slots with above-average power, so δ and P only move apart, slowly.
    """
    started = time.perf_counter()
    u = units(site, gamma)
    n = u.n
    if initial_m is None:
        q, d = initial(u, start)
    else:
        q = np.asarray(initial_m[0], dtype=float)[1:] / UNIT_M
        d = np.asarray(initial_m[1], dtype=float) * n / site.period_s
    if schedule0 == "nearest":  # each slot to its nearest GN
        near = np.argmin(np.sum((q[None] - u.gn[:, None]) ** 2, axis=-1), axis=0)
        s = np.zeros((len(u.gn), n))
        s[near, np.arange(n)] = 1.0
    else:  # every GN an equal share of every slot
        s = np.full((len(u.gn), n), 1.0 / len(u.gn))
    p = power_step(u, q, d, s) if power0 == "p2" else None
    p = np.full(n, P0_SHARE) if p is None else p
    history = [objective(u, q, d, p, s)]
    gap = float(np.max(np.minimum(s, 1 - s)))
    eta, eta_div = eta_initial, (site.period_s if eta_per_period else 1.0)
    done = 0
    while done < iterations:
        done += 1
        step = trajectory_step(u, q, d, p, s, scheme, keep_power_budget)
        if step is not None:
            q, d = step
        s_new = schedule_step(u, slot_rates(u, q, d, p), s, eta / eta_div)
        s = s if s_new is None else s_new
        eta = min(kappa * eta, eta_max)
        p_new = power_step(u, q, d, s)
        p = p if p_new is None else p_new
        history.append(objective(u, q, d, p, s))
        gap = float(np.max(np.minimum(s, 1 - s)))  # 0 for a binary schedule
        if gap < 1e-3 and history[-1] - history[-2] < epsilon:
            break
    relaxed = history[-1]
    sched = np.argmax(s, axis=0)
    s = np.zeros_like(s)
    s[sched, np.arange(n)] = 1.0
    p_new = power_step(u, q, d, s)
    if p_new is not None and objective(u, q, d, p_new, s) >= objective(u, q, d, p, s):
        p = p_new
    p *= min(1.0, n / float(d @ p))  # solver noise must not lift the average power above P_avg
    traj = np.vstack([q[-1:], q]) * UNIT_M
    delta_s, power_w = d * site.period_s / n, p * site.p_avg_w
    rates = _average_rates(site, traj, delta_s, power_w, sched)
    return {"min_rate_bps_hz": float(np.min(rates)), "trajectory_m": traj, "delta_s": delta_s,
            "power_w": power_w, "schedule": sched.astype(np.int64), "history": history,
            "relaxed_final": relaxed, "binary_gap": gap, "iterations": done,
            "seconds": time.perf_counter() - started}


def _average_rates(site: Site, traj: Array, delta_s: Array, power_w: Array,
                   sched: NDArray[np.int64]) -> Array:
    """Exact time-averaged rates (bps/Hz), eq. (13) (the same formula as the planner's
    ``average_rates``, which this file must not import)."""
    d2 = np.sum((traj[1:] - site.gn_xy_m[sched]) ** 2, axis=1) + site.altitude_m**2
    r = delta_s * np.log2(1 + site.beta0 * power_w / (site.noise_w * d2)) / site.period_s
    return np.bincount(sched, weights=r, minlength=site.num_gns).astype(float)


def check_plan(site: Site, plan: dict[str, Any]) -> dict[str, float]:
    """Worst margins of a plan: all must be ≥ 0 (leg clearance from the buffered NFZs in m,
    |Σδ − T| in s as a negative number, speed slack Vδ − leg in m, power budgets in W)."""
    traj, delta, p = plan["trajectory_m"], plan["delta_s"], plan["power_w"]
    legs = np.linalg.norm(np.diff(traj, axis=0), axis=1)
    clear = (leg_clearances(traj, site.nfz_xy_m, site.planning_radius_m)
             if site.num_nfzs else np.full((1, 1), np.inf))
    return {"clearance_m": float(np.min(clear)),
            "closed_m": -float(np.linalg.norm(traj[0] - traj[-1])),
            "sum_delta_s": -abs(float(np.sum(delta)) - site.period_s),
            "speed_m": float(np.min(site.max_speed_mps * delta - legs)),
            "avg_power_w": site.p_avg_w - float(delta @ p) / site.period_s,
            "peak_power_w": site.p_peak_w - float(np.max(p))}
