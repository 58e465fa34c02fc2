"""A ground station's side of a MAVLink link: mission and parameter protocols over pymavlink.

:class:`Link` opens a connection string as pymavlink takes it (``udpin:HOST:PORT``,
``udpout:HOST:PORT``, ``tcp:HOST:PORT``, a serial port), waits for the vehicle's HEARTBEAT and
then speaks the MAVLink 2 mission protocol (MISSION_COUNT -> MISSION_REQUEST_INT ->
MISSION_ITEM_INT -> MISSION_ACK, and the reverse for downloads) for mission, fence and rally
lists, the parameter protocol (PARAM_SET / PARAM_VALUE) and COMMAND_LONG.

Timing: every request is repeated after ``retry_s`` without an answer, and a transfer whose
vehicle has not answered for ``timeout_s`` fails with :class:`LinkError`; nothing waits longer.
A rejected transfer (MISSION_ACK with an error) fails at once with the MAV_MISSION_RESULT name.

:func:`upload_plan` and :func:`download_plan` are what ``upload-mission`` and
``download-mission`` do. An upload is reported as a success only when all three lists read
back from the vehicle are identical, item by item, to what was sent.
"""

from __future__ import annotations

import re
import select
import struct
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from validator.autopilot.fence import FENCE_RULES
from validator.errors import InputError
from validator.geodesy import from_int_e7
from validator.mavlink import NETWORK_URL
from validator.mavlink.signing import RefusedTraffic, carries_signature, sign_and_verify
from validator.mavlink.storage import first_stored_difference, storage_losses
from validator.mavlink.wire import (
    MissionType,
    WireItem,
    WireLists,
    mavlink,
    mavutil,
    mission_result_name,
    plan_to_wire,
    wire_to_plan,
)
from validator.plan_format import Autopilot, Plan

GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = 190  # MAV_COMP_ID_MISSIONPLANNER, as ground stations use
DEFAULT_TIMEOUT_S = 10.0
DEFAULT_RETRY_S = 0.5
TRANSFER_ATTEMPTS = 5  # whole-transfer restarts when the vehicle loses its place
RESENDS_BEFORE_RESTART = 4  # of the last item, waiting for the final ACK
# Silence mid-upload after which the vehicle has given up re-requesting and MISSION_COUNT
# starts the transfer again (MAVSDK gives up after 5 requests 0.5 s apart, ArduPilot later).
RESTART_AFTER_S = 3.0
# A booting ArduPilot answers MISSION_COUNT with NO_SPACE until its mission storage is set up
# ("Only 0 items are supported"): keep asking this long before calling the refusal final.
BOOT_PATIENCE_S = 60.0
_ROOM = re.compile(r"Only (\d+) items are supported")

_MISSION_REQUESTS = ("MISSION_REQUEST_INT", "MISSION_REQUEST")
# Results after which starting the transfer again can succeed (lost or duplicated packets).
_RESTARTABLE = {
    mavlink.MAV_MISSION_INVALID_SEQUENCE,
    mavlink.MAV_MISSION_OPERATION_CANCELLED,
}


class LinkError(InputError):
    """The link or the vehicle failed: no heartbeat, silence, a NACK, a read-back mismatch.

    A subclass of :class:`InputError` so commands report it on one line with exit status 2.
    """


@dataclass(frozen=True)
class VehicleInfo:
    """Who answered: from the vehicle's HEARTBEAT."""

    system_id: int
    component_id: int
    autopilot: int  # MAV_AUTOPILOT
    vehicle_type: int  # MAV_TYPE

    @property
    def is_ardupilot(self) -> bool:
        return self.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA

    @property
    def is_px4(self) -> bool:
        return self.autopilot == mavlink.MAV_AUTOPILOT_PX4

    @property
    def autopilot_name(self) -> str:
        return {3: "ArduPilot", 12: "PX4"}.get(self.autopilot, f"MAV_AUTOPILOT {self.autopilot}")


