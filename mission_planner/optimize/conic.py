"""Solving a built cvxpy problem with Clarabel, robustly.

Clarabel occasionally stops with "InsufficientProgress" on these nearly degenerate SCA
subproblems (e.g. when Σδ = T and an active power budget are almost parallel). The same problem
then solves with a shorter interior-point step or without equilibration, so those are tried in
turn before a step is given up.
"""

from __future__ import annotations

import warnings
from typing import Any

import cvxpy as cp

# An SCA step needs no more than 1e-7: the exact objective judges it afterwards, and NFZ
# constraints carry a 2 cm margin. (Clarabel's default 1e-8 costs ~10 % more iterations.)
_TOLERANCE: dict[str, Any] = {"tol_gap_abs": 1e-7, "tol_gap_rel": 1e-7, "tol_feas": 1e-7}
_ATTEMPTS: tuple[dict[str, Any], ...] = (
    {},
    {"max_step_fraction": 0.9},
    {"equilibrate_enable": False},
    {"max_step_fraction": 0.8, "equilibrate_enable": False},
)
_ACCEPTED = (cp.OPTIMAL, cp.OPTIMAL_INACCURATE)


def solve(problem: cp.Problem) -> bool:
    """Solve ``problem`` with Clarabel; True when a (possibly inaccurate) optimum was found."""
    for settings in _ATTEMPTS:
        try:
            with warnings.catch_warnings():
                # The status is judged below; cvxpy's "may be inaccurate" warning adds nothing.
                warnings.simplefilter("ignore", UserWarning)
                # warm_start=False: cvxpy would otherwise update the previous Clarabel instance
                # in place, whose results then depend on what it solved before.
                problem.solve(solver=cp.CLARABEL, warm_start=False, **_TOLERANCE, **settings)
        except cp.SolverError:
            continue
        if problem.status in _ACCEPTED:
            return True
    return False
