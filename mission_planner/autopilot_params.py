"""The autopilot parameters a mission needs to be flown as planned, and their file formats.

The paper's model knows only a top speed; an autopilot also limits acceleration and jerk and
rounds corners inside its waypoint radius. :func:`recommended_params` turns a mission and its
site into the parameters that make the vehicle fly the plan with the site's limits:

ArduCopter (names, units and documented ranges: :mod:`validator.autopilot.ardupilot`)

- ``WPNAV_SPEED``: the fastest planned leg (the largest DO_CHANGE_SPEED in the plan) or the
  vehicle's real top speed (:func:`validator.motion.speed_model.top_speed_mps`,
  lean-limited with drag), whichever is lower: the speed the vehicle will reach. Rounded up to
  a whole cm/s, so a leg without a speed change is never flown slower;
- ``WPNAV_ACCEL``: the site's ``uav.max_accel``; ``WPNAV_JERK``: its ``uav.max_jerk``;
- ``WPNAV_RADIUS``: :func:`waypoint_radius_m`;
- ``WP_YAW_BEHAVIOR``: 2, facing the next waypoint, as the wind's timing takes it
  (:data:`validator.motion.arducopter_speed.PLAN_YAW_BEHAVIOR`): ArduCopter's default, set so
  that a vehicle configured otherwise flies the yaw the plan was timed with.

PX4 (:mod:`validator.autopilot.px4`)

- ``MPC_XY_CRUISE`` and ``MPC_XY_VEL_MAX``: the fastest planned leg or the vehicle's top
  speed, whichever is lower (PX4 caps every mission speed at MPC_XY_VEL_MAX), rounded up to
  a whole cm/s;
- ``MPC_ACC_HOR``: ``uav.max_accel``; ``MPC_JERK_AUTO``: ``uav.max_jerk``;
- ``NAV_ACC_RAD``: :func:`waypoint_radius_m`.

Both: every failsafe set to an action that never flies a path the audit has not proven clear
(:mod:`validator.autopilot.failsafe`: ArduCopter retraces its flown path with SmartRTL or lands
in place, SRTL_POINTS sized for the whole mission by
:func:`validator.failsafe.smartrtl_points_needed` within its documented range; PX4 holds or
lands in place), and the geofence switched on with a breach action that never flies straight
across another zone (:mod:`validator.autopilot.fence`: ArduCopter FENCE_TYPE 4, FENCE_ACTION 5
SmartRTL or Land, FENCE_ENABLE 1, written last so it is set after the others; PX4 GF_ACTION 2
Hold).

A value outside the documented range is still written (the plan needs it) and listed in
``notes``, so the operator can check that the vehicle accepts it.

:func:`dumps_params` writes them as an ArduPilot ``.param`` file (``NAME VALUE`` per line, as
Mission Planner and MAVProxy load) or, for PX4, as a QGroundControl parameter file
(``SYSID COMPID NAME VALUE TYPE``, tab-separated; :mod:`validator.autopilot.param_file`);
``#`` lines are comments in both, and ``upload-mission --params`` reads both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from mission_planner.mission import Mission
from mission_planner.mission.options import waypoint_radius_m
from validator.autopilot.failsafe import recommended_failsafes
from validator.autopilot.fence import FENCE_RULES
from validator.autopilot.param_file import format_params
from validator.autopilot.tables import param_table, range_notes
from validator.autopilot.waypoint_radius import radius_params
from validator.failsafe import smartrtl_points_needed
from validator.flight import resolve_flight
from validator.motion.arducopter_speed import PLAN_YAW_BEHAVIOR
from validator.motion.speed_model import top_speed_mps
from validator.plan_format import Cmd


@dataclass(frozen=True)
class AutopilotParams:
    """Parameters for one autopilot, in its own names and units (see the module doc).

    ``notes`` lists each value outside the autopilot's documented range.
    """

    autopilot: str
    values: dict[str, float]
    notes: tuple[str, ...] = field(default=())

    def unit(self, name: str) -> str:
        return param_table(self.autopilot)[name].unit

    def as_dict(self) -> dict[str, object]:
        return {
            "autopilot": self.autopilot,
            "values": dict(self.values),
            "units": {n: self.unit(n) for n in self.values},
            "notes": list(self.notes),
        }


def fastest_leg_mps(mission: Mission) -> float:
    """The fastest speed (m/s) the mission commands (DO_CHANGE_SPEED, transits included)."""
    speeds = [it.params[1] for it in mission.plan.items if it.command == Cmd.DO_CHANGE_SPEED]
    return float(max(speeds, default=mission.plan.cruise_speed_mps))


def _ceil(value: float, step: float) -> float:
    # Round up to the file's resolution, ignoring float noise just above a step.
    return math.ceil(value / step - 1e-9) * step


def recommended_params(mission: Mission) -> AutopilotParams:
    """The parameters ``mission`` needs on its autopilot (``mission.options.autopilot``)."""
    site = mission.solution.site
    autopilot = mission.options.autopilot
    speed = min(fastest_leg_mps(mission), top_speed_mps(site, autopilot))
    table = param_table(autopilot)
    if autopilot == "px4":
        values = {
            "MPC_XY_CRUISE": round(_ceil(speed, 0.01), 2),
            "MPC_XY_VEL_MAX": round(_ceil(speed, 0.01), 2),
            "MPC_ACC_HOR": site.max_accel_mps2,
            "MPC_JERK_AUTO": site.max_jerk_mps3,
        }
    else:
        values = {
            "WPNAV_SPEED": _ceil(table["WPNAV_SPEED"].from_si(speed), 1.0),
            "WPNAV_ACCEL": round(table["WPNAV_ACCEL"].from_si(site.max_accel_mps2), 6),
            "WPNAV_JERK": table["WPNAV_JERK"].from_si(site.max_jerk_mps3),
            "WP_YAW_BEHAVIOR": PLAN_YAW_BEHAVIOR,
        }
    values.update(radius_params(site, autopilot, mission.fence_margin_m))
    srtl = None
    if autopilot == "ardupilot":
        srtl_spec = table["SRTL_POINTS"]
        need = smartrtl_points_needed(resolve_flight(mission.plan, site, "mission"))
        srtl = float(min(max(need, srtl_spec.default), srtl_spec.maximum))
    values.update(recommended_failsafes(autopilot, srtl))
    values.update(FENCE_RULES[autopilot].recommended)
    return AutopilotParams(autopilot, values, range_notes(autopilot, values))


def dumps_params(params: AutopilotParams, title: str = "") -> str:
    """The parameter file text (:func:`validator.autopilot.param_file.format_params`), with
    ``#`` comments naming the title, units and notes."""
    comments = [title] if title else []
    comments.append(", ".join(f"{n} in {params.unit(n)}" for n in params.values))
    comments += [f"note: {note}" for note in params.notes]
    table = param_table(params.autopilot)
    types = {n: table[n].mav_type for n in params.values}
    return format_params(params.values, params.autopilot, comments, types)


__all__ = [
    "AutopilotParams",
    "dumps_params",
    "fastest_leg_mps",
    "recommended_params",
    "waypoint_radius_m",
]
