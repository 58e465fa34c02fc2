"""Fixtures for the MAVLink tests: SITL vehicles on free loopback ports, small plans, and a
misbehaving fake vehicle. Every vehicle binds port 0, so tests run in parallel (xdist)."""

from __future__ import annotations

import random
import socket
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

from tests.validator.builders import jump, make_site, nav, plan_of, speed
from validator.mavlink.sim import SitlVehicle, VehicleConfig
from validator.mavlink.wire import WireItem, mavlink, mavutil
from validator.plan_format import Cmd, FencePolygon, Frame, MissionItem, Plan
from validator.site import Site


def url_of(vehicle: SitlVehicle) -> str:
    return f"udpout:127.0.0.1:{vehicle.address[1]}"


def home_of(plan: Plan) -> tuple[float, float, float]:
    return plan.home_lat_deg, plan.home_lon_deg, plan.home_alt_m


@pytest.fixture()
def site() -> Site:
    return make_site(nfz=((100.0, 0.0, 20.0),))


@pytest.fixture()
def plan(site: Site) -> Plan:
    """Every kind of item the wire carries: takeoff, speed, waypoints with a hold, a DO_JUMP,
    LAND; fence circle, polygon and return point; rally points."""
    items = [
        nav(site, Cmd.NAV_TAKEOFF, (0, 0)),
        speed(6.0),
        nav(site, Cmd.NAV_WAYPOINT, (60, 40)),
        nav(site, Cmd.NAV_WAYPOINT, (140, 40), p1=2.0),
        jump(2, 1),
        nav(site, Cmd.NAV_LAND, (0, 0), 0.0),
    ]
    p = plan_of(site, items, rally=[(10.0, -10.0), (-20.0, 5.0)])
    lat, lon = site.frame.to_geodetic(np.array([[-50.0, -50.0], [250.0, -50.0], [250.0, 150.0],
                                                [-50.0, 150.0]]))
    p.polygons = [FencePolygon([(float(a), float(b)) for a, b in zip(lat, lon, strict=True)])]
    p.breach_return = (p.home_lat_deg, p.home_lon_deg, 25.0)
    return p


# The built-in vehicle's fence is report-only by default; uploads check for a safe breach action.
FENCE_ON = {"FENCE_ACTION": 5.0}


