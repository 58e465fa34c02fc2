"""A mission plan resolved into what the vehicle will do: legs, speeds, holds, jumps, RTL.

The one interpreter of a plan, shared by the audit, the replay, the exporter's safety gate and
the simulated vehicle:

- :mod:`.resolve`: :func:`resolve_flight` walks the items as ArduCopter executes them (the
  conventions: item numbering, jumps, RTL, loiters, "where the vehicle is");
- :mod:`.model`: what it returns, a :class:`Flight` of straight :class:`Leg` s, each with the
  :class:`Home` in force on it, the service cycle among them (:class:`CycleSpan`) and
  :class:`Finding` s;
- :mod:`.home`: what a mission's DO_SET_HOME does to that home, on ArduCopter and PX4;
- :mod:`.frames`: the frames each autopilot takes a navigation item's position in, and how it
  reads the coordinates there (frame 2: unscaled on the wire);
- :mod:`.service`: the planner's metadata a plan carries (:class:`ServicePlan`,
  :func:`parse_service`);
- :mod:`.bounds`: how long a mission may last (:data:`MAX_MISSION_S`).
"""

from validator.flight.bounds import MAX_MISSION_S
from validator.flight.model import CycleSpan, Finding, Flight, Home, Leg, LegKind, Severity
from validator.flight.resolve import (
    DO_FENCE_ENABLE,
    DO_SET_HOME,
    FOREVER_REPEATS,
    MAX_LEGS,
    PASSIVE_COMMANDS,
    UNSUPPORTED_NAV,
    check_duration,
    resolve_flight,
)
from validator.flight.service import ServicePlan, parse_service

__all__ = [
    "DO_FENCE_ENABLE",
    "DO_SET_HOME",
    "FOREVER_REPEATS",
    "MAX_LEGS",
    "MAX_MISSION_S",
    "PASSIVE_COMMANDS",
    "UNSUPPORTED_NAV",
    "CycleSpan",
    "Finding",
    "Flight",
    "Home",
    "Leg",
    "LegKind",
    "ServicePlan",
    "Severity",
    "check_duration",
    "parse_service",
    "resolve_flight",
]
