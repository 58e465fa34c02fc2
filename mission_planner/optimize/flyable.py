"""Plans the vehicle flies on time (``dynamics="vehicle"``): Algorithm 1 at the highest
planning top speed whose path, re-timed as the multicopter flies it (:mod:`.retime`), fits T.

The vehicle's moves take longer than the paper's; planning for a lower top speed gives a
shorter path. The search starts at the site's V or the vehicle's real top speed, whichever is
lower; the speed falls until the re-timed moves fit (or, when they fit at once, rises by
:data:`RAISE_FACTOR` while they fit, up to :data:`RAISE_LIMIT` times the start), else bisects
between the fastest speed that fit and the slowest that overran (each speed once,
``retime_attempts`` candidates at most). The candidate with the best min rate is kept. The
planning speed only shapes Algorithm 1's path: every candidate is timed at the vehicle's real
speed.

Each candidate is a whole run of Algorithm 1, most of it inside Clarabel, which releases the
GIL. So while one candidate runs, the one the search will most likely try next is evaluated in
a spare thread (:class:`_Ahead`, ``PlannerOptions.search_ahead``); a guess is used only for
exactly the speed it was made for, so the plan is the same as without it; and only while a
core is idle (:func:`_spare_core`). On this 2-core machine, over the two samples and six
random sites, 13 of 25 guesses were used and the wall time fell 11-19 % (22.5-24.9 -> 20.0 s;
realistic.yaml, the quick start's site, 1.8 -> 1.1-1.4 s) for about 40 % more CPU time.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from types import TracebackType
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from mission_planner.optimize import retime
from mission_planner.optimize.bcd import (
    START_SCHEDULES,
    PlannerOptions,
    Progress,
    _descend,
    _finish,
    _initial_schedule,
    _renormalise,
    _solution,
    _start_states,
    _State,
)
from mission_planner.optimize.scaled import LENGTH_UNIT_M, Scaled, min_rate, scale_site
from mission_planner.optimize.solution import Solution, VehicleTiming
from validator.errors import InputError
from validator.motion.speed_model import cruise_speed_mps
from validator.site import Site

SEARCH_ITERATIONS = 15  # Algorithm 1 iterations per candidate top speed
BRACKET_REL = 0.05  # the search stops bisecting within 5 % of the overrunning speed
RAISE_FACTOR = 1.25  # a path that fits at the vehicle's top speed is planned again this much faster
RAISE_LIMIT = 2.0  # ... up to this multiple of the top speed
# In wind the still-air family searches from another start schedule only where that start's
# first candidate is better by this much (min rate, or the move-time ratio when neither fits)
START_MARGIN = 0.01


@runtime_checkable
class SearchProgress(Protocol):
    """A ``progress`` callback that also hears which candidate the search runs: Algorithm 1's
    iterations restart at 1 for each (e.g. :class:`mission_planner.progress.PlanProgress`)."""

    def __call__(self, iteration: int, objective: float) -> None: ...

    def candidate(self, number: int, most: int, speed_mps: float) -> None: ...


@dataclass
class _Flyable:
    """A re-timed candidate: the planning top speed, the trajectory indices of its waypoints,
    the vehicle's move time (s), and the optimised state on that timeline."""

    speed_mps: float
    waypoint_slots: list[int]
    move_s: float
    state: _State
    min_rate: float
    still_path: bool = False  # in wind: the still-air path, re-timed in the wind
    start: str = "nearest"  # the start schedule Algorithm 1 ran from (START_SCHEDULES)


def _as_calibrated(opt: PlannerOptions) -> bool:
    """Whether plans keep to the shapes the autopilot's replay was calibrated on: PX4's (SIH
    flights, issues 16 and 26): the skeleton judged a whole stretch at a time, no planning
    speed above the vehicle's, the search ended at the first speed that fits. Simplified
    chord by chord, PX4 plans stopped at more corners, which SIH flew 3-5 % faster than the
    px4 model predicts (about 0.7 s a stop). Its corners are flown through where their swing
    region keeps the buffer (:mod:`.corners`); the search ending at the first speed that
    fits, such a plan may be worse than the one stopping at every waypoint, so
    :func:`mission_planner.pipeline.plan_and_build` makes both and keeps the better flown."""
    return opt.autopilot == "px4"


