"""The vehicle search's top-speed sequence, and the spare thread that runs its likely next
candidate ahead: a guess must be exactly the speed the search then asks for, a guess it does
not need is cancelled, and the plan is the same with or without it."""

from __future__ import annotations

import threading
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from mission_planner.optimize import PlannerOptions, flyable, plan
from mission_planner.optimize.flyable import _Ahead, _Cancelled, _clearly_better, _Search
from mission_planner.study.sites import random_site


class _Fit:
    def __init__(self, rate: float) -> None:
        self.min_rate = rate


def test_after_an_overrun_with_no_fit_yet_the_speed_falls_by_the_overrun() -> None:
    search = _Search(10.0, raises=True)
    search.record(10.0, None)
    assert search.next_speed(10.0, 1.5) == pytest.approx(10.0 * 0.6)
    assert search.next_speed(10.0, None) is None  # it depends on the overrun


def test_a_path_that_fits_at_the_start_is_planned_again_faster() -> None:
    search = _Search(10.0, raises=True)
    search.record(10.0, _Fit(1.0))  # type: ignore[arg-type]
    assert search.next_speed(10.0, 0.8) == pytest.approx(12.5)


def test_px4s_search_plans_no_faster_than_the_start() -> None:
    search = _Search(10.0, raises=False)
    search.record(10.0, _Fit(1.0))  # type: ignore[arg-type]
    assert search.next_speed(10.0, 0.8) is None


def test_a_probes_search_ends_at_the_first_speed_that_fits_without_bisecting() -> None:
    search = _Search(10.0, raises=False, first_fit=True)
    search.record(10.0, None)
    search.record(6.0, _Fit(1.0))  # type: ignore[arg-type]
    assert search.next_speed(6.0, 0.9) is None


@pytest.mark.parametrize("raises", [True, False])  # PX4's search too
def test_between_a_fit_and_an_overrun_the_search_bisects(raises: bool) -> None:
    search = _Search(10.0, raises=raises)
    search.record(10.0, None)
    search.record(6.0, _Fit(1.0))  # type: ignore[arg-type]
    assert search.next_speed(6.0, 0.9) == pytest.approx(8.0)


def test_another_start_that_fits_where_the_own_overruns_is_clearly_better() -> None:
    assert _clearly_better((_Fit(1.0), 1.2), (None, 1.1))  # type: ignore[arg-type]
    assert not _clearly_better((None, 1.0), (_Fit(1.0), 1.2))  # type: ignore[arg-type]


def test_another_start_that_fits_is_clearly_better_only_by_the_margin() -> None:
    margin = 1 + flyable.START_MARGIN
    assert _clearly_better((_Fit(margin + 1e-9), 1.0), (_Fit(1.0), 1.0))  # type: ignore[arg-type]
    assert not _clearly_better((_Fit(margin - 1e-9), 1.0), (_Fit(1.0), 1.0))  # type: ignore[arg-type]


def test_where_neither_start_fits_the_shorter_moves_are_clearly_better_by_the_margin() -> None:
    margin = 1 - flyable.START_MARGIN
    assert _clearly_better((None, 1.1 * margin - 1e-9), (None, 1.1))
    assert not _clearly_better((None, 1.1 * margin + 1e-9), (None, 1.1))


@pytest.mark.parametrize("options", [PlannerOptions(start_schedules=("nearest", "shares")),
                                     PlannerOptions(first_fit=True)])
def test_no_start_is_chosen_with_two_starts_or_for_a_plan_only_looked_at(
    options: PlannerOptions
) -> None:
    site = random_site(2, slots=24)
    assert flyable._still_start(site, "proposed", options, 5.0) == (options, None)


