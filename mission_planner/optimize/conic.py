"""Solving a built cvxpy problem with Clarabel, robustly.

Clarabel occasionally stops with "InsufficientProgress" on these nearly degenerate SCA
subproblems (e.g. when Σδ = T and an active power budget are almost parallel). The same problem
then solves with a shorter interior-point step or without equilibration, so those are tried in
turn before a step is given up.
"""

from __future__ import annotations

from typing import Any

import cvxpy as cp

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
            problem.solve(solver=cp.CLARABEL, **settings)
        except cp.SolverError:
            continue
        if problem.status in _ACCEPTED:
            return True
    return False