def _retimed(
    site: Site, scheme: str, speed: float, opt: PlannerOptions, progress: Progress | None,
    still_path: bool = False,
) -> tuple[_Flyable | None, float]:
    """Plan with top speed ``speed`` (paper model), re-time it for the vehicle, and optimise
    schedule and power on the new timing. Returns the candidate (None if its moves overrun T)
    and the ratio of the vehicle's move time to the paper's. With several start schedules
    each start's path is re-timed and the best flyable one kept: the best paper-model path
    is not always the best flown one. ``still_path``: Algorithm 1 plans for still air (the
    re-timing is in the site's wind all the same)."""
    return _best_of(_retimed_starts(site, scheme, speed, opt, progress, still_path))


def _retimed_starts(
    site: Site, scheme: str, speed: float, opt: PlannerOptions, progress: Progress | None,
    still_path: bool,
) -> list[tuple[_Flyable | None, float]]:
    """:func:`_retimed`'s candidate and move-time ratio from each of ``opt.start_schedules``."""
    planning_site = site.with_limits(max_speed_mps=speed)
    if still_path:
        planning_site = planning_site.with_limits(wind=None)
    elif site.wind is not None:
        # The planning speed scales the vehicle's whole ground-speed envelope in the wind,
        # so the wind scales with it: slowing the air speed alone would leave upwind legs a
        # sliver of their real speed (V − w at V = 8.1 m/s in 6 m/s of wind: 2.1, flown 4).
        cruise = cruise_speed_mps(site, opt.autopilot)
        planning_site = planning_site.with_limits(wind=site.wind.scaled(speed / cruise))
    psc = scale_site(planning_site, opt.nfz_margin_m, opt.gamma)
    # The re-timing, not Algorithm 1's slow tail, decides these candidates: fewer iterations,
    # and no over-relaxation, which sharpens that tail (over 24 vehicle plans it left 20 within
    # 0.1 % and moved the rest by -9.7 % to +0.6 %: the best paper path is not the best flown).
    search = replace(opt, max_iterations=min(opt.max_iterations, SEARCH_ITERATIONS),
                     overrelax=False)
    each = [_retimed_path(site, scheme, speed, opt, planning_site, psc, state)
            for state in _start_states(psc, scheme, search, progress)]
    for (cand, _), start in zip(each, opt.start_schedules, strict=True):
        if cand is not None:
            cand.start = start
    return each


def _best_of(each: list[tuple[_Flyable | None, float]]) -> tuple[_Flyable | None, float]:
    """The best flyable candidate of several (the first of equal min rates) and the least
    ratio of the vehicle's move time to the paper's among them."""
    best: _Flyable | None = None
    for cand, _ in each:
        if cand is not None and (best is None or cand.min_rate > best.min_rate):
            best = cand
    return best, float(min(ratio for _, ratio in each))


