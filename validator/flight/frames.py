"""The frames an autopilot takes a mission item in, and how it reads the coordinates there:
the one rule :mod:`.resolve` asks of every item of a plan, and ``upload-mission``
(:func:`validator.mavlink.link.upload_to`) of every item it is about to send.

How the coordinates travel: MISSION_ITEM_INT carries a position's latitude and longitude as
x and y, int32 degrees x 1e7 in the global frames. In frame 2 (MAV_FRAME_MISSION, meant for
items without a position) ground stations send params 5 and 6 unscaled, as whole numbers:
QGroundControl (``PlanManager``: ``frame == MAV_FRAME_MISSION ? param5 : param5 * 1e7``,
truncated to int32, and read back the same way) and MAVSDK's ``.plan`` import
(``MissionImport::set_int32``) alike; so does :mod:`validator.mavlink.wire`, which refuses the
fraction they would cut. A latitude or longitude left out (NaN) travels as 0.

ArduPilot 4.5 (``AP_Mission::mavlink_int_to_mission_cmd``, ``stored_in_location``): a command
with a location (:data:`ARDUPILOT_LOCATED`) takes x and y as degrees x 1e7 whatever the frame;
frames 0, 2 and 5 make its altitude absolute, 3 and 6 above home, 10 and 11 above terrain, any
other is refused (MAV_MISSION_UNSUPPORTED_FRAME). A command without one (RTL, NAV_DELAY, the
DO items but DO_SET_HOME, DO_LAND_START, DO_GO_AROUND and DO_SET_ROI) is taken in any frame,
which it ignores. A frame-2 item with coordinates (whole degrees on the wire) therefore flies
toward 0°N 0°E; without them (x and y 0) it flies from where the vehicle is, as in any frame
(``ModeAuto::loc_from_cmd``: only latitude and longitude both 0 are "here"). ArduCopter's
NAV_TAKEOFF uses only the altitude (it climbs where it is).

PX4 v1.15 (``MavlinkMissionManager::parse_mavlink_mission_item``): the frame decides which
commands it takes. Frames 0 and 3 and, sent as MISSION_ITEM_INT, 5 and 6 take only the
commands with a position (:data:`PX4_POSITIONED`); frame 2 only those without one
(:data:`PX4_UNPOSITIONED`: RTL, NAV_DELAY, the DO and CONDITION items it knows); NAV_ROI and
DO_SET_ROI go in either, by their ROI mode (:data:`PX4_ROI_MODES`, else
MAV_MISSION_INVALID_PARAM1). A command in the other kind of frame is refused
(MAV_MISSION_UNSUPPORTED): an RTL in frame 3 as much as a waypoint in frame 2, with or without
coordinates; so is one in neither table (NAV_LOITER_TURNS, DO_SET_SERVO, CONDITION_YAW...), in
every frame. Every other frame, the terrain frames 10 and 11 too, is refused
(MAV_MISSION_UNSUPPORTED_FRAME). One refused item fails the whole upload, wherever it sits in
the mission.

A refusal here is an :class:`~validator.errors.InputError` of its caller, as for any plan the
autopilot would not take or not fly as written.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from validator.item_numbers import item_label
from validator.plan_format import Cmd, Frame, MissionItem

AMSL_FRAMES = frozenset({Frame.GLOBAL, Frame.MISSION, 5})  # 5: GLOBAL_INT
RELATIVE_FRAMES = frozenset({Frame.GLOBAL_RELATIVE_ALT, 6})  # 6: GLOBAL_RELATIVE_ALT_INT
TERRAIN_FRAMES = frozenset({Frame.GLOBAL_TERRAIN_ALT, 11})  # 11: GLOBAL_TERRAIN_ALT_INT
PX4_FRAMES = frozenset({Frame.GLOBAL, Frame.GLOBAL_RELATIVE_ALT, 5, 6})
USE_INSTEAD = "use 3 (above home) or 0 (AMSL)"

# AP_Mission::stored_in_location: the commands whose x, y, z are a location.
ARDUPILOT_LOCATED = frozenset({16, 17, 18, 19, 21, 22, 30, 31, 82, 92, 179, 189, 191, 201,
                               84, 85, 94})
# parse_mavlink_mission_item's case labels: the commands PX4 takes in a global frame...
PX4_POSITIONED: dict[int, str] = {
    16: "NAV_WAYPOINT", 17: "NAV_LOITER_UNLIM", 19: "NAV_LOITER_TIME", 21: "NAV_LAND",
    22: "NAV_TAKEOFF", 31: "NAV_LOITER_TO_ALT", 84: "NAV_VTOL_TAKEOFF", 85: "NAV_VTOL_LAND",
    195: "DO_SET_ROI_LOCATION", 4501: "CONDITION_GATE", 5000: "NAV_FENCE_RETURN_POINT",
    5001: "NAV_FENCE_POLYGON_VERTEX_INCLUSION", 5002: "NAV_FENCE_POLYGON_VERTEX_EXCLUSION",
    5003: "NAV_FENCE_CIRCLE_INCLUSION", 5004: "NAV_FENCE_CIRCLE_EXCLUSION",
    5100: "NAV_RALLY_POINT",
}
# ... those it takes in frame 2 (MISSION) ...
PX4_UNPOSITIONED: dict[int, str] = {
    20: "NAV_RETURN_TO_LAUNCH", 93: "NAV_DELAY", 112: "CONDITION_DELAY",
    114: "CONDITION_DISTANCE", 177: "DO_JUMP", 178: "DO_CHANGE_SPEED", 179: "DO_SET_HOME",
    187: "DO_SET_ACTUATOR", 189: "DO_LAND_START", 196: "DO_SET_ROI_WPNEXT_OFFSET",
    197: "DO_SET_ROI_NONE", 200: "DO_CONTROL_VIDEO", 203: "DO_DIGICAM_CONTROL",
    204: "DO_MOUNT_CONFIGURE", 205: "DO_MOUNT_CONTROL", 206: "DO_SET_CAM_TRIGG_DIST",
    211: "DO_GRIPPER", 214: "DO_SET_CAM_TRIGG_INTERVAL", 260: "OBLIQUE_SURVEY",
    530: "SET_CAMERA_MODE", 532: "SET_CAMERA_FOCUS", 1000: "DO_GIMBAL_MANAGER_PITCHYAW",
    1001: "DO_GIMBAL_MANAGER_CONFIGURE", 2000: "IMAGE_START_CAPTURE",
    2001: "IMAGE_STOP_CAPTURE", 2003: "DO_TRIGGER_CONTROL", 2500: "VIDEO_START_CAPTURE",
    2501: "VIDEO_STOP_CAPTURE", 3000: "DO_VTOL_TRANSITION", 42600: "DO_WINCH",
}
# ... and in both, by param1's MAV_ROI mode: (global frame, frame 2) -> the modes taken
PX4_ROI: dict[int, str] = {80: "NAV_ROI", 201: "DO_SET_ROI"}
PX4_ROI_MODES = {True: ("0 (none) or 3 (a location)", frozenset({0, 3})),
                 False: ("0 (none), 1 (next waypoint) or 2 (a waypoint)", frozenset({0, 1, 2}))}


def no_coordinate(value: float) -> bool:
    """A latitude or longitude MISSION_ITEM_INT carries as 0: NaN (sent as 0) or 0."""
    return math.isnan(value) or value == 0.0


def unplaced(it: MissionItem) -> bool:
    """``it`` gives no latitude and longitude (both sent as 0): the autopilot flies it from
    where the vehicle is."""
    return no_coordinate(it.params[4]) and no_coordinate(it.params[5])


def coordinate_refusal(it: MissionItem) -> str | None:
    """Why ``it``, one of its latitude and longitude left out (NaN), is not flown where the
    plan seems to say, in one line; None when both or neither are given."""
    lat, lon = it.params[4], it.params[5]
    if unplaced(it) or not (math.isnan(lat) or math.isnan(lon)):
        return None
    missing, given = ("latitude", "longitude") if math.isnan(lat) else ("longitude", "latitude")
    return (f"{missing} left out (null) but {given} {lon if math.isnan(lat) else lat:g} "
            f"given: MISSION_ITEM_INT sends it as {missing} 0, so the vehicle flies toward "
            f"{missing} 0, not from where it is (only both left out mean that); give both "
            "or neither")


def _name(command: int) -> str:
    try:
        return Cmd(command).name
    except ValueError:
        return (PX4_POSITIONED.get(command) or PX4_UNPOSITIONED.get(command)
                or PX4_ROI.get(command) or f"command {command}")


def _px4_refusal(it: MissionItem) -> str | None:
    """Why PX4 v1.15 refuses mission item ``it`` at upload (see the module doc)."""
    frame, name = it.frame, _name(it.command)
    positioned = it.command in PX4_POSITIONED
    known = positioned or it.command in PX4_UNPOSITIONED or it.command in PX4_ROI
    instead = (USE_INSTEAD if positioned else "use 2 (MISSION)" if known
               else f"and PX4 takes {name} in no frame")
    if frame in TERRAIN_FRAMES:
        return (f"frame {frame} (above terrain): PX4 refuses the item "
                f"(MAV_MISSION_UNSUPPORTED_FRAME); {instead}")
    if frame not in PX4_FRAMES and frame != Frame.MISSION:
        return (f"frame {frame}: PX4 takes a mission item only in frames 0, 3, 5, 6 (with a "
                f"position) and 2 (without) and refuses {name} in it "
                f"(MAV_MISSION_UNSUPPORTED_FRAME); {instead}")
    in_global = frame in PX4_FRAMES
    if it.command in PX4_ROI:
        modes, taken = PX4_ROI_MODES[in_global]
        p1 = it.params[0]
        if math.isfinite(p1) and math.trunc(p1) in taken:
            return None
        return (f"PX4 takes {name} in frame {frame} only with param1 {modes}, not {p1:g} "
                f"(MAV_MISSION_INVALID_PARAM1); "
                + ("a next-waypoint or waypoint ROI belongs in frame 2 (MISSION)" if in_global
                   else "a location belongs in frame 3 or 0"))
    if (positioned if in_global else it.command in PX4_UNPOSITIONED):
        return None
    if positioned:
        return (f"frame 2 (MISSION) is for items without a position: PX4 refuses {name} in "
                f"it (MAV_MISSION_UNSUPPORTED); {USE_INSTEAD}")
    if it.command in PX4_UNPOSITIONED:
        return (f"PX4 takes {name} only in frame 2 (MISSION), for items without a position: "
                f"it refuses it in frame {frame} (MAV_MISSION_UNSUPPORTED); use 2 (MISSION)")
    return f"PX4 takes {name} in no frame: it refuses the item (MAV_MISSION_UNSUPPORTED)"


def _flown_to(command: int) -> bool:
    """A navigation command the vehicle flies to, at its latitude and longitude (ArduCopter's
    takeoff climbs where it is; a DO item's location moves no leg, DO_SET_HOME's is judged
    in :mod:`validator.flight.home`)."""
    return command < 100 and command != Cmd.NAV_TAKEOFF and command in ARDUPILOT_LOCATED


def _ardupilot_refusal(it: MissionItem) -> str | None:
    """Why ArduPilot 4.5 refuses mission item ``it`` at upload, or flies it elsewhere, for
    its frame (see the module doc)."""
    if it.command not in ARDUPILOT_LOCATED:
        return None  # it ignores the frame of a command without a location
    if it.frame not in AMSL_FRAMES | RELATIVE_FRAMES | TERRAIN_FRAMES:
        return (f"frame {it.frame} is no frame for a position: ArduPilot refuses the item "
                f"(MAV_MISSION_UNSUPPORTED_FRAME); {USE_INSTEAD}")
    if it.frame == Frame.MISSION and _flown_to(it.command) and not unplaced(it):
        return ("frame 2 (MISSION) carries latitude and longitude unscaled, as "
                "QGroundControl sends them, and ArduPilot reads them as degrees x 1e7: "
                f"{_name(it.command)} would fly toward 0°N 0°E; {USE_INSTEAD}")
    return None


def item_refusal(it: MissionItem, px4: bool) -> str | None:
    """Why the autopilot (PX4 if ``px4``, else ArduPilot) would refuse mission item ``it`` at
    upload because of its frame, or fly it elsewhere than the plan says (its frame, or one of
    latitude and longitude left out), in one line; None when it takes it as written."""
    why = _px4_refusal(it) if px4 else _ardupilot_refusal(it)
    if why is None and _flown_to(it.command):
        why = coordinate_refusal(it)
    return why


def plan_refusal(items: Sequence[MissionItem], px4: bool) -> str | None:
    """``item N: why`` for the first of a mission's ``items`` (N its number,
    :func:`~validator.item_numbers.item_number`) the autopilot would refuse or misplace by
    :func:`item_refusal`, or None. All of them, reached or not: the autopilot refuses the
    upload for any one refused."""
    for i, it in enumerate(items):
        why = item_refusal(it, px4)
        if why is not None:
            return f"{item_label(i)}: {why}"
    return None