@dataclass(frozen=True)
class ParamValue:
    """A parameter as the vehicle reports it (value decoded, MAV_PARAM_TYPE)."""

    name: str
    value: float
    param_type: int


@dataclass
class UploadReport:
    """What :func:`upload_plan` sent and verified."""

    vehicle: VehicleInfo
    counts: dict[str, int]  # items per list as sent (mission includes ArduPilot's home item)
    params: dict[str, float] = field(default_factory=dict)  # as read back from the vehicle

    def summary(self) -> str:
        c = self.counts
        text = (f"uploaded and verified {c['mission']} mission, {c['fence']} fence and "
                f"{c['rally']} rally items on system {self.vehicle.system_id} "
                f"({self.vehicle.autopilot_name})")
        if self.params:
            text += f"; {len(self.params)} parameters set"
        return text


def _check_url(url: str) -> None:
    """Refuse strings pymavlink would open as a log file to replay, a classic slip."""
    if NETWORK_URL.match(url):
        return
    path = Path(url.split(",")[0])
    if path.is_file():
        raise LinkError(f"--connect {url}: is a file, not a connection (e.g. udpin:0.0.0.0:14550)")


def open_connection(url: str, *, source_system: int, source_component: int,
                    timeout_s: float) -> Any:
    """A pymavlink connection for ``url``; failures to open raise :class:`LinkError`."""
    _check_url(url)
    try:
        return mavutil.mavlink_connection(
            url,
            source_system=source_system,
            source_component=source_component,
            autoreconnect=False,
            retries=max(0, int(timeout_s) - 1),
        )
    except Exception as err:  # pymavlink raises OSError, ValueError, SerialException...
        raise LinkError(f"--connect {url}: cannot open ({err})") from None


def _decode_param(value: float, param_type: int, bytewise: bool) -> float:
    """PARAM_VALUE's float field as the parameter's value (PX4 packs integers bytewise)."""
    if not bytewise or param_type in (mavlink.MAV_PARAM_TYPE_REAL32, mavlink.MAV_PARAM_TYPE_REAL64):
        return float(value)
    raw = struct.pack("<f", value)
    fmt = {1: "<B3x", 2: "<b3x", 3: "<H2x", 4: "<h2x", 5: "<I", 6: "<i"}.get(param_type, "<i")
    return float(struct.unpack(fmt, raw)[0])


def _encode_param(value: float, param_type: int, bytewise: bool) -> float:
    if not bytewise or param_type in (mavlink.MAV_PARAM_TYPE_REAL32, mavlink.MAV_PARAM_TYPE_REAL64):
        return float(value)
    fmt = {1: "<B3x", 2: "<b3x", 3: "<H2x", 4: "<h2x", 5: "<I", 6: "<i"}.get(param_type, "<i")
    return float(struct.unpack("<f", struct.pack(fmt, int(round(value))))[0])


def _same_param(a: float, b: float, param_type: int) -> bool:
    if param_type in (mavlink.MAV_PARAM_TYPE_REAL32, mavlink.MAV_PARAM_TYPE_REAL64):
        return struct.pack("<f", a) == struct.pack("<f", b)
    return int(round(a)) == int(round(b))


