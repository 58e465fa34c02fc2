"""The numpy-assembled sparse matrix handed to Clarabel equals scipy's for the same entries."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from mission_planner.optimize.conic import Csc


def _both(rows, cols, vals, shape):
    ours = Csc.from_entries(np.asarray(rows), np.asarray(cols), np.asarray(vals, float), shape)
    theirs = sp.csc_matrix((vals, (rows, cols)), shape=shape)
    return ours, theirs


def test_random_entries_match_scipy_csc():
    rng = np.random.default_rng(3)
    rows, cols = rng.integers(0, 40, 500), rng.integers(0, 25, 500)
    ours, theirs = _both(rows, cols, rng.normal(size=500), (40, 25))
    np.testing.assert_array_equal(ours.indptr, theirs.indptr)
    np.testing.assert_array_equal(ours.indices, theirs.indices)
    # three or more repeats of one entry may be summed in another order: an ulp apart
    np.testing.assert_allclose(ours.data, theirs.data, rtol=1e-15, atol=1e-15)


def test_repeated_entries_are_summed():
    ours, _ = _both([1, 1, 0], [2, 2, 2], [1.5, 2.0, 4.0], (3, 3))
    assert ours.data.tolist() == [4.0, 3.5]
    assert ours.indices.tolist() == [0, 1]


def test_empty_columns_keep_their_pointer():
    ours, _ = _both([0], [2], [1.0], (1, 4))
    assert ours.indptr.tolist() == [0, 0, 0, 1, 1]


def test_no_entries_give_an_empty_matrix():
    ours, _ = _both(np.zeros(0, int), np.zeros(0, int), [], (2, 3))
    assert ours.indptr.tolist() == [0, 0, 0, 0]
    assert ours.data.size == 0
