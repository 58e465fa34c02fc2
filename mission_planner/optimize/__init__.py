"""The paper's optimiser: Algorithm 1 with (P1-2) scheduling, (P2) power, (P3-2) trajectory."""

from mission_planner.optimize.bcd import PlannerOptions, plan
from mission_planner.optimize.solution import SCHEMES, Solution

__all__ = ["SCHEMES", "PlannerOptions", "Solution", "plan"]
