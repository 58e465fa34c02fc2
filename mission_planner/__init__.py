"""Mission planning by optimisation: the paper's BCD optimiser, mission construction, studies.

Builds on :mod:`validator` (site files, geometry, plan formats); never imported by it.

The front door is :mod:`mission_planner.api`; its names are importable from here
(``from mission_planner import load_site, plan_mission``), loaded on first use so that a
command importing one module does not load them all.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mission_planner.api import (
        AutopilotParams,
        FlightCheck,
        Flown,
        Mission,
        MissionOptions,
        Replayed,
        Solution,
        UnsafeMission,
        VehicleChoice,
        Wind,
        Written,
        audit_plan,
        build_mission,
        choose_vehicle,
        fly_plan,
        load_site,
        plan_mission,
        plan_solution,
        read_plan,
        recommended_params,
        replay_mission,
        replay_plan,
        score_recorded,
        write_mission,
        write_track,
    )

__all__ = [
    "AutopilotParams", "FlightCheck", "Flown", "Mission", "MissionOptions", "Replayed",
    "Solution", "UnsafeMission", "VehicleChoice", "Wind", "Written", "audit_plan",
    "build_mission", "choose_vehicle", "fly_plan", "load_site", "plan_mission", "plan_solution",
    "read_plan", "recommended_params", "replay_mission", "replay_plan", "score_recorded",
    "write_mission", "write_track",
]


def __getattr__(name: str) -> Any:
    if name in __all__:
        return getattr(importlib.import_module("mission_planner.api"), name)
    raise AttributeError(f"module 'mission_planner' has no attribute {name!r}")
