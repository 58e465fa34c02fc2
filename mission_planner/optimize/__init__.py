"""The paper's optimiser: Algorithm 1 with (P1-2) scheduling, (P2) power, (P3-2) trajectory.

``plan`` and ``PlannerOptions`` load lazily: code that only reads a :class:`Solution` (mission
export, reports) needs neither Clarabel nor the subproblems (cvxpy only in the test oracles).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mission_planner.optimize.solution import SCHEMES, Solution

if TYPE_CHECKING:
    from mission_planner.optimize.bcd import PAPER_OPTIONS, PlannerOptions
    from mission_planner.optimize.planner import plan

__all__ = ["PAPER_OPTIONS", "SCHEMES", "PlannerOptions", "Solution", "plan"]


def __getattr__(name: str) -> Any:
    if name == "plan":
        from mission_planner.optimize.planner import plan

        return plan
    if name in ("PlannerOptions", "PAPER_OPTIONS"):
        from mission_planner.optimize import bcd

        return getattr(bcd, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
