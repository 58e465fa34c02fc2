"""Douglas-Peucker with a veto: a polyline's wiggles straightened where a chord may stand."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from validator.geometry import segment_point_distance


def douglas_peucker(pts: NDArray[np.float64], tolerance_m: float,
                    keeps: Callable[[int, int], bool],
                    tightest: Callable[[int, int], int]) -> list[int]:
    """Indices of the polyline ``pts`` (P, 2) kept by Douglas-Peucker within ``tolerance_m``,
    where a chord i→j also replaces the points between only if ``keeps(i, j)`` (here: no
    closer to a zone than they were); a chord refused for that alone is split at
    ``tightest(i, j)`` (the point between them closest to a zone), not at the farthest one.
    Deciding chord by chord lets a stretch far from every zone lose its wiggles while one
    hugging a zone keeps its vertices (a whole-path check would keep them all)."""
    last = len(pts) - 1
    kept = {0, last}
    todo = [(0, last)]
    while todo:
        i, j = todo.pop()
        if j <= i + 1:
            continue
        off = segment_point_distance(pts[i], pts[j], pts[i + 1:j])
        k = i + 1 + int(np.argmax(off))
        if float(off[k - i - 1]) <= tolerance_m:
            if keeps(i, j):
                continue
            k = tightest(i, j)
        kept.add(k)
        todo += [(i, k), (k, j)]
    return sorted(kept)