def _retimed_path(
    site: Site, scheme: str, speed: float, opt: PlannerOptions, planning_site: Site,
    psc: Scaled, state: _State,
) -> tuple[_Flyable | None, float]:
    """:func:`_retimed` for one finished paper-model state planned on ``planning_site``."""
    paper = _solution(planning_site, scheme, psc, state, 0.0)
    # Simplified legs keep the planner's margin too, so the exporter need not nudge them (a
    # nudged waypoint no longer lies on the S-curve it was timed with).
    sk = retime.skeleton(
        paper.trajectory_m, paper.delta_s, site.nfz_xy_m, site.planning_radius_m + opt.nfz_margin_m,
        polygons=site.polygon_zones, polygon_clear_m=site.buffer_m + opt.nfz_margin_m,
        chordwise=not _as_calibrated(opt),
    )
    sk = retime.started_near(sk, site.home_xy_m)
    paper_move_s = max(site.period_s - float(np.sum(sk.hold_s)), 1e-9)
    # Passing through corners leaves the time saved to the hover points; with fewer than two
    # it would all pool at one, so stopping at every corner is tried as well (stops that pay).
    modes = [opt.pass_through_corners]
    if (opt.pass_through_corners and not _as_calibrated(opt)
            and np.count_nonzero(sk.hold_s > 0) < 2):
        modes.append(False)
    best: _Flyable | None = None
    fastest_move_s = np.inf
    for pass_through in modes:
        move_s, timed = retime.time_cycle(site, sk, site.period_s, site.slots, opt.autopilot,
                                          opt.timing_params, pass_through)
        fastest_move_s = min(fastest_move_s, move_s)
        if timed is None:
            continue
        cand = _on_timeline(site, sk, timed, move_s, speed, state.iterations, opt)
        if best is None or cand.min_rate > best.min_rate:
            best = cand
    return best, fastest_move_s / paper_move_s


def _on_timeline(
    site: Site, sk: retime.Skeleton, timed: tuple[NDArray[np.float64], NDArray[np.float64]],
    move_s: float, speed: float, iterations: int, opt: PlannerOptions,
) -> _Flyable:
    """Schedule and power optimised on a re-timed trajectory (``timed``: (N+1, 2) positions,
    (N,) slot lengths) of skeleton ``sk``, planned at ``speed``."""
    sc = scale_site(site, opt.nfz_margin_m, opt.gamma)
    trajectory_m, delta_s = timed
    q = trajectory_m[1:] / LENGTH_UNIT_M
    delta = _renormalise(delta_s / sc.slot_s, sc.num_slots)
    timed_state = _State(
        q,
        delta,
        _initial_schedule(sc, q),
        np.full(sc.num_slots, 1.0 - 1e-3),
        iterations=iterations,
    )
    _descend(sc, timed_state, opt, None, None)
    _finish(sc, timed_state)
    rate = min_rate(sc, timed_state.q, timed_state.delta, timed_state.power, timed_state.s)
    return _Flyable(speed, _waypoint_slots(trajectory_m, sk), move_s, timed_state, rate)


@dataclass
class _Search:
    """The top-speed search's state (module docstring): what was tried and what it gave."""

    start: float  # the first speed: the site's V or the vehicle's real top speed
    raises: bool  # a path that fits is planned again faster (not PX4's: _as_calibrated)
    first_fit: bool = False  # a probe's (PlannerOptions.first_fit): no bisection after a fit
    fits_at: float | None = None  # the fastest speed whose moves fit T
    over_at: float | None = None  # the slowest speed whose moves overran T
    tried: set[float] = field(default_factory=set)
    best: _Flyable | None = None

    def record(self, speed: float, cand: _Flyable | None) -> None:
        self._bracket(speed, fits=cand is not None)
        if cand is not None and (self.best is None or cand.min_rate > self.best.min_rate):
            self.best = cand

    def _bracket(self, speed: float, fits: bool) -> None:
        self.tried.add(round(speed, 3))
        if fits:
            self.fits_at = speed if self.fits_at is None else max(self.fits_at, speed)
        else:
            self.over_at = speed if self.over_at is None else min(self.over_at, speed)

    def next_speed(self, speed: float, overrun: float | None) -> float | None:
        """The speed to try after ``speed`` (recorded), whose moves took ``overrun`` times the
        paper's; None when the search is over, or (``overrun`` None) when it depends on that."""
        if self.fits_at is None:
            return None if overrun is None else speed * float(np.clip(0.9 / overrun, 0.2, 0.9))
        if self.first_fit:
            return None
        if self.over_at is None:
            if not self.raises:
                return None
            # The vehicle flies this path within T with time to spare: planning for a faster
            # UAV than it is (a path reaching further, or hovering longer) may still fit.
            faster = speed * RAISE_FACTOR
            return None if faster > RAISE_LIMIT * self.start else faster
        if self.over_at - self.fits_at < BRACKET_REL * self.over_at or self.fits_at >= self.start:
            return None  # (above the start, a raise that overruns ends the search: no bisection)
        # Bisect between the fastest fit and the slowest overrun. A fitting candidate with a
        # lower min rate than the best still moves the bracket: the min rate is not monotonic
        # in the planning speed (each speed gives Algorithm 1 another path).
        middle = (self.fits_at + self.over_at) / 2
        return None if round(middle, 3) in self.tried else middle

    def likely_next(self, speed: float) -> float | None:
        """The speed the search will try after ``speed`` in its likelier outcome, if that can be
        known before ``speed`` is flown: before any fit, the one after a fit (after an overrun
        it depends on by how much); afterwards the one after an overrun (in the bisection the
        upper half overran on 12 of 16 candidates over six sites)."""
        guess = replace(self, tried=set(self.tried))
        guess._bracket(speed, fits=self.fits_at is None)
        return guess.next_speed(speed, None)


