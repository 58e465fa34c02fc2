"""The built-in vehicle's mission download reports its home now as item 0, as ArduPilot's
does (``AP_Mission::read_cmd_from_storage`` reads index 0 from AP_AHRS's home): MAVSDK's
answers rewritten on their way out, without a socket or MAVSDK."""

from __future__ import annotations

from typing import Any

import pytest

from validator.geodesy import from_int_e7
from validator.mavlink.sim.mission_server import MissionServer
from validator.mavlink.wire import mavlink

m = mavlink
HOME = (47.3977, 8.5456, 512.5)  # the vehicle's home now: degrees, m above sea level


def served(seq: int, mission_type: int = m.MAV_MISSION_TYPE_MISSION) -> Any:
    """What the GCS receives when MAVSDK answers with item ``seq`` (the uploaded item 0: the
    plan's home, 1 km away, 0 m above home in frame 3)."""
    out: list[Any] = []
    server = MissionServer(1, None, out.append, lambda: HOME)
    mavsdk = m.MAVLink(None, srcSystem=1, srcComponent=1)
    mavsdk.seq = 41
    item = m.MAVLink_mission_item_int_message(
        255, 190, seq, m.MAV_FRAME_GLOBAL_RELATIVE_ALT, m.MAV_CMD_NAV_WAYPOINT, 0, 1,
        0, 0, 0, 0, 474067000, 85456000, 0.0, mission_type)
    server._from_mavsdk(item.pack(mavsdk))
    (msg,) = out
    parsed = m.MAVLink(None).parse_char(msg.get_msgbuf())  # as the GCS decodes it
    assert parsed is not None and parsed.get_seq() == 41  # MAVSDK's sequence number kept
    return parsed


def test_item_0_of_a_mission_download_is_the_home_now():
    item = served(0)
    assert (item.command, item.frame) == (m.MAV_CMD_NAV_WAYPOINT, m.MAV_FRAME_GLOBAL)
    assert float(from_int_e7(item.x)) == pytest.approx(HOME[0], abs=1e-7)
    assert float(from_int_e7(item.y)) == pytest.approx(HOME[1], abs=1e-7)
    assert item.z == pytest.approx(HOME[2], abs=1e-3)


@pytest.mark.parametrize(("seq", "mission_type"), [(1, m.MAV_MISSION_TYPE_MISSION),
                                                   (0, m.MAV_MISSION_TYPE_FENCE),
                                                   (0, m.MAV_MISSION_TYPE_RALLY)])
def test_other_items_and_lists_go_out_as_mavsdk_sent_them(seq, mission_type):
    item = served(seq, mission_type)
    assert (item.x, item.y, item.frame) == (474067000, 85456000, m.MAV_FRAME_GLOBAL_RELATIVE_ALT)
