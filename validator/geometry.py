"""Exact plane geometry of straight legs and circular no-fly zones.

Positions are metres in a local east/north frame; arrays of points are (..., 2).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def segment_point_distance(a: ArrayLike, b: ArrayLike, c: ArrayLike) -> NDArray[np.float64]:
    """Minimum distance (m) from points ``c`` to straight segments ``a``→``b``.

    Broadcasts: ``a``, ``b`` (..., 2) against ``c`` (..., 2). A zero-length segment is a point.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c = np.asarray(c, dtype=float)
    ab = b - a
    ac = c - a
    den = np.sum(ab * ab, axis=-1)
    t = np.divide(
        np.sum(ac * ab, axis=-1),
        den,
        out=np.zeros(np.broadcast(den, ac[..., 0]).shape),
        where=den > 0,
    )
    t = np.clip(t, 0.0, 1.0)
    closest = a + t[..., None] * ab
    return np.asarray(np.linalg.norm(c - closest, axis=-1), dtype=float)


def segment_point_closest_fraction(a: ArrayLike, b: ArrayLike, c: ArrayLike) -> NDArray[np.float64]:
    """Fraction t in [0, 1] along ``a``→``b`` of the point closest to ``c``."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c = np.asarray(c, dtype=float)
    ab = b - a
    den = np.sum(ab * ab, axis=-1)
    num = np.sum((c - a) * ab, axis=-1)
    t = np.divide(num, den, out=np.zeros(np.broadcast(den, num).shape), where=den > 0)
    return np.asarray(np.clip(t, 0.0, 1.0), dtype=float)


def leg_clearances(
    path_m: ArrayLike, centres_m: ArrayLike, radii_m: ArrayLike
) -> NDArray[np.float64]:
    """Clearance (m) of every straight leg of a polyline from every circle.

    ``path_m`` is (P, 2) with P >= 2, ``centres_m`` (M, 2), ``radii_m`` (M,). Returns (P-1, M):
    distance from the leg to the centre minus the radius; negative means the leg enters the zone.
    """
    path = np.asarray(path_m, dtype=float)
    centres = np.asarray(centres_m, dtype=float).reshape(-1, 2)
    radii = np.asarray(radii_m, dtype=float).reshape(-1)
    d = segment_point_distance(path[:-1, None, :], path[1:, None, :], centres[None, :, :])
    return np.asarray(d - radii[None, :], dtype=float)


def min_leg_clearance(path_m: ArrayLike, centres_m: ArrayLike, radii_m: ArrayLike) -> float:
    """Smallest clearance (m) of any leg of a polyline from any circle; +inf with no circles."""
    if np.asarray(radii_m).size == 0 or np.asarray(path_m).shape[0] < 2:
        return float("inf")
    return float(np.min(leg_clearances(path_m, centres_m, radii_m)))


def expanded_radius(radius_m: ArrayLike, leg_length_m: ArrayLike) -> NDArray[np.float64]:
    """The paper's expanded NFZ radius sqrt(R² + (L/2)²) (eq. 6) for legs of length ≤ L.

    By Theorem 1, a segment of length ≤ L whose end points both lie at least this far from the
    centre never comes closer than R to it.
    """
    r = np.asarray(radius_m, dtype=float)
    half = np.asarray(leg_length_m, dtype=float) / 2.0
    return np.asarray(np.sqrt(r * r + half * half), dtype=float)


def theorem1_lower_bound(
    expanded_radius_m: ArrayLike, leg_length_m: ArrayLike
) -> NDArray[np.float64]:
    """Theorem 1: distance bound sqrt(R_B² − (L/2)²) from the centre for L ≤ 2 R_B."""
    rb = np.asarray(expanded_radius_m, dtype=float)
    half = np.asarray(leg_length_m, dtype=float) / 2.0
    return np.asarray(np.sqrt(np.maximum(rb * rb - half * half, 0.0)), dtype=float)
