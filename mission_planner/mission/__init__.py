"""A planned service cycle turned into an autopilot-ready mission.

:func:`build_mission` takes a :class:`~mission_planner.optimize.solution.Solution` and lays
out a QGroundControl :class:`~validator.plan_format.Plan`:

1. NAV_TAKEOFF at home to the site altitude (relative-altitude frame 3);
2. DO_CHANGE_SPEED to the transit speed and the outbound transit: the shortest path from home
   to q[0] whose straight legs keep out of every NFZ plus its buffer (:mod:`.clearance`,
   :mod:`mission_planner.transit`);
3. one service cycle: for each slot n a DO_CHANGE_SPEED (param1 = 1, param2 = leg length /
   δ[n] m/s) where the speed changes and a NAV_WAYPOINT at q[n]. Slots in which the UAV stays
   put (within ``stationary_tol_m``) merge into the waypoint before them, whose hold is their
   δ sum; slots at the start of the cycle in which it stays put become a hold at q[0];
   consecutive slots on one straight line at one speed become one waypoint
   (:func:`merge_straight_steps`), so waypoints stand only where the path turns or the speed
   changes: fewer corners for the autopilot to round off and fewer rest-to-rest legs;
4. DO_JUMP back to the cycle's first item ``cycles − 1`` times;
5. DO_CHANGE_SPEED to the transit speed, the return transit, NAV_LAND at home. Never RTL:
   it flies straight home whatever lies between.

The geofence holds one exclusion circle per NFZ (radius R + fence margin), optionally an
inclusion polygon or circle around everything the vehicle flies, the breach return point and
one rally point at home. What fails the safety gate is listed in ``Mission.problems``
(plan-mission's refusal).

One idea a module, each documenting the decisions it makes where autopilots and the plan
disagree (all set in :class:`MissionOptions`):

- :mod:`.options`: the options, their checks, the autopilots served;
- :mod:`.steps`: slots grouped into waypoints and holds, straight runs merged into long legs;
- :mod:`.clearance`: legs kept clear after MAVLink's rounding (nudges, transits);
- :mod:`.speeds`: leg speeds and holds as the autopilot takes them (speed limit, slow legs,
  stop lag, whole-second holds);
- :mod:`.fence`: the geofence; :mod:`.build`: the items, in order, and :class:`Mission`;
- :mod:`.gate`: the safety gate; :mod:`.readback`: the plan as the vehicle gets it, resolved by
  the validator;
- :mod:`.summary`: the mission part of the report.
"""

from mission_planner.mission.build import Mission, build_mission
from mission_planner.mission.clearance import nudge_clear, safe_transits
from mission_planner.mission.fence import Geofence, operating_area
from mission_planner.mission.gate import CLEARANCE_TOLERANCE_M, plan_problems
from mission_planner.mission.options import (
    AUTOPILOTS,
    OPERATING_AREAS,
    MissionOptions,
    check_options,
    fence_margin_for,
)
from mission_planner.mission.readback import as_received, flown_legs, planned_cycle_s
from mission_planner.mission.speeds import (
    SPEED_EXCESS_ALLOWED,
    assign_speeds,
    stop_lags,
)
from mission_planner.mission.steps import (
    CycleStep,
    merge_straight_steps,
    place_on_legs,
    scurve_legs,
    service_steps,
)
from mission_planner.mission.summary import cycle_duration_s, mission_summary
from validator.autopilot.rules import whole_second_holds
from validator.plan_format import EXTRA_KEY

__all__ = [
    "AUTOPILOTS",
    "CLEARANCE_TOLERANCE_M",
    "EXTRA_KEY",
    "Geofence",
    "OPERATING_AREAS",
    "SPEED_EXCESS_ALLOWED",
    "CycleStep",
    "Mission",
    "MissionOptions",
    "as_received",
    "assign_speeds",
    "build_mission",
    "check_options",
    "cycle_duration_s",
    "fence_margin_for",
    "flown_legs",
    "merge_straight_steps",
    "mission_summary",
    "nudge_clear",
    "operating_area",
    "place_on_legs",
    "plan_problems",
    "planned_cycle_s",
    "safe_transits",
    "scurve_legs",
    "service_steps",
    "stop_lags",
    "whole_second_holds",
]
