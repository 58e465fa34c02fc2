"""The vehicle side of the mission protocol, done by MAVSDK's MissionRawServer: the mission,
fence and rally lists the vehicle holds.

MAVSDK runs on a ``raw://`` connection: the vehicle owns the socket and hands MAVSDK the
mission-protocol packets only, and passes on only MAVSDK's mission-protocol answers, so
MAVSDK's generic heartbeat and our ArduCopter telemetry do not fight over one port.

A mission download's item 0 is the vehicle's home as it is now, as ArduPilot's is
(``AP_Mission::read_cmd_from_storage`` reads index 0 from ``AP::ahrs().get_home()``; sent as
NAV_WAYPOINT in MAV_FRAME_GLOBAL, altitude above sea level, params 0), not the item 0 uploaded:
MAVSDK's answer is rewritten on its way out (:meth:`MissionServer._as_home`).
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable, Iterator
from typing import Any

from validator.geodesy import to_int_e7
from validator.mavlink.wire import WireItem, WireLists, mavlink

log = logging.getLogger(__name__)

MAVLINK_PACKET_TYPES_FOR_MAVSDK = frozenset({
    "MISSION_COUNT", "MISSION_ITEM_INT", "MISSION_ITEM", "MISSION_REQUEST_LIST",
    "MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK", "MISSION_CLEAR_ALL", "HEARTBEAT",
})
MAVSDK_PACKET_TYPES_TO_GCS = frozenset({
    "MISSION_COUNT", "MISSION_ITEM_INT", "MISSION_ITEM", "MISSION_REQUEST_INT",
    "MISSION_REQUEST", "MISSION_ACK",
})


class MissionServer:
    """The lists the vehicle holds, kept by MAVSDK's MissionRawServer once :meth:`start`
    has run. ``mav`` sends our own answers; ``forward`` sends the packets MAVSDK answers with
    (called from MAVSDK's thread); ``home()`` is the vehicle's home now (latitude, longitude
    in degrees, altitude in m above sea level), which a download reports as item 0."""

    def __init__(self, system_id: int, mav: Any, forward: Callable[[Any], None],
                 home: Callable[[], tuple[float, float, float]]) -> None:
        self.system_id = system_id
        self.mav = mav
        self.forward = forward
        self.home = home
        self._lists_lock = threading.Lock()
        self._lists: dict[int, tuple[WireItem, ...]] = {0: (), 1: (), 2: ()}
        self._completed: dict[int, int] = {}  # mission_type -> items of its finished upload
        self._updates: queue.SimpleQueue[int] = queue.SimpleQueue()
        self._mavsdk: Any = None
        self._mission_server: Any = None
        self._out_parser = mavlink.MAVLink(None)
        self._out_parser.robust_parsing = True

    def start(self) -> None:
        from mavsdk import Configuration, Mavsdk
        from mavsdk.plugins.mission_raw_server import MissionRawServer, MissionRawServerResult

        _quiet_mavsdk_log()
        cfg = Configuration.create_manual(self.system_id, 1, False)
        self._mavsdk = Mavsdk(cfg)
        self._mavsdk.add_any_connection("raw://")
        self._mavsdk.subscribe_raw_bytes_to_be_sent(self._from_mavsdk)
        self._mission_server = MissionRawServer(self._mavsdk.server_component())

        def incoming(result: Any, plan: Any, _ud: Any) -> None:
            if result != MissionRawServerResult.SUCCESS:
                return
            items = tuple(
                WireItem(int(i.seq), int(i.frame), int(i.command), float(i.param1),
                         float(i.param2), float(i.param3), float(i.param4), int(i.x), int(i.y),
                         float(i.z), int(i.mission_type), int(i.autocontinue))
                for i in plan.mission_items
            )
            if not items:
                return  # MAVSDK does not say which list is empty: see MISSION_COUNT in handle
            self._completed[items[0].mission_type] = len(items)
            self._set_list(items[0].mission_type, items)

        def cleared(mission_type: int, _ud: Any) -> None:
            types = [0, 1, 2] if mission_type == 255 else [int(mission_type)]
            for t in types:
                self._set_list(t, ())

        self._mission_server.subscribe_incoming_mission(incoming)
        self._mission_server.subscribe_clear_all(cleared)

    def close(self) -> None:
        if self._mavsdk is not None:
            self._mavsdk.destroy()
            self._mavsdk = None
            self._mission_server = None

    def handle(self, msg: Any) -> bool:
        """Take ``msg`` if it is a mission-protocol packet (True) and MAVSDK is running."""
        kind = msg.get_type()
        if kind not in MAVLINK_PACKET_TYPES_FOR_MAVSDK or self._mavsdk is None:
            return False
        mtype = int(getattr(msg, "mission_type", 0))
        if kind == "MISSION_COUNT":
            self._completed.pop(mtype, None)
            if msg.count == 0:
                self._set_list(mtype, ())
        if kind == "MISSION_ITEM_INT" and self._completed.get(mtype) == msg.seq + 1:
            # The ground station repeats the last item because our ACK was lost; MAVSDK
            # has finished and would stay silent, so answer as the protocol asks.
            self.mav.mission_ack_send(msg.get_srcSystem(), msg.get_srcComponent(),
                                      mavlink.MAV_MISSION_ACCEPTED, mtype)
            return True
        self._mavsdk.pass_received_raw_bytes(bytes(msg.get_msgbuf()))
        return True

    def lists(self) -> WireLists:
        """The mission, fence and rally lists the vehicle holds."""
        with self._lists_lock:
            return WireLists(self._lists[0], self._lists[1], self._lists[2])

    def updates(self) -> Iterator[int]:
        """The mission types of the lists stored since last asked, in order: MAVSDK stores
        them from its own thread, the vehicle's loop acts on them in its own."""
        while not self._updates.empty():
            yield self._updates.get()

    def _set_list(self, mission_type: int, items: tuple[WireItem, ...]) -> None:
        with self._lists_lock:
            self._lists[mission_type] = items
        self._updates.put(mission_type)

    def _from_mavsdk(self, data: bytes) -> None:
        """MAVSDK's outgoing bytes: pass on its mission-protocol answers, drop the rest (its
        GENERIC heartbeat, PING, AUTOPILOT_VERSION, MISSION_CURRENT)."""
        try:
            msgs = self._out_parser.parse_buffer(bytes(data)) or []
        except Exception:  # a packet we cannot parse is one we would not forward either
            return
        for msg in msgs:
            if msg.get_type() in MAVSDK_PACKET_TYPES_TO_GCS:
                self.forward(self._as_home(msg))

    def _as_home(self, msg: Any) -> Any:
        """``msg``, or, when it is the mission's item 0 (MISSION_ITEM_INT, what MAVSDK sends),
        that item holding the home now, packed again as MAVSDK sent it (same sender and
        sequence number)."""
        if (msg.get_type() != "MISSION_ITEM_INT" or msg.seq != 0
                or int(getattr(msg, "mission_type", 0)) != mavlink.MAV_MISSION_TYPE_MISSION):
            return msg
        lat, lon, amsl_m = self.home()
        msg.frame, msg.command = mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_NAV_WAYPOINT
        msg.param1 = msg.param2 = msg.param3 = msg.param4 = 0.0
        msg.x, msg.y, msg.z = int(to_int_e7(lat)), int(to_int_e7(lon)), float(amsl_m)
        packer = mavlink.MAVLink(None, msg.get_srcSystem(), msg.get_srcComponent())
        packer.seq = msg.get_seq()
        msg.pack(packer)
        return msg


_mavsdk_log_quiet = False


def _quiet_mavsdk_log() -> None:
    """Route MAVSDK's own log lines to :mod:`logging` instead of stderr (once per process)."""
    global _mavsdk_log_quiet
    if _mavsdk_log_quiet:
        return
    from mavsdk import LogLevel, log_subscribe

    def handler(level: Any, message: str, _file: str | None, _line: int) -> bool:
        if level >= LogLevel.WARN:
            log.debug("mavsdk: %s", message)
        return True

    log_subscribe(handler)
    _mavsdk_log_quiet = True