class Link:
    """A connection to one vehicle, from the ground station's side.

    ``target_system`` picks the vehicle by MAVLink system id; None takes the first autopilot
    heard. Opening waits up to ``timeout_s`` for its HEARTBEAT. With ``signing_key`` every
    packet sent is signed and every packet received that is not signed with that key is
    refused (:mod:`validator.mavlink.signing`). Use as a context manager.
    """

    def __init__(
        self,
        url: str,
        *,
        timeout_s: float = DEFAULT_TIMEOUT_S,
        target_system: int | None = None,
        retry_s: float = DEFAULT_RETRY_S,
        source_system: int = GCS_SYSTEM_ID,
        source_component: int = GCS_COMPONENT_ID,
        signing_key: bytes | None = None,
    ) -> None:
        if not timeout_s > 0:
            raise InputError(f"--timeout: must be > 0, got {timeout_s}")
        if target_system is not None and not 1 <= target_system <= 255:
            raise InputError(f"--sysid: must be 1..255, got {target_system}")
        self.url = url
        self.timeout_s = float(timeout_s)
        self.retry_s = min(float(retry_s), self.timeout_s / 4)
        self.conn = open_connection(url, source_system=source_system,
                                    source_component=source_component, timeout_s=timeout_s)
        self.mav = self.conn.mav
        # with a key: everything sent is signed, everything unsigned or signed otherwise is
        # refused, and counted here to explain a vehicle that seems silent
        self.refused: RefusedTraffic | None = None
        if signing_key is not None:
            sign_and_verify(self.mav, signing_key)
            self.refused = RefusedTraffic(signing_key)
        self.vehicle_signs = False  # its heartbeat was signed
        self._last_gcs_heartbeat = 0.0
        # called with every message from the vehicle that recv() reads, wanted or not
        self.listeners: list[Callable[[Any], None]] = [self._keep_statustext]
        self.statustexts: deque[str] = deque(maxlen=50)  # the vehicle's latest STATUSTEXTs
        # system ids of other autopilots heard on the link: a failure names them, since the
        # vehicle chosen without --sysid may not be the one the user meant
        self.other_autopilots: set[int] = set()
        try:
            self.vehicle = self._wait_vehicle(target_system)
        except BaseException:
            self.close()
            raise

    # -- plumbing --------------------------------------------------------------------------

    def close(self) -> None:
        try:
            self.conn.close()
        except Exception:  # closing twice or a serial port gone: nothing left to do
            pass

    def __enter__(self) -> Link:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _keep_statustext(self, msg: Any) -> None:
        if msg.get_type() == "STATUSTEXT":
            self.statustexts.append(str(msg.text))

    def _mission_room(self) -> int | None:
        """How many mission items the vehicle last said it has room for (ArduPilot says so
        in a STATUSTEXT with its NO_SPACE refusal), or None if it never said."""
        for text in reversed(self.statustexts):
            m = _ROOM.search(text)
            if m:
                return int(m.group(1))
        return None

    @property
    def target(self) -> tuple[int, int]:
        return self.vehicle.system_id, self.vehicle.component_id

    def _heartbeat_if_due(self) -> None:
        """Send our GCS heartbeat once a second: udpout peers learn our address from it."""
        now = time.monotonic()
        if now - self._last_gcs_heartbeat >= 1.0:
            self._last_gcs_heartbeat = now
            self.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)

    def recv(self, types: Iterable[str], deadline: float,
             accept: Callable[[Any], bool] | None = None) -> Any | None:
        """The next message of one of ``types`` from our vehicle before ``deadline``
        (``time.monotonic()``), or None. Others go to :attr:`listeners` only, so a recorder
        misses nothing while a request waits for its answer."""
        wanted = set(types)
        while True:
            self._heartbeat_if_due()
            msg = self.conn.recv_msg()
            if msg is None:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return None
                fd = self.conn.fd if getattr(self.conn, "fd", None) is not None else None
                if fd is not None:
                    select.select([fd], [], [], min(remaining, 0.05))
                else:
                    time.sleep(min(remaining, 0.01))
                continue
            if self.refused is not None:
                self.refused.note(msg)
            if hasattr(self, "vehicle") and msg.get_srcSystem() != self.vehicle.system_id:
                if msg.get_type() == "HEARTBEAT" and (
                        msg.autopilot != mavlink.MAV_AUTOPILOT_INVALID):
                    self.other_autopilots.add(msg.get_srcSystem())
                continue
            for listener in self.listeners:
                listener(msg)
            if msg.get_type() not in wanted:
                continue
            target = getattr(msg, "target_system", 0)
            if target not in (0, self.conn.source_system):
                continue
            if accept is None or accept(msg):
                return msg

    def _wait_vehicle(self, target_system: int | None) -> VehicleInfo:
        deadline = time.monotonic() + self.timeout_s
        heard: set[int] = set()
        while True:
            msg = self.recv(["HEARTBEAT"], deadline)
            if msg is None:
                if self.refused:
                    raise LinkError(f"--connect {self.url}: no signed heartbeat within "
                                    f"{self.timeout_s:g} s; {self.refused.explanation()}")
                if heard:
                    raise LinkError(
                        f"--connect {self.url}: no vehicle with system id {target_system} "
                        f"within {self.timeout_s:g} s (heard system id "
                        f"{', '.join(str(s) for s in sorted(heard))})"
                    )
                raise LinkError(f"--connect {self.url}: no heartbeat within {self.timeout_s:g} s "
                                "(is the vehicle running and sending to this address?)")
            if msg.type == mavlink.MAV_TYPE_GCS or msg.autopilot == mavlink.MAV_AUTOPILOT_INVALID:
                continue
            sysid = msg.get_srcSystem()
            if target_system is not None and sysid != target_system:
                heard.add(sysid)
                continue
            self.vehicle_signs = carries_signature(msg)
            return VehicleInfo(sysid, msg.get_srcComponent(), int(msg.autopilot), int(msg.type))

    # -- mission protocol ------------------------------------------------------------------

    def upload_list(self, items: tuple[WireItem, ...], mission_type: MissionType) -> bool:
        """Upload one list. Returns True once the vehicle ACKs it as accepted, False when every
        item was requested and sent but the final ACK never came (the caller's read-back then
        decides). Raises :class:`LinkError` on a NACK or when the vehicle falls silent.

        The vehicle drives the transfer and re-requests what it misses; we only repeat
        MISSION_COUNT until the first request, and the last item until the ACK. (Repeating
        items mid-transfer would keep resetting the vehicle's own re-request timer.)
        """
        label = mission_type.label
        count = len(items)
        ts, tc = self.target
        last_progress = time.monotonic()
        first_refusal: float | None = None  # of a NO_SPACE a booting vehicle may take back
        attempt = 0
        while attempt < TRANSFER_ATTEMPTS:
            attempt += 1
            self.mav.mission_count_send(ts, tc, count, int(mission_type))
            last_send = time.monotonic()
            last_sent: int | None = None
            final_resends = 0
            highest = -1
            while True:
                now = time.monotonic()
                if now - last_progress > self.timeout_s:
                    where = (f"after item {highest} of {count}" if highest >= 0
                             else "to MISSION_COUNT")
                    raise LinkError(f"{label} upload: vehicle stopped answering {where} "
                                    f"(no reply for {self.timeout_s:g} s); upload incomplete")
                if last_sent is not None and highest < count - 1 and (
                    now - last_progress > RESTART_AFTER_S
                ):
                    break  # the vehicle gave up re-requesting (MAVSDK: after 5): start again
                if now - last_send >= self.retry_s:
                    if last_sent is None:
                        self.mav.mission_count_send(ts, tc, count, int(mission_type))
                    elif highest == count - 1:
                        if final_resends >= RESENDS_BEFORE_RESTART:
                            return False
                        items[count - 1].send(self.mav, ts, tc)
                        final_resends += 1
                    last_send = now
                msg = self.recv(
                    (*_MISSION_REQUESTS, "MISSION_ACK"),
                    min(last_send + self.retry_s, last_progress + self.timeout_s),
                    lambda m: getattr(m, "mission_type", 0) == int(mission_type),
                )
                if msg is None:
                    continue
                if msg.get_type() == "MISSION_ACK":
                    if msg.type == mavlink.MAV_MISSION_ACCEPTED:
                        if highest == count - 1:
                            return True
                        continue  # a stale ACK from an earlier attempt
                    name = mission_result_name(msg.type)
                    if msg.type in _RESTARTABLE:
                        last_progress = time.monotonic()
                        break  # start the transfer again
                    if msg.type == mavlink.MAV_MISSION_NO_SPACE and last_sent is None:
                        # ArduPilot says its room in a STATUSTEXT that may follow the ACK
                        self.recv((), time.monotonic() + 1.0)
                        room = self._mission_room()
                        if room:
                            raise LinkError(f"{label} upload: vehicle rejected it with {name}: "
                                            f"it has room for {room} items, the plan needs "
                                            f"{count}")
                        if first_refusal is None:
                            first_refusal = time.monotonic()
                        patience = BOOT_PATIENCE_S if room == 0 else self.timeout_s
                        if time.monotonic() - first_refusal < patience:
                            last_progress = time.monotonic()  # booting: ask again
                            attempt -= 1
                            break
                    at = f" at item {last_sent}" if last_sent is not None else ""
                    raise LinkError(f"{label} upload: vehicle rejected it with {name}{at}")
                seq = int(msg.seq)
                if seq >= count:
                    continue
                items[seq].send(self.mav, ts, tc)
                last_sent, highest = seq, max(highest, seq)
                last_progress = last_send = time.monotonic()
        raise LinkError(f"{label} upload: gave up after {TRANSFER_ATTEMPTS} attempts; "
                        "the link loses too many packets")

    def download_list(self, mission_type: MissionType) -> tuple[WireItem, ...]:
        """Download one list from the vehicle (we drive: one request per item, repeated
        after ``retry_s``; after ``RESTART_AFTER_S`` of silence the vehicle has given up on the
        transfer and MISSION_REQUEST_LIST opens it again)."""
        label = mission_type.label
        ts, tc = self.target
        mtype = int(mission_type)
        count: int | None = None
        out: list[WireItem] = []
        last_progress = last_open = time.monotonic()
        opened = False  # a MISSION_REQUEST_LIST re-sent mid-download awaits its answer
        best = 0  # most items any attempt got
        fruitless = 0  # attempts in a row that got no further than ``best``
        while count is None or len(out) < count:
            now = time.monotonic()
            if now - last_progress > self.timeout_s:
                what = ("MISSION_REQUEST_LIST" if count is None
                        else f"item {len(out)} of {count}")
                raise LinkError(f"{label} download: no answer to {what} within "
                                f"{self.timeout_s:g} s")
            if count is not None and now - max(last_progress, last_open) > RESTART_AFTER_S:
                # Each reopen starts again at item 0: go on while attempts get further.
                fruitless = fruitless + 1 if len(out) <= best else 0
                best = max(best, len(out))
                if fruitless >= TRANSFER_ATTEMPTS:
                    raise LinkError(f"{label} download: gave up after {TRANSFER_ATTEMPTS} "
                                    "attempts without progress; the link loses too many "
                                    "packets")
                opened = True
                last_open = now
                self.mav.mission_request_list_send(ts, tc, mtype)
            elif count is None:
                self.mav.mission_request_list_send(ts, tc, mtype)
            if count is not None:
                self.mav.mission_request_int_send(ts, tc, len(out), mtype)
            msg = self.recv(
                ("MISSION_COUNT", "MISSION_ITEM_INT", "MISSION_ACK"),
                min(time.monotonic() + self.retry_s, last_progress + self.timeout_s),
                _answer_to(mtype, len(out)),
            )
            if msg is None:
                continue
            kind = msg.get_type()
            if kind == "MISSION_ACK":
                if msg.type == mavlink.MAV_MISSION_ACCEPTED:
                    continue  # a late ACK to something else
                if opened and msg.type in _RESTARTABLE:
                    out.clear()  # the vehicle wants the transfer from the start
                    continue
                raise LinkError(f"{label} download: vehicle refused it with "
                                f"{mission_result_name(msg.type)}")
            if kind == "MISSION_COUNT":
                if count is not None and int(msg.count) != count:
                    raise LinkError(f"{label} download: the list changed during the download "
                                    f"({count} then {msg.count} items)")
                if count is None:
                    last_progress = time.monotonic()
                elif opened:
                    out.clear()  # a reopened transfer starts at item 0 (MAVSDK insists)
                count = int(msg.count)
                opened = False
                continue
            out.append(WireItem.from_msg(msg))
            last_progress = time.monotonic()
        self.mav.mission_ack_send(ts, tc, mavlink.MAV_MISSION_ACCEPTED, mtype)
        return tuple(out)

    def upload(self, lists: WireLists) -> None:
        """Upload mission, fence and rally lists, in that order."""
        for mtype in MissionType:
            self.upload_list(lists.of(mtype), mtype)

    def download(self) -> WireLists:
        """Download all three lists."""
        return WireLists(*(self.download_list(t) for t in MissionType))

    # -- commands --------------------------------------------------------------------------

    def command(self, command: int, *params: float, accept_in_progress: bool = True) -> int:
        """Send COMMAND_LONG (repeated on silence) and return the MAV_RESULT of its ACK."""
        p = [float(v) for v in params] + [0.0] * (7 - len(params))
        ts, tc = self.target
        start = time.monotonic()
        confirmation = 0
        while True:
            self.mav.command_long_send(ts, tc, command, confirmation, *p)
            confirmation = min(confirmation + 1, 255)
            msg = self.recv(["COMMAND_ACK"], min(time.monotonic() + 3 * self.retry_s,
                                                 start + self.timeout_s),
                            lambda m: int(m.command) == int(command))
            if msg is not None:
                if msg.result == mavlink.MAV_RESULT_IN_PROGRESS and accept_in_progress:
                    start = time.monotonic()
                    continue
                return int(msg.result)
            if time.monotonic() - start > self.timeout_s:
                raise LinkError(f"command {command_name(command)}: no COMMAND_ACK within "
                                f"{self.timeout_s:g} s")

    def command_ok(self, command: int, *params: float) -> None:
        """:meth:`command`, raising :class:`LinkError` unless the vehicle accepts it."""
        result = self.command(command, *params)
        if result != mavlink.MAV_RESULT_ACCEPTED:
            name = mavlink.enums["MAV_RESULT"][result].name if result in mavlink.enums[
                "MAV_RESULT"] else str(result)
            raise LinkError(f"command {command_name(command)}: vehicle answered {name}")

    # -- parameters ------------------------------------------------------------------------

    @property
    def _bytewise(self) -> bool:
        return self.vehicle.is_px4

    def read_param(self, name: str) -> ParamValue:
        """Read one parameter by name (PARAM_REQUEST_READ -> PARAM_VALUE)."""
        ts, tc = self.target
        start = time.monotonic()
        while True:
            self.mav.param_request_read_send(ts, tc, name.encode("ascii"), -1)
            msg = self.recv(["PARAM_VALUE"], min(time.monotonic() + self.retry_s,
                                                 start + self.timeout_s),
                            lambda m: m.param_id == name)
            if msg is not None:
                return ParamValue(name, _decode_param(msg.param_value, msg.param_type,
                                                      self._bytewise), int(msg.param_type))
            if time.monotonic() - start > self.timeout_s:
                raise LinkError(f"parameter {name}: vehicle did not report it within "
                                f"{self.timeout_s:g} s (unknown parameter?)")

    def set_param(self, name: str, value: float) -> float:
        """Set one parameter and return the value the vehicle reports back; raises
        :class:`LinkError` unless it equals ``value`` (in the parameter's type)."""
        current = self.read_param(name)
        ts, tc = self.target
        start = time.monotonic()
        encoded = _encode_param(value, current.param_type, self._bytewise)
        held: float | None = None
        while True:
            self.mav.param_set_send(ts, tc, name.encode("ascii"), encoded, current.param_type)
            msg = self.recv(["PARAM_VALUE"], min(time.monotonic() + self.retry_s,
                                                 start + self.timeout_s),
                            lambda m: m.param_id == name)
            if msg is not None:
                held = _decode_param(msg.param_value, msg.param_type, self._bytewise)
                if _same_param(held, value, current.param_type):
                    return held
                # An answer to an earlier request may still carry the old value: ask again.
            if time.monotonic() - start > self.timeout_s:
                if held is not None:
                    raise LinkError(f"parameter {name}: set {value:g}, vehicle holds {held:g}")
                raise LinkError(f"parameter {name}: vehicle did not confirm {value:g} within "
                                f"{self.timeout_s:g} s")

    def set_params(self, params: Mapping[str, float]) -> dict[str, float]:
        """Set and read back each parameter in order; the values read back."""
        return {name: self.set_param(name, value) for name, value in params.items()}


