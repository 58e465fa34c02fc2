"""Exact leg/circle geometry and Theorem 1 of the paper."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from validator.geometry import (
    expanded_radius,
    leg_clearances,
    min_leg_clearance,
    segment_point_distance,
    theorem1_lower_bound,
)


def test_distance_to_a_segment_uses_the_interior_point() -> None:
    assert segment_point_distance([0, 0], [10, 0], [5, 3]) == 3.0


def test_distance_to_a_segment_uses_the_nearer_end() -> None:
    assert segment_point_distance([0, 0], [10, 0], [13, 4]) == 5.0


def test_zero_length_segment_is_a_point() -> None:
    assert segment_point_distance([1, 1], [1, 1], [4, 5]) == 5.0


def test_leg_clearance_is_negative_inside() -> None:
    c = leg_clearances(
        np.array([[-50.0, 5.0], [50.0, 5.0]]), np.array([[0.0, 0.0]]), np.array([30.0])
    )
    assert c.shape == (1, 1)
    assert math.isclose(c[0, 0], -25.0)


def test_min_leg_clearance_without_zones_is_infinite() -> None:
    assert min_leg_clearance(np.zeros((3, 2)), np.zeros((0, 2)), np.zeros(0)) == math.inf


@settings(max_examples=500, deadline=None)
@given(
    radius=st.floats(1.0, 100.0),
    limit_frac=st.floats(0.0, 3.0),
    used_frac=st.floats(0.0, 1.0),
    a_ang=st.floats(0, 2 * math.pi),
    a_out=st.floats(1.0, 2.0),
    heading=st.floats(0, 2 * math.pi),
)
def test_theorem1_segment_never_enters_the_zone(
    radius: float, limit_frac: float, used_frac: float, a_ang: float, a_out: float, heading: float
) -> None:
    """A segment of length ≤ L whose ends lie outside √(R² + (L/2)²) stays ≥ R from the centre."""
    limit = limit_frac * radius  # L, the longest leg allowed
    r_exp = float(expanded_radius(radius, limit))
    a = r_exp * a_out * np.array([math.cos(a_ang), math.sin(a_ang)])
    b = a + used_frac * limit * np.array([math.cos(heading), math.sin(heading)])
    assume(float(np.hypot(*b)) >= r_exp)
    assert segment_point_distance(a, b, [0.0, 0.0]) >= radius * (1 - 1e-9)


@given(radius=st.floats(1.0, 100.0), frac=st.floats(0.01, 1.0))
def test_theorem1_bound_is_tight(radius: float, frac: float) -> None:
    """The chord of length L of the expanded circle passes exactly R from the centre."""
    length = frac * 2 * radius
    r_exp = float(expanded_radius(radius, length))
    h = math.sqrt(r_exp**2 - (length / 2) ** 2)
    a, b = np.array([-length / 2, h]), np.array([length / 2, h])
    assert math.isclose(float(np.hypot(*a)), r_exp)
    assert math.isclose(float(segment_point_distance(a, b, [0, 0])), radius, rel_tol=1e-9)
    assert math.isclose(float(theorem1_lower_bound(r_exp, length)), radius, rel_tol=1e-9)


def test_point_only_constraint_is_not_enough() -> None:
    """Ends outside R (constraint 5) but a leg through the zone: the paper's Fig. 2a."""
    a, b = np.array([-31.0, 0.0]), np.array([31.0, 0.0])
    assert np.hypot(*a) >= 30 and np.hypot(*b) >= 30
    assert segment_point_distance(a, b, [0, 0]) == 0.0