class _Cancelled(Exception):
    """A guessed candidate the search no longer needs (raised inside its Algorithm 1)."""


class _Ahead:
    """Evaluates one guessed candidate in a spare thread while the search runs the current one.

    ``evaluate(speed, progress)`` runs a candidate. A guess whose speed the search then asks for
    is waited for and used; a guess the search turns out not to need is cancelled at its next
    Algorithm 1 iteration (its progress callback raises). With ``enabled`` False (or one CPU)
    nothing runs ahead.
    """

    def __init__(self, evaluate: Callable[[float, Progress | None], tuple[_Flyable | None, float]],
                 enabled: bool) -> None:
        self._evaluate = evaluate
        self._pool = ThreadPoolExecutor(max_workers=1) if enabled else None
        self._guess: tuple[float, Future[tuple[_Flyable | None, float]], threading.Event] | None
        self._guess = None

    def __enter__(self) -> _Ahead:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self._drop()
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)

    def guess(self, speed: float | None) -> None:
        if self._pool is None or self._guess is not None or speed is None:
            return
        stop = threading.Event()

        def cancellable(iteration: int, objective: float) -> None:
            if stop.is_set():
                raise _Cancelled

        self._guess = (speed, self._pool.submit(self._evaluate, speed, cancellable), stop)

    def run(self, speed: float, progress: Progress | None) -> tuple[_Flyable | None, float]:
        """The candidate at ``speed``: the guess's result if it was made for it, else run here
        (a guess made for the next candidate runs on meanwhile)."""
        if self._guess is not None and self._guess[0] == speed:
            result = self._guess[1].result()
            self._guess = None
            return result
        return self._evaluate(speed, progress)

    def keep_only(self, speed: float | None) -> None:
        """Cancel the guess unless it was made for ``speed``, the search's next candidate."""
        if self._guess is not None and self._guess[0] != speed:
            self._drop()

    def _drop(self) -> None:
        if self._guess is not None:
            self._guess[2].set()
            self._guess = None


def _spare_core() -> bool:
    """Whether a core is free for a guess: two CPUs or more, and the load average (1 min, which
    counts this process once it has run a while) leaves at least half a CPU idle.

    On a busy machine (parallel plans, a test suite, a simulator) a guess only takes CPU from
    the others and from the current candidate; PX4 SIH, which is not lockstepped, then flies
    late."""
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):  # no load average (Windows): assume an idle machine
        load = 0.0
    cpus = os.cpu_count() or 1
    return cpus >= 2 and cpus - load >= 0.5