def _answer_to(mission_type: int, seq: int) -> Callable[[Any], bool]:
    """Accepts download answers of ``mission_type``; items only when they are ``seq``."""

    def accept(m: Any) -> bool:
        if getattr(m, "mission_type", 0) != mission_type:
            return False
        return bool(m.get_type() != "MISSION_ITEM_INT" or int(m.seq) == seq)

    return accept


def command_name(command: int) -> str:
    entry = mavlink.enums["MAV_CMD"].get(int(command))
    return entry.name if entry is not None else str(command)


# -- what the commands do ------------------------------------------------------------------


def verify_lists(link: Link, sent: WireLists) -> None:
    """Download all three lists and raise :class:`LinkError` at the first item the vehicle
    does not hold as sent (verbatim, or as its autopilot documents to store it:
    :mod:`validator.mavlink.storage`)."""
    held = link.download()
    for mtype in MissionType:
        diff = first_stored_difference(sent.of(mtype), held.of(mtype), mtype,
                                       link.vehicle.autopilot,
                                       skip_seq0=mtype == MissionType.MISSION
                                       and link.vehicle.is_ardupilot)
        if diff is not None:
            raise LinkError(f"read-back differs from the upload: {diff}")


def fence_problems(link: Link, plan: Plan) -> list[str]:
    """Why the fence the vehicle holds for ``plan`` is off or has an unsafe breach action,
    read from the vehicle's own parameters (empty when fine, or when ``plan`` has no fence or
    the autopilot is neither ArduPilot nor PX4)."""
    autopilot = ("ardupilot" if link.vehicle.is_ardupilot
                 else "px4" if link.vehicle.is_px4 else None)
    if autopilot is None or not (plan.circles or plan.polygons):
        return []
    rules = FENCE_RULES[autopilot]
    return rules.problems({n: link.read_param(n).value for n in rules.param_names})


