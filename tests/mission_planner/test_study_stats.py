"""The Fig. 4 mean interval respects the data: never below zero, reproducible."""

from __future__ import annotations

import math

import numpy as np

from mission_planner.study.stats import mean_interval


def test_interval_of_a_sample_with_outages_stays_non_negative() -> None:
    # Spectral efficiency of a conventional-scheme point: zero on each outage. The Student t
    # interval of this sample is about [-0.31, 1.45].
    se = [0.0, 0.0, 0.0, 0.0, 0.0, 2.3, 2.1, 0.0]
    low, high = mean_interval(se)
    assert 0.0 <= low < float(np.mean(se)) < high <= max(se)


def test_interval_of_all_outages_is_zero() -> None:
    assert mean_interval([0.0] * 6) == (0.0, 0.0)


def test_interval_is_reproducible() -> None:
    values = list(np.random.default_rng(3).exponential(size=40))
    assert mean_interval(values) == mean_interval(values)


def test_interval_covers_the_mean_like_a_t_interval_on_normal_data() -> None:
    values = list(np.random.default_rng(4).normal(5.0, 1.0, size=200))
    low, high = mean_interval(values)
    half_t = 1.97 * float(np.std(values, ddof=1)) / math.sqrt(len(values))
    assert abs((high - low) / 2 - half_t) < 0.15 * half_t
