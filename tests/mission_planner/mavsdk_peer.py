"""MAVSDK 4.x as the outside peer: offline import of a QGroundControl plan (no vehicle).

``MissionRaw.import_qgroundcontrol_mission`` needs a system, so a raw:// connection is fed
one HEARTBEAT packed with pymavlink. With an ArduPilot heartbeat MAVSDK puts the planned home
at seq 0; with a PX4 one it does not. The importer does no semantic checks (notes:
mavlink-facts.md), so callers assert item counts and contents themselves.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

os.environ["MAVLINK20"] = "1"  # before pymavlink's first import: MAVLink 2 has mission_type

from mavsdk import ComponentType, Configuration, Mavsdk  # noqa: E402
from mavsdk.plugins.mission_raw import MissionRaw  # noqa: E402
from pymavlink import mavutil  # noqa: E402

if mavutil.mavlink.WIRE_PROTOCOL_VERSION != "2.0":  # pymavlink was imported before us
    mavutil.set_dialect("ardupilotmega")


def mavsdk_import(path: str | Path, autopilot: int) -> Any:
    """MAVSDK's MissionImportData (mission, geofence, rally items) for the plan at ``path``,
    as seen by a ground station talking to an autopilot of type ``autopilot`` (MAV_AUTOPILOT)."""
    mav = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        mav.add_any_connection("raw://")
        link = mavutil.mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        heartbeat = link.heartbeat_encode(mavutil.mavlink.MAV_TYPE_QUADROTOR, autopilot, 0, 0,
                                          mavutil.mavlink.MAV_STATE_STANDBY)
        mav.pass_received_raw_bytes(bytes(heartbeat.pack(link)))
        system = mav.first_autopilot(2.0)
        assert system is not None, "MAVSDK did not see the heartbeat"
        return MissionRaw(system).import_qgroundcontrol_mission(str(path))
    finally:
        mav.destroy()