def plan_flyable(
    site: Site, scheme: str, opt: PlannerOptions, progress: Progress | None, started: float
) -> Solution:
    """Algorithm 1 at the highest top speed whose path the vehicle flies within T (module
    docstring). In wind each family of ``opt.wind_paths`` has its own search and the better
    plan is kept (:func:`_wind_searches`); the timing's ``wind_path`` says which won."""
    windy = site.wind is not None and not site.wind.calm
    if windy:
        search, tries = _wind_searches(site, scheme, opt, progress)
    else:
        search, tries = _search(site, scheme, opt, progress, still_path=False)
    best = search.best
    if best is None:
        raise InputError(
            f"uav: no flyable cycle of {site.period_s:g} s found within max_accel "
            f"{site.max_accel_mps2:g} m/s² and max_jerk {site.max_jerk_mps3:g} m/s³ "
            f"(tried top speeds down to {min(search.tried):.2f} m/s)"
        )
    sc = scale_site(site, opt.nfz_margin_m, opt.gamma)
    timing = VehicleTiming(
        autopilot=opt.autopilot,
        timing_params=dict(opt.timing_params),
        planning_speed_mps=best.speed_mps,
        speeds_tried=tries,
        waypoint_slots=tuple(best.waypoint_slots),
        move_s=best.move_s,
        wind_path=None if not windy else "still-air" if best.still_path else "air-frame",
        start_schedule=best.start if windy else None,
    )
    return _solution(site, scheme, sc, best.state, started, timing)


def _wind_searches(site: Site, scheme: str, opt: PlannerOptions, progress: Progress | None
                   ) -> tuple[_Search, int]:
    """The search of each family of ``opt.wind_paths``, the one that found the better plan
    (the first listed on a tie), and how many speeds they tried in all.

    The air-frame cone shapes the paper model's path for a vehicle without acceleration
    limits, which is not always the best flown one: re-timed in the wind, the still-air path
    at a lower planning speed flies better on some sites, and worse on others (module
    docstring of :mod:`mission_planner.optimize.bcd`, ``wind_paths``). The still-air search
    starts where a straight there-and-back along the wind takes as long as in still air,
    (V² − w²)/V: the speed it ends at, not V; and from the start schedule whose first
    candidate there is clearly better (:func:`_still_start`). With a core spare the families
    run side by side (Clarabel releases the GIL), each then without its guess ahead; the plan
    is the same either way."""
    families = [family == "still-air" for family in opt.wind_paths]
    cruise = cruise_speed_mps(site, opt.autopilot)
    wind = site.wind.speed_mps if site.wind is not None else 0.0
    still_first = max(cruise * 0.2, (cruise ** 2 - wind ** 2) / cruise)

    def run(i: int, still: bool, ahead: bool) -> tuple[_Search, int]:
        family, first = replace(opt, search_ahead=ahead), None
        if still:
            family, first = _still_start(site, scheme, family, still_first)
        return _search(site, scheme, family, progress if i == 0 else None, still_path=still,
                       first_mps=still_first if still else None, first=first)

    if len(families) > 1 and opt.search_ahead and _spare_core():
        with ThreadPoolExecutor(max_workers=len(families)) as pool:
            found = list(pool.map(lambda i: run(i, families[i], False), range(len(families))))
    else:
        found = [run(i, still, opt.search_ahead) for i, still in enumerate(families)]
    best = found[0][0]
    for still, (search, _) in zip(families, found, strict=True):
        if search.best is not None:
            search.best.still_path = still
            if best.best is None or search.best.min_rate > best.best.min_rate:
                best = search
    return best, sum(n for _, n in found)