def upload_to(link: Link, plan: Plan, params: Mapping[str, float] | None = None, *,
              require_fence: bool = True) -> UploadReport:
    """Upload ``plan``'s three lists, set ``params`` (each read back, in order, after the
    lists: a fence is switched on only once it is loaded) and verify the lists by downloading
    them again. Raises :class:`InputError` before sending anything when the autopilot would
    store an item with another meaning (a fractional ArduPilot hold), and :class:`LinkError`
    on any failure, any difference, or, with ``require_fence``, a plan whose fence the vehicle
    then holds switched off or with a breach action that can cross another zone."""
    sent = plan_to_wire(plan, home_item=link.vehicle.is_ardupilot)
    losses = [line for mtype in MissionType
              for line in storage_losses(sent.of(mtype), link.vehicle.autopilot)]
    if losses:
        raise InputError(f"the vehicle would not keep the plan as written: {losses[0]}"
                         + (f" (and {len(losses) - 1} more)" if len(losses) > 1 else ""))
    link.upload(sent)
    got_params = link.set_params(params) if params else {}
    verify_lists(link, sent)
    if require_fence:
        problems = fence_problems(link, plan)
        if problems:
            raise LinkError(f"the mission is on the vehicle but its geofence is not protecting "
                            f"it: {problems[0]}; set the plan's parameter file (--set-params "
                            "X.param) or pass --allow-fence-off")
    return UploadReport(
        link.vehicle,
        {t.label: len(sent.of(t)) for t in MissionType},
        got_params,
    )