def test_a_guess_is_exactly_the_speed_the_search_tries_after_the_guessed_outcome() -> None:
    # Random searches (fits and overruns drawn at random, PX4's rule on some): wherever the
    # outcome is the one a guess assumed, the guess is the very float the search tries next.
    checked = 0
    for seed in range(50):
        rng = np.random.default_rng(seed)
        search = _Search(10.0, raises=seed % 5 != 0, first_fit=seed % 7 == 0)
        speed: float | None = 10.0
        while speed is not None:
            guess = search.likely_next(speed)
            fits = bool(rng.random() < 0.4)
            overrun = float(rng.uniform(0.6, 0.99) if fits else rng.uniform(1.01, 1.8))
            assumed_fit = search.fits_at is None  # the outcome a guess assumes
            search.record(speed, _Fit(float(rng.random())) if fits else None)  # type: ignore[arg-type]
            after = search.next_speed(speed, overrun)
            if fits == assumed_fit:
                assert guess == after
                checked += int(after is not None)
            speed = after if len(search.tried) < 8 else None
    assert checked > 30


def _counting(calls: list[float], started: threading.Event | None = None) -> Any:
    def evaluate(speed: float, progress: Any) -> tuple[Any, float]:
        calls.append(speed)
        if started is not None and threading.current_thread() is not threading.main_thread():
            started.set()
            for i in range(2000):  # an Algorithm 1 that reports every iteration
                progress(i, 0.0)
                threading.Event().wait(0.001)
        return None, speed

    return evaluate


def test_a_guess_the_search_asks_for_is_not_run_twice() -> None:
    calls: list[float] = []
    with _Ahead(_counting(calls), enabled=True) as ahead:
        ahead.guess(7.0)
        ahead.run(9.0, None)
        ahead.keep_only(7.0)
        assert ahead.run(7.0, None) == (None, 7.0)
    assert sorted(calls) == [7.0, 9.0]


def test_a_guess_the_search_does_not_need_is_cancelled() -> None:
    calls: list[float] = []
    started = threading.Event()
    with _Ahead(_counting(calls, started), enabled=True) as ahead:
        ahead.guess(7.0)
        assert started.wait(5.0)
        pending = ahead._guess
        assert pending is not None
        ahead.keep_only(8.0)
        with pytest.raises(_Cancelled):
            pending[1].result(timeout=5.0)


def test_disabled_nothing_runs_ahead() -> None:
    calls: list[float] = []
    with _Ahead(_counting(calls), enabled=False) as ahead:
        ahead.guess(7.0)
        ahead.run(9.0, None)
    assert calls == [9.0]


def test_running_ahead_gives_the_same_vehicle_plan(monkeypatch: pytest.MonkeyPatch) -> None:
    site = random_site(2, slots=24)  # a search of several candidates, guesses used and not
    monkeypatch.setattr(flyable, "_spare_core", lambda: True)  # even on a busy test machine
    ran_ahead: list[float] = []
    retimed = flyable._retimed

    def spy(site: Any, scheme: str, speed: float, opt: Any, progress: Any) -> Any:
        if threading.current_thread() is not threading.main_thread():
            ran_ahead.append(speed)
        return retimed(site, scheme, speed, opt, progress)

    monkeypatch.setattr(flyable, "_retimed", spy)
    ahead = plan(site, "proposed", options=PlannerOptions())
    assert ran_ahead  # the spare thread did run candidates
    alone = plan(site, "proposed", options=replace(PlannerOptions(), search_ahead=False))
    assert ahead.timing is not None and ahead.timing.speeds_tried >= 3
    assert np.array_equal(ahead.trajectory_m, alone.trajectory_m)
    assert np.array_equal(ahead.delta_s, alone.delta_s)
    assert np.array_equal(ahead.power_w, alone.power_w)


@pytest.mark.parametrize(("cpus", "load", "spare"), [(2, 0.3, True), (2, 1.0, True),
                                                     (2, 1.7, False), (1, 0.0, False),
                                                     (8, 7.4, True), (8, 7.8, False)])
def test_a_guess_runs_only_while_a_core_is_idle(monkeypatch: pytest.MonkeyPatch, cpus: int,
                                                 load: float, spare: bool) -> None:
    monkeypatch.setattr(flyable.os, "cpu_count", lambda: cpus)
    monkeypatch.setattr(flyable.os, "getloadavg", lambda: (load, load, load))
    assert flyable._spare_core() is spare