@pytest.fixture()
def start_vehicle() -> Iterator[Callable[..., SitlVehicle]]:
    """``start_vehicle(plan_or_home, **VehicleConfig fields)``: a running SITL vehicle whose
    fence has a safe breach action (:data:`FENCE_ON`, unless ``params`` say otherwise),
    stopped after the test."""
    started: list[SitlVehicle] = []

    def start(where: Plan | tuple[float, float, float], **config: Any) -> SitlVehicle:
        home = home_of(where) if isinstance(where, Plan) else where
        config["params"] = {**FENCE_ON, **config.get("params", {})}
        v = SitlVehicle("udpin:127.0.0.1:0", VehicleConfig(home=home, **config)).start()
        started.append(v)
        return v

    yield start
    for v in started:
        v.stop()


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class FakeVehicle:
    """A minimal ArduCopter impostor on a loopback port that misbehaves on purpose.

    ``nack``: answer every MISSION_COUNT with this MAV_MISSION_RESULT. ``silent_after``: stop
    answering mission requests after that many items (heartbeats go on). ``corrupt_seq``: hold
    everything but report param2 + 1 for that seq on download. ``drop_download_at``: when
    that item is first requested, abandon the download as MAVSDK does after its retries: say
    nothing more until a new MISSION_REQUEST_LIST, then serve items only from 0 in order.
    ``mute_items``: answer MISSION_REQUEST_LIST but never an item. ``booting``: refuse that
    many MISSION_COUNTs with NO_SPACE and "Only 0 items are supported", as a booting
    ArduPilot does; ``room``: say "Only ROOM items are supported" with every ``nack``.

    Faults for :mod:`test_link_faults`: ``nack_after``: send ``nack`` only once that many
    items of a mission upload have arrived (the last item's ACK when it is the count).
    ``wire``: a :class:`FaultyWire` every packet the vehicle sends goes through (garbage,
    truncated and duplicated packets). ``impostors``: other system ids flooding ArduPilot
    heartbeats from the same socket (before the vehicle's own) and NACKing every upload.
    ``stray_acks``: before each mission-protocol answer, MISSION_ACKs of the other two
    mission types (a NACK and an ACCEPTED). ``ack_type``: the final ACK of a mission upload
    carries this mission type instead. ``reboot_at``: when that item of a mission upload
    first arrives, fall silent for ``reboot_gap_s`` (no heartbeat, input discarded), then come
    back with the transfer forgotten and the mission list it held before (``lists`` at boot:
    a stale mission, as a reboot reloads it from storage). ``reorder_seed``: request the
    items of a mission upload in a shuffled order (seeded), each once. ``ardupilot_nacks``:
    answer an item it did not ask for as ArduPilot 4.5 does, INVALID_SEQUENCE mid-transfer
    (which goes on) and MAV_MISSION_ERROR once the transfer is complete. ``lose_final_acks``:
    that many final ACKs of uploads are lost on the way. ``counts_received`` counts the
    MISSION_COUNTs that arrived (one per list unless a transfer restarts).
    """

    def __init__(self, *, nack: int | None = None, silent_after: int | None = None,
                 corrupt_seq: int | None = None, drop_download_at: int | None = None,
                 mute_items: bool = False, sysid: int = 1, booting: int = 0,
                 room: int | None = None, nack_after: int | None = None,
                 wire: FaultyWire | None = None, impostors: tuple[int, ...] = (),
                 stray_acks: bool = False, ack_type: int | None = None,
                 reboot_at: int | None = None, reboot_gap_s: float = 1.0,
                 reorder_seed: int | None = None, ardupilot_nacks: bool = False,
                 lose_final_acks: int = 0) -> None:
        self.ardupilot_nacks, self.lose_final_acks = ardupilot_nacks, lose_final_acks
        self.counts_received = 0
        self.conn = mavutil.mavlink_connection("udpin:127.0.0.1:0", source_system=sysid,
                                               source_component=1)
        self.wire = wire
        self.reorder = None if reorder_seed is None else random.Random(reorder_seed)
        if wire is not None:
            wire.conn = self.conn
            self.conn.mav.file = wire
        self.nack_after, self.stray_acks, self.ack_type = nack_after, stray_acks, ack_type
        self.reboot_at, self.reboot_gap_s, self.reboots = reboot_at, reboot_gap_s, 0
        self.impostors = [mavlink.MAVLink(self.conn.mav.file, srcSystem=i, srcComponent=1)
                          for i in impostors]
        self.impostor_nacks = 0
        self.nack, self.silent_after, self.corrupt_seq = nack, silent_after, corrupt_seq
        self.drop_download_at, self.mute_items = drop_download_at, mute_items
        self.booting, self.room = booting, room
        self.serving: int | None = None  # next item a download may ask for; None: abandoned
        self.list_requests = 0
        self.lists: dict[int, list[WireItem]] = {0: [], 1: [], 2: []}
        self.incoming: dict[int, WireItem] = {}  # by seq
        self.order: list[int] = []  # the order this upload's items are requested in
        self.expect = 0
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)

    @property
    def url(self) -> str:
        return f"udpout:127.0.0.1:{self.conn.port.getsockname()[1]}"

    def __enter__(self) -> FakeVehicle:
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop.set()
        self.thread.join(5)
        self.conn.close()

    def run(self) -> None:
        mav = self.conn.mav
        last_hb = 0.0
        count, mtype = 0, 0
        gcs, last_item = (255, 0), 0.0
        stored = {t: list(items) for t, items in self.lists.items()}  # what a reboot reloads
        while not self.stop.is_set():
            for imp in self.impostors:  # a flood: every pass, before our own heartbeat
                imp.heartbeat_send(mavlink.MAV_TYPE_QUADROTOR,
                                   mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 4, 3)
            if time.monotonic() - last_hb > 0.2:
                mav.heartbeat_send(mavlink.MAV_TYPE_QUADROTOR,
                                   mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 4, 3)
                last_hb = time.monotonic()
            msg = self.conn.recv_match(blocking=True, timeout=0.02)
            if msg is None:
                if self.wire is not None and 0 < len(self.incoming) < count and (
                        time.monotonic() - last_item > 0.3):
                    # a real vehicle re-requests what it misses: needed once packets get lost
                    mav.mission_request_int_send(*gcs, self.next_seq(), mtype)
                    last_item = time.monotonic()
                continue
            kind = msg.get_type()
            src = msg.get_srcSystem(), msg.get_srcComponent()
            if kind in ("MISSION_COUNT", "MISSION_ITEM_INT"):  # an upload under way
                gcs, last_item = src, time.monotonic()
                mt = int(msg.mission_type)
                for imp in self.impostors:
                    imp.mission_ack_send(*src, mavlink.MAV_MISSION_ERROR, mt)
                    self.impostor_nacks += 1
                if self.stray_acks:
                    mav.mission_ack_send(*src, mavlink.MAV_MISSION_ERROR, (mt + 1) % 3)
                    mav.mission_ack_send(*src, mavlink.MAV_MISSION_ACCEPTED, (mt + 2) % 3)
            if (kind == "MISSION_ITEM_INT" and msg.seq == self.reboot_at and msg.mission_type == 0
                    and self.reboots == 0 and msg.seq == self.next_seq()):
                self.reboots += 1
                self._reboot(stored)
                count = 0
                continue
            if kind == "MISSION_COUNT":
                self.counts_received += 1
                count, mtype = msg.count, msg.mission_type
                self.incoming = {}
                self.order = list(range(count))
                if self.reorder is not None and mtype == 0:
                    self.reorder.shuffle(self.order)
                if self.nack_after == 0 and self.nack is not None and mtype == 0:
                    mav.mission_ack_send(*src, self.nack, mtype)
                    continue
                if self.booting > 0:
                    self.booting -= 1
                    mav.mission_ack_send(*src, mavlink.MAV_MISSION_NO_SPACE, mtype)
                    mav.statustext_send(mavlink.MAV_SEVERITY_WARNING,
                                        b"Only 0 items are supported")
                elif self.nack is not None and self.nack_after is None:
                    mav.mission_ack_send(*src, self.nack, mtype)
                    if self.room is not None:
                        mav.statustext_send(mavlink.MAV_SEVERITY_WARNING,
                                            f"Only {self.room} items are supported".encode())
                elif count == 0:
                    self.lists[mtype] = []
                    mav.mission_ack_send(*src, mavlink.MAV_MISSION_ACCEPTED, mtype)
                else:
                    mav.mission_request_int_send(*src, self.next_seq(), mtype)
            elif kind == "MISSION_ITEM_INT" and msg.seq == self.next_seq():
                self.incoming[msg.seq] = WireItem.from_msg(msg)
                if self.silent_after is not None and len(self.incoming) >= self.silent_after:
                    continue
                if (self.nack is not None and self.nack_after == len(self.incoming)
                        and mtype == 0):
                    mav.mission_ack_send(*src, self.nack, mtype)
                    self.incoming = {}
                    count = 0
                elif len(self.incoming) == count:
                    self.lists[mtype] = [self.incoming[i] for i in range(count)]
                    ack_type = self.ack_type if self.ack_type is not None and mtype == 0 else mtype
                    if self.lose_final_acks > 0:
                        self.lose_final_acks -= 1
                    else:
                        mav.mission_ack_send(*src, mavlink.MAV_MISSION_ACCEPTED, ack_type)
                else:
                    mav.mission_request_int_send(*src, self.next_seq(), mtype)
            elif kind == "MISSION_ITEM_INT" and self.ardupilot_nacks:
                done = count == 0 or self.next_seq() is None
                mav.mission_ack_send(*src, mavlink.MAV_MISSION_ERROR if done
                                     else mavlink.MAV_MISSION_INVALID_SEQUENCE, msg.mission_type)
            elif kind == "MISSION_REQUEST_LIST":
                self.list_requests += 1
                self.serving = 0
                mav.mission_count_send(*src, len(self.lists[msg.mission_type]), msg.mission_type)
            elif kind == "MISSION_REQUEST_INT" and not self.mute_items:
                items = self.lists[msg.mission_type]
                if self.drop_download_at is not None:
                    if msg.seq == self.drop_download_at and self.list_requests == 1:
                        self.serving = None
                    if self.serving is None or msg.seq not in (self.serving, self.serving - 1):
                        continue
                    self.serving = max(self.serving, msg.seq + 1)
                if msg.seq < len(items):
                    it = items[msg.seq]
                    if msg.seq == self.corrupt_seq and msg.mission_type == 0:
                        it = WireItem(it.seq, it.frame, it.command, it.param1, it.param2 + 1.0,
                                      it.param3, it.param4, it.x, it.y, it.z, it.mission_type)
                    it.send(mav, *src)

    def next_seq(self) -> int | None:
        """The item this upload asks for next (None when it has them all)."""
        n = len(self.incoming)
        return self.order[n] if n < len(self.order) else None

    def _reboot(self, stored: dict[int, list[WireItem]]) -> None:
        """Silence (no heartbeat, input lost) for ``reboot_gap_s``, then a fresh boot."""
        end = time.monotonic() + self.reboot_gap_s
        while time.monotonic() < end and not self.stop.is_set():
            self.conn.recv_match(blocking=True, timeout=0.02)
        self.lists = {t: list(items) for t, items in stored.items()}
        self.incoming, self.order, self.serving = {}, [], None
        self.conn.mav.seq = 0  # packet counters restart with the autopilot


