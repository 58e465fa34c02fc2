"""Confidence intervals for Monte-Carlo estimates (scipy.stats, already required by cvxpy)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy import stats

CONFIDENCE = 0.95
BOOTSTRAP_RESAMPLES = 9999
BOOTSTRAP_SEED = 0


def proportion_interval(successes: int, trials: int, confidence: float = CONFIDENCE
                        ) -> tuple[float, float]:
    """Wilson score interval of a proportion; (nan, nan) for zero trials.

    Wilson rather than the normal approximation because outage probabilities sit at 0 for the
    proposed scheme, where the normal interval collapses to a point.
    """
    if trials == 0:
        return (math.nan, math.nan)
    ci = stats.binomtest(successes, trials).proportion_ci(confidence, method="wilson")
    return (float(ci.low), float(ci.high))


def mean_interval(values: Sequence[float], confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Bootstrap percentile interval of a mean; (nan, nan) for fewer than two values.

    Percentile rather than Student t because spectral efficiency is zero on every outage: a
    sample of zeros and a few positive rates is far from normal, and the t interval then reaches
    below zero, which no mean of non-negative rates can. A percentile interval lies within the
    data's range. The resampling seed is fixed, so a study's summary is reproducible.
    """
    if len(values) < 2:
        return (math.nan, math.nan)
    sample = np.asarray(values, dtype=float)
    ci = stats.bootstrap(
        (sample,),
        np.mean,
        confidence_level=confidence,
        n_resamples=BOOTSTRAP_RESAMPLES,
        method="percentile",
        random_state=np.random.default_rng(BOOTSTRAP_SEED),
    ).confidence_interval
    return (float(ci.low), float(ci.high))
