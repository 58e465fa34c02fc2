"""The frames an autopilot takes a navigation item's position in, and how it reads the
coordinates there: the one rule :mod:`.resolve` asks of every positioned item.

How the coordinates travel: MISSION_ITEM_INT carries a position's latitude and longitude as
x and y, int32 degrees x 1e7 in the global frames. In frame 2 (MAV_FRAME_MISSION, meant for
items without a position) ground stations send params 5 and 6 unscaled, as whole numbers:
QGroundControl (``PlanManager``: ``frame == MAV_FRAME_MISSION ? param5 : param5 * 1e7``,
truncated to int32, and read back the same way) and MAVSDK's ``.plan`` import
(``MissionImport::set_int32``) alike; so does :mod:`validator.mavlink.wire`, which refuses the
fraction they would cut.

ArduPilot 4.5 (``AP_Mission::mavlink_int_to_mission_cmd``, ``stored_in_location``): a command
with a location takes x and y as degrees x 1e7 whatever the frame; frames 0, 2 and 5 make its
altitude absolute, 3 and 6 above home, 10 and 11 above terrain, any other is refused
(MAV_MISSION_UNSUPPORTED_FRAME). A frame-2 item with coordinates (whole degrees on the wire)
therefore flies toward 0°N 0°E; without them (x and y 0) it flies from where the vehicle is,
as in any frame. ArduCopter's NAV_TAKEOFF uses only the altitude (it climbs where it is).

PX4 v1.15 (``MavlinkMissionManager::parse_mavlink_mission_item``): a position only in frames
0 and 3 and, sent as MISSION_ITEM_INT, 5 and 6; frame 2 takes only commands without one (DO
items, RTL, NAV_DELAY...), so NAV_WAYPOINT, the loiters, LAND and TAKEOFF there are refused
(MAV_MISSION_UNSUPPORTED), with or without coordinates; every other frame, the terrain frames
10 and 11 too, is refused (MAV_MISSION_UNSUPPORTED_FRAME).

A refusal here is an :class:`~validator.errors.InputError` of the resolver, as for any plan the
autopilot would not take or not fly as written.
"""

from __future__ import annotations

import math

from validator.plan_format import Cmd, Frame, MissionItem

AMSL_FRAMES = frozenset({Frame.GLOBAL, Frame.MISSION, 5})  # 5: GLOBAL_INT
RELATIVE_FRAMES = frozenset({Frame.GLOBAL_RELATIVE_ALT, 6})  # 6: GLOBAL_RELATIVE_ALT_INT
TERRAIN_FRAMES = frozenset({Frame.GLOBAL_TERRAIN_ALT, 11})  # 11: GLOBAL_TERRAIN_ALT_INT
PX4_FRAMES = frozenset({Frame.GLOBAL, Frame.GLOBAL_RELATIVE_ALT, 5, 6})
USE_INSTEAD = "use 3 (above home) or 0 (AMSL)"


def no_coordinate(value: float) -> bool:
    """A latitude or longitude MISSION_ITEM_INT carries as 0: NaN (sent as 0) or 0."""
    return math.isnan(value) or value == 0.0


def _name(command: int) -> str:
    try:
        return Cmd(command).name
    except ValueError:
        return f"command {command}"


def nav_frame_refusal(it: MissionItem, px4: bool, *, at_position: bool) -> str | None:
    """Why the autopilot (PX4 if ``px4``, else ArduPilot) would refuse navigation item ``it``
    or fly it elsewhere than the plan says, in one line; None when it flies it as written.
    ``at_position``: the item's latitude and longitude are used, not only its altitude."""
    frame = it.frame
    if frame not in AMSL_FRAMES | RELATIVE_FRAMES | TERRAIN_FRAMES:
        return (f"frame {frame} is no frame for a position: the autopilot refuses the item "
                f"(MAV_MISSION_UNSUPPORTED_FRAME); {USE_INSTEAD}")
    if px4 and frame == Frame.MISSION:
        return (f"frame 2 (MISSION) is for items without a position: PX4 refuses "
                f"{_name(it.command)} in it (MAV_MISSION_UNSUPPORTED); {USE_INSTEAD}")
    if px4 and frame not in PX4_FRAMES:
        return (f"frame {frame} (above terrain): PX4 refuses the item "
                f"(MAV_MISSION_UNSUPPORTED_FRAME); {USE_INSTEAD}")
    lat, lon = it.params[4], it.params[5]
    if (frame == Frame.MISSION and at_position
            and not (no_coordinate(lat) and no_coordinate(lon))):
        return ("frame 2 (MISSION) carries latitude and longitude unscaled, as "
                "QGroundControl sends them, and ArduPilot reads them as degrees x 1e7: "
                f"{_name(it.command)} would fly toward 0°N 0°E; {USE_INSTEAD}")
    return None
