"""A slower candidate speed starts from the last candidate's path, re-timed to stay feasible."""

from __future__ import annotations

import numpy as np
import pytest

from mission_planner.optimize import bcd
from mission_planner.optimize.initial import initial_tour
from mission_planner.optimize.scaled import scale_site
from mission_planner.optimize.trajectory import MIN_SLOT
from mission_planner.study.sites import random_site


def _start(seed: int, speed_mps: float) -> tuple[bcd._State, bcd.Scaled, bcd.Scaled]:
    site = random_site(seed)
    fast = scale_site(site, 0.02)
    slow = scale_site(site.with_limits(max_speed_mps=speed_mps), 0.02)
    q, delta = initial_tour(fast)
    prev = bcd._State(q, delta, bcd._initial_schedule(fast, q), np.ones(fast.num_slots))
    return prev, fast, slow


@pytest.mark.parametrize("seed", [0, 3, 7])
def test_slowed_path_is_feasible_at_the_lower_speed(seed: int) -> None:
    prev, fast, slow = _start(seed, 21.0)
    start = bcd._slowed(slow, prev)
    assert start is not None
    n = slow.num_slots
    legs = np.linalg.norm(start.q - np.roll(start.q, 1, axis=0), axis=1)
    assert np.all(legs <= slow.speed * start.delta + 1e-9)  # (1) at the new top speed
    assert np.sum(start.delta) == pytest.approx(n)
    assert np.all(start.delta >= MIN_SLOT - 1e-12)
    np.testing.assert_array_equal(start.q, prev.q)  # the same path, only re-timed
    # (6-1): no slot's Ṽδ̃ grows, so both ends of each leg stay as clear as before.
    assert np.all(slow.speed * start.delta <= np.maximum(fast.speed * prev.delta, legs) + 1e-9)


def test_slowed_path_is_refused_when_the_hovers_cannot_pay() -> None:
    prev, _, slow = _start(0, 1.0)  # far too slow to fly the tour's legs within T
    assert bcd._slowed(slow, prev) is None