def upload_plan(
    plan: Plan,
    url: str,
    *,
    timeout_s: float = DEFAULT_TIMEOUT_S,
    sysid: int | None = None,
    params: Mapping[str, float] | None = None,
    require_fence: bool = True,
    signing_key: bytes | None = None,
) -> UploadReport:
    """Upload ``plan`` to the vehicle at ``url`` and verify it (``upload-mission``; see
    :func:`upload_to`); with ``signing_key``, over a signed link (:mod:`.signing`)."""
    with Link(url, timeout_s=timeout_s, target_system=sysid, signing_key=signing_key) as link, \
            _explaining(link, sysid):
        return upload_to(link, plan, params, require_fence=require_fence)


# How long a failed command without --sysid listens for other autopilots (heartbeats: 1 Hz).
OTHERS_LISTEN_S = 1.5


@contextmanager
def _explaining(link: Link, sysid: int | None) -> Iterator[None]:
    """Add to a :class:`LinkError` the other autopilots heard (without ``--sysid`` the vehicle
    is the first heard, perhaps not the one meant: then listen a moment to find out) and the
    packets a signed link refused."""
    try:
        yield
    except LinkError as err:
        if sysid is None and not link.other_autopilots:
            link.recv((), time.monotonic() + min(OTHERS_LISTEN_S, link.timeout_s))
        text = str(err)
        if link.other_autopilots:
            others = ", ".join(str(s) for s in sorted(link.other_autopilots))
            text += (f" (talking to system id {link.vehicle.system_id}; also heard system id "
                     f"{others}: choose one with --sysid)")
        if link.refused:
            text += f"; {link.refused.explanation()}"
        elif link.refused is None and link.vehicle_signs:
            text += ("; the vehicle signs its packets and may refuse unsigned ones: connect "
                     "with --signing-key FILE")
        if text == str(err):
            raise
        raise LinkError(text) from None