def _still_start(
    site: Site, scheme: str, opt: PlannerOptions, speed: float
) -> tuple[PlannerOptions, tuple[_Flyable | None, float] | None]:
    """The options the still-air family searches with in wind (their one start schedule) and,
    when a start was chosen here, its candidate at the search's first speed ``speed``.

    Re-timed in wind at the lower planning speeds this family ends at, the still-air path
    depends more on Algorithm 1's start than in still air: over 42 site-wind pairs (the SITL
    campaign's 21 and ``bench_wind.py``'s) the 1/K shares start gave this family up to 22 %
    more (site-c 4@90,1) and up to 12 % less (site-e 6@135,1.5) than the nearest-GN start.
    So both starts' first candidates are made and the search goes on from the other start
    only where its candidate is clearly better (:data:`START_MARGIN`): it fits where the own
    start's overruns, or its min rate or move-time ratio is 1 % better. Over those pairs the
    plans for the wind gained 2.0 % of min rate on average, up to 19 % (site-c 6@270), on 13,
    and lost 0.8 % on one (site-d 8@0,2), for one more candidate (the margin was chosen on
    the campaign's 21, where no plan got worse, and held on the others; searching from both
    starts all along gained 2.5 %, never worse, for a third more CPU). With several starts
    per candidate (``--second-start``), or a plan only looked at (``first_fit``), nothing is
    chosen.
    """
    if len(opt.start_schedules) != 1 or opt.first_fit:
        return opt, None
    own = opt.start_schedules[0]
    starts = (own, *(s for s in START_SCHEDULES if s != own))
    each = _retimed_starts(site, scheme, speed, replace(opt, start_schedules=starts), None,
                           still_path=True)
    pick = 0
    for i in range(1, len(each)):
        if _clearly_better(each[i], each[pick]):
            pick = i
    return replace(opt, start_schedules=(starts[pick],)), each[pick]


def _clearly_better(a: tuple[_Flyable | None, float], b: tuple[_Flyable | None, float]) -> bool:
    """Whether candidate ``a`` (with its move-time ratio) beats ``b`` by :data:`START_MARGIN`:
    it fits where ``b`` overruns, or both fit and its min rate is higher by the margin, or
    neither fits and its moves are shorter (relative to the paper's) by the margin."""
    (fit_a, ratio_a), (fit_b, ratio_b) = a, b
    if fit_a is not None and fit_b is not None:
        return fit_a.min_rate > fit_b.min_rate * (1 + START_MARGIN)
    if fit_a is not None or fit_b is not None:
        return fit_a is not None
    return ratio_a < ratio_b * (1 - START_MARGIN)


def _search(site: Site, scheme: str, opt: PlannerOptions, progress: Progress | None,
            still_path: bool, first_mps: float | None = None,
            first: tuple[_Flyable | None, float] | None = None) -> tuple[_Search, int]:
    """The top-speed search (module docstring), from ``first_mps`` if given (else the start),
    and how many speeds it tried; ``first``: the first speed's candidate, already made."""
    search = _Search(cruise_speed_mps(site, opt.autopilot),
                     raises=not _as_calibrated(opt), first_fit=opt.first_fit)
    speed = search.start if first_mps is None else first_mps
    tries = 0

    def evaluate(v: float, report: Progress | None) -> tuple[_Flyable | None, float]:
        if still_path:
            return _retimed(site, scheme, v, opt, report, still_path=True)
        return _retimed(site, scheme, v, opt, report)

    with _Ahead(evaluate, opt.search_ahead and _spare_core()) as ahead:
        for attempt in range(opt.retime_attempts):
            if attempt + 1 < opt.retime_attempts:
                ahead.guess(search.likely_next(speed))
            if isinstance(progress, SearchProgress):
                progress.candidate(attempt + 1, opt.retime_attempts, speed)
            if attempt == 0 and first is not None:
                cand, overrun = first
            else:
                cand, overrun = ahead.run(speed, progress)
            search.record(speed, cand)
            tries += 1
            after = search.next_speed(speed, overrun)
            ahead.keep_only(after)
            if after is None:
                break
            speed = after
    return search, tries


def _waypoint_slots(trajectory_m: NDArray[np.float64], sk: retime.Skeleton) -> list[int]:
    """Trajectory indices (0..N) at which the re-timed cycle reaches a skeleton waypoint."""
    out = []
    for p in sk.points_m:
        d = np.linalg.norm(trajectory_m - p, axis=1)
        out.append(int(np.flatnonzero(d < 1e-6)[0]))
    return sorted(set(out))


