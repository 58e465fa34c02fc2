"""Confidence intervals for Monte-Carlo estimates (scipy.stats, already required by cvxpy)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from scipy import stats

CONFIDENCE = 0.95


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
    """Student-t interval of a mean; (nan, nan) for fewer than two values."""
    n = len(values)
    if n < 2:
        return (math.nan, math.nan)
    mean = math.fsum(values) / n
    sd = math.sqrt(math.fsum((v - mean) ** 2 for v in values) / (n - 1))
    half = float(stats.t.ppf(0.5 + confidence / 2.0, n - 1)) * sd / math.sqrt(n)
    return (mean - half, mean + half)