def home_of(link: Link) -> tuple[float, float, float] | None:
    """The vehicle's home (lat, lon, alt AMSL) from HOME_POSITION, or None if it never says."""
    ts, tc = link.target
    deadline = time.monotonic() + link.timeout_s
    while time.monotonic() < deadline:
        # The answer may come before or after the COMMAND_ACK: wait for the message itself.
        link.mav.command_long_send(ts, tc, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                   float(mavlink.MAVLINK_MSG_ID_HOME_POSITION), 0, 0, 0, 0, 0, 0)
        msg = link.recv(["HOME_POSITION"], min(deadline, time.monotonic() + 3 * link.retry_s))
        if msg is not None:
            return (float(from_int_e7(msg.latitude)), float(from_int_e7(msg.longitude)),
                    msg.altitude / 1000.0)
    return None


def download_from(link: Link) -> Plan:
    """The three lists the vehicle holds, as a :class:`Plan`."""
    lists = link.download()
    home = None if link.vehicle.is_ardupilot and lists.mission else home_of(link)
    firmware = {3: int(Autopilot.ARDUPILOTMEGA), 12: int(Autopilot.PX4)}.get(
        link.vehicle.autopilot, int(Autopilot.GENERIC))
    return wire_to_plan(lists, home_item=link.vehicle.is_ardupilot, home=home,
                        firmware_type=firmware)


def download_plan(url: str, *, timeout_s: float = DEFAULT_TIMEOUT_S,
                  sysid: int | None = None, signing_key: bytes | None = None) -> Plan:
    """What the vehicle at ``url`` holds, as a plan (``download-mission``); with
    ``signing_key``, over a signed link (:mod:`.signing`)."""
    with Link(url, timeout_s=timeout_s, target_system=sysid, signing_key=signing_key) as link, \
            _explaining(link, sysid):
        return download_from(link)