class FaultyWire:
    """A ``write(bytes)`` target for a vehicle's packets that mangles the stream, seeded:
    before a packet, with probability ``garbage``, a datagram of random bytes (sometimes
    starting with a MAVLink magic byte); with probability ``truncate``, the packet cut short
    instead of whole; with ``duplicate``, every packet (as sent) twice."""

    def __init__(self, conn: Any = None, *, garbage: float = 0.0, truncate: float = 0.0,
                 duplicate: bool = False, seed: int = 0) -> None:
        self.conn = conn
        self.garbage, self.truncate, self.duplicate = garbage, truncate, duplicate
        self.rng = random.Random(seed)
        self.lock = threading.Lock()
        self.mangled = 0

    def write(self, buf: bytes) -> None:
        with self.lock:
            out: list[bytes] = []
            if self.rng.random() < self.garbage:
                junk = bytes(self.rng.randrange(256) for _ in range(self.rng.randint(1, 40)))
                out.append(bytes([self.rng.choice((0xFD, 0xFE, 0x55))]) + junk)
                self.mangled += 1
            if self.rng.random() < self.truncate:
                buf = buf[:self.rng.randint(1, len(buf) - 1)]
                self.mangled += 1
            out += [buf, buf] if self.duplicate else [buf]
            for b in out:
                try:
                    self.conn.write(b)
                except OSError:  # no peer yet
                    pass


def rtl_plan(site: Site, points: list[tuple[float, float]], v: float = 8.0) -> Plan:
    items = [nav(site, Cmd.NAV_TAKEOFF, (0, 0)), speed(v)]
    items += [nav(site, Cmd.NAV_WAYPOINT, p) for p in points]
    items.append(MissionItem(int(Cmd.NAV_RETURN_TO_LAUNCH), [0.0] * 7, int(Frame.MISSION)))
    return plan_of(site, items)
