"""What a mission's DO_SET_HOME (MAV_CMD_DO_SET_HOME, 179) does to the home a return flies to.

A return, the mission's own NAV_RETURN_TO_LAUNCH as much as a failsafe's RTL or Return, flies
to the home in force when it starts (or to a rally point chosen against that home), so the
resolved flight carries the :class:`~validator.flight.model.Home` in force on each leg: the
plan's home until a DO_SET_HOME moves it, then the new one.

ArduCopter 4.5, as read in ArduPilot's sources (``AP_Mission::advance_current_nav_cmd``,
``ModeAuto::do_set_home``, ``Copter::set_home``, ``AP_AHRS::set_home``,
``ModeRTL::compute_return_target``, ``AP_SmartRTL::set_home``; copies from before 4.5 to
after it, which agree on all of this):

- AP_Mission runs the DO items after a navigation item when that item completes, as it starts
  the next navigation item: the new home is in force for the whole leg to it. A CONDITION_*
  item before it holds it back until the condition is met, or for ever when the next
  navigation item completes first: that is a warning here, and the home is taken as moved at
  the leg's start.
- param1 1, or latitude, longitude and altitude all 0: home becomes where the vehicle is
  (``set_home_to_current_location``); anything else takes the item's location, read as
  degrees x 1e7 in any frame, which MISSION_ITEM_INT carries only in a global frame. A 0°, 0°
  with another altitude is taken as it is (AP_AHRS refuses only all three 0): home moves to
  0°N 0°E. Both are violations here, the home left where it was.
- RTL, as a mode or as the mission's item, builds its path when it starts, to the nearest rally
  point or ``ahrs.get_home()``: the home in force (RALLY_INCL_HOME compares with it too).
- SmartRTL: a DO_SET_HOME at the current position restarts SmartRTL's path there; one at a
  location leaves it retracing to where it began. Either way it flies the flown path, clear
  wherever the mission is, so only a straight return's destination moves.
- "Where the vehicle is" is where the previous waypoint counted as reached: within its radius,
  or on the corner it cuts; taken as the waypoint, the few metres left to the buffer as for
  corners. It is the whole location, altitude included (``ahrs.get_location``): in the air
  home moves up to the vehicle. A location's altitude is made absolute against the home in
  force (``Location::change_alt_frame(ABSOLUTE)``): frame 3 is above it, 0 above sea level.
  Measured on ArduCopter 4.5.6 SITL (a waypoint at 20 m, DO_SET_HOME param1 1, a waypoint at
  20 m above home, RTL): HOME_POSITION moved to where the vehicle cut the corner, 1.7 m from
  the waypoint, at 20 m above the ground, and was sent unasked; GLOBAL_POSITION_INT's
  relative altitude read 0 from there on. The next leg was flown at its old 20 m (the corner
  had queued it against the old home) and the vehicle then hovered at its waypoint for the
  remaining 570 s, never completing it (its destination, re-read above the new home, was 20 m
  higher): so legs keep their altitudes here, above the plan's home. The audit is horizontal
  (zones are walls), so that changes no verdict.

PX4 v1.15 does not ignore it (``MavlinkMissionManager::parse_mavlink_mission_item``,
``MissionBlock::issue_command``, the commander's VEHICLE_CMD_DO_SET_HOME,
``HomePosition::setManually``, copies from around v1.15 and main; Return's destination comes
from the home position the commander publishes):

- it takes DO_SET_HOME only in MAV_FRAME_MISSION (2); in a global frame the upload is refused
  (MAV_MISSION_UNSUPPORTED), a rule of :mod:`validator.flight.frames`, which the resolver
  applies to every item first;
- the mission issues it as a vehicle command when it becomes the active item, and the commander
  applies it (COM_HOME_EN 1, the default): param1 above 0.5 is the current position, as
  ArduCopter's 1;
- otherwise it passes MISSION_ITEM_INT's x and y on unscaled, as degrees: home moves to whole
  degrees (how frame 2 carries them), or nowhere on Earth (sent as degrees x 1e7): a violation
  here, the home left where it was;
- the current position is the global position estimate, altitude included
  (``HomePosition::setHomePosition``, ``fillGlobalHomePos``), as on ArduCopter.

:func:`moved_home` is the rule the resolver and the simulated vehicle both apply.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from validator.flight.frames import AMSL_FRAMES, RELATIVE_FRAMES, unplaced
from validator.flight.model import Home, Severity
from validator.item_lists import GLOBAL_FRAMES
from validator.plan_format import MissionItem
from validator.site import Site
from validator.zones import buffer_intrusion

# CONDITION_DELAY, CONDITION_DISTANCE, CONDITION_YAW: they hold back the DO items after them
CONDITIONS = {112: "CONDITION_DELAY", 114: "CONDITION_DISTANCE", 115: "CONDITION_YAW"}
PX4_CURRENT_ABOVE = 0.5  # the commander's "use current position" threshold on param1
HOME_ALT_MOVE_M = 1.0  # a home moved less than this up or down moves no height worth a word


def set_home_source(it: MissionItem, px4: bool) -> tuple[bool, str]:
    """How the autopilot takes DO_SET_HOME ``it`` (see the module doc): (True: where the
    vehicle is, else at the item's latitude/longitude; why its home is not known, "" when it
    is), for an item in a frame the autopilot takes (:func:`~.frames.item_refusal`)."""
    p1, alt = it.params[0], it.params[6]
    if px4:
        if p1 > PX4_CURRENT_ABOVE:
            return True, ""
        return False, ("PX4 takes a DO_SET_HOME's latitude and longitude unscaled from "
                       "MISSION_ITEM_INT (whole degrees in frame 2): home would not be this "
                       "item's position; give param1 1 at the new home instead")
    here = unplaced(it)
    if (math.isfinite(p1) and int(p1) == 1) or (here and alt == 0.0):
        return True, ""
    if here:
        return False, ("ArduCopter moves home to 0°N 0°E: param1 is not 1, latitude and "
                       "longitude are 0 and the altitude is not; give param1 1 for the "
                       "current position, or the new home's coordinates")
    if it.frame not in GLOBAL_FRAMES:
        return False, (f"ArduCopter reads a DO_SET_HOME's latitude and longitude as degrees "
                       f"x 1e7, which MISSION_ITEM_INT carries only in a global frame, not "
                       f"frame {it.frame}: home would not be this item's position; use "
                       "frame 3 or 0")
    return False, ""


def moved_home(it: MissionItem, item: int, px4: bool, *, here_xy_m: ArrayLike,
               here_alt_m: float, home: Home, plan_home_amsl_m: float,
               item_xy_m: Callable[[], NDArray[np.float64]]) -> tuple[Home | None, str]:
    """The home DO_SET_HOME ``it`` (item ``item``) moves to while the vehicle is at
    ``here_xy_m`` (m), ``here_alt_m`` (m above the plan's home, whose altitude is
    ``plan_home_amsl_m``) under ``home``: (the new home, "") or (None, why it is not known, as
    :func:`set_home_source` says). ``item_xy_m()`` is the item's own position (m), asked for
    only when home goes there."""
    at_current, unknown = set_home_source(it, px4)
    if unknown:
        return None, unknown
    if at_current:
        return Home(np.array(here_xy_m, dtype=float), item, float(here_alt_m)), ""
    return Home(item_xy_m(), item, location_alt_m(it, home, plan_home_amsl_m)), ""


def location_alt_m(it: MissionItem, home: Home, plan_home_amsl_m: float) -> float:
    """The altitude (m above the plan's home) ArduCopter gives a home set at ``it``'s location,
    made absolute against ``home``, the home in force: a mission item's, or a ground station's
    DO_SET_HOME command read as one (``Location::change_alt_frame`` serves both)."""
    alt = it.params[6]
    if not math.isfinite(alt):
        return home.alt_m
    if it.frame in RELATIVE_FRAMES:
        return home.alt_m + alt
    if it.frame in AMSL_FRAMES:
        return alt - plan_home_amsl_m
    return alt  # above terrain: the ground, level with the plan's home, as the resolver has it


def home_height_finding(old: Home, new: Home) -> tuple[Severity, str] | None:
    """A warning when the home moves from ``old`` to ``new`` up or down: altitudes above home
    after it are no longer the plan's (see the module doc for what ArduCopter flew)."""
    up_m = new.alt_m - old.alt_m
    if abs(up_m) < HOME_ALT_MOVE_M:
        return None
    way = "up" if up_m > 0 else "down"
    return "warning", (f"home moves {abs(up_m):.0f} m {way}: altitudes above home after this "
                       "item move with it (the audit and replay keep the plan's), and "
                       "ArduCopter 4.5.6 SITL, its home moved up to where it was, flew the next "
                       "leg at its old height and hovered at its waypoint for good; set home at "
                       "the ground's altitude, or give altitudes above sea level after it")


def home_finding(site: Site, home_xy_m: ArrayLike) -> tuple[Severity, str]:
    """(severity, message) of a home a DO_SET_HOME moves to ``home_xy_m`` (m): a violation in a
    zone or its buffer, where every return lands."""
    inside = buffer_intrusion(site, home_xy_m)
    if inside:
        return "violation", f"DO_SET_HOME moves home into {inside}: a return lands there"
    return "note", "DO_SET_HOME moves the RTL destination"
