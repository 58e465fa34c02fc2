"""Base layer: site files, geometry, plan formats, flight model, audit and MAVLink.

Nothing here imports :mod:`mission_planner`, so the auditor can judge plans from any source.

The front door is :mod:`validator.api`; its names are importable from here
(``from validator import load_site, audit_plan``), loaded on first use so that importing one
module of the package (as every command does) does not load them all.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from validator.api import (
        Flown,
        Replayed,
        VehicleChoice,
        Wind,
        audit_plan,
        choose_vehicle,
        flight_profile,
        fly_plan,
        load_site,
        read_plan,
        replay_plan,
        score_recorded,
        write_track,
    )

__all__ = ["Flown", "Replayed", "VehicleChoice", "Wind", "audit_plan", "choose_vehicle",
           "flight_profile", "fly_plan", "load_site", "read_plan", "replay_plan", "score_recorded",
           "write_track"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        return getattr(importlib.import_module("validator.api"), name)
    raise AttributeError(f"module 'validator' has no attribute {name!r}")
