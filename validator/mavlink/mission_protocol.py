"""The MAVLink 2 mission protocol from the ground station's side: upload or download one
mission, fence or rally list.

An upload is MISSION_COUNT -> MISSION_REQUEST_INT -> MISSION_ITEM_INT ... -> MISSION_ACK, the
vehicle asking for each item; a download the reverse, the ground station asking. A rejected
transfer (MISSION_ACK with an error) fails at once with the MAV_MISSION_RESULT name; lost or
duplicated packets restart the transfer, a few times at most.
"""

from __future__ import annotations

import math
import re
import time
from typing import Any

from validator.item_numbers import list_item_label
from validator.mavlink.connection import Connection, LinkClosed, LinkError
from validator.mavlink.wire import MissionType, WireItem, mavlink, mission_result_name

TRANSFER_ATTEMPTS = 5  # whole-transfer restarts when the vehicle loses its place
RESENDS_BEFORE_RESTART = 4  # of the last item, waiting for the final ACK
# Silence mid-upload after which the vehicle has given up re-requesting and MISSION_COUNT
# starts the transfer again (MAVSDK gives up after 5 requests 0.5 s apart, ArduPilot later).
RESTART_AFTER_S = 3.0
# ... and after an INVALID_SEQUENCE NACK: ArduPilot sends one for every item it did not ask
# for (a duplicate, or one overtaken on the link) and goes on, asking again for what it
# wants within 1 s; a vehicle that abandoned the transfer instead stays silent.
RESTART_AFTER_NACK_S = 2.5
# A booting ArduPilot answers MISSION_COUNT with NO_SPACE until its mission storage is set up
# ("Only 0 items are supported"): keep asking this long before calling the refusal final.
BOOT_PATIENCE_S = 60.0
_ROOM = re.compile(r"Only (\d+) items are supported")

_MISSION_REQUESTS = ("MISSION_REQUEST_INT", "MISSION_REQUEST")
# Results after which starting the transfer again can succeed (lost or duplicated packets).
# MAV_MISSION_ERROR is one: ArduPilot answers so an item that reaches it after its transfer
# ended (a duplicate, or one delayed past the end); a real refusal repeats every attempt.
_RESTARTABLE = {
    mavlink.MAV_MISSION_INVALID_SEQUENCE,
    mavlink.MAV_MISSION_OPERATION_CANCELLED,
    mavlink.MAV_MISSION_ERROR,
}


# NACKs a download passes over: ArduPilot DENIES a download while it receives an upload (one
# we gave up confirming goes on until its own timeout), and the others can be late answers
# to an upload's duplicated items.
_STALE_OR_BUSY = {mavlink.MAV_MISSION_DENIED, *_RESTARTABLE}


class UnconfirmedUpload(LinkError):
    """Every item of a list went out, and the vehicle answered the last one with a NACK
    that a lost final ACK also explains (ArduPilot NACKs a repeated last item with
    MAV_MISSION_ERROR once its transfer is complete). Only reading the list back can tell;
    the message is the NACK, for when it does not hold the list."""

    def __init__(self, message: str, mission_type: MissionType) -> None:
        super().__init__(message)
        self.mission_type = mission_type


def _mission_room(link: Connection) -> int | None:
    """How many mission items the vehicle last said it has room for (ArduPilot says so in a
    STATUSTEXT with its NO_SPACE refusal), or None if it never said."""
    for text in reversed(link.statustexts):
        m = _ROOM.search(text)
        if m:
            return int(m.group(1))
    return None


def upload_list(link: Connection, items: tuple[WireItem, ...],
                mission_type: MissionType) -> bool:
    """Upload one list. Returns True once the vehicle ACKs it as accepted, False when every
    item was requested and sent but the final ACK never came (the caller's read-back then
    decides). Raises :class:`UnconfirmedUpload` when the last item drew a NACK a lost ACK
    also explains, :class:`LinkError` on any other NACK (one that may come from a packet
    lost or duplicated on the link only after :data:`TRANSFER_ATTEMPTS` tries) or when the
    vehicle falls silent.

    The vehicle drives the transfer and re-requests what it misses; we only repeat
    MISSION_COUNT until the first request, and the last item until the ACK. (Repeating
    items mid-transfer would keep resetting the vehicle's own re-request timer, which is also
    why this loop does not use :meth:`Connection.exchange`, which sends on every wake-up.)
    A request is answered with the item it names, whatever the order, as often as it comes.
    """
    label = mission_type.label
    count = len(items)
    ts, tc = link.target
    last_progress = time.monotonic()
    first_refusal: float | None = None  # of a NO_SPACE a booting vehicle may take back
    refusal: tuple[int, str] | None = None  # the last restartable NACK (result, text)
    attempt = 0
    while attempt < TRANSFER_ATTEMPTS:
        attempt += 1
        link.mav.mission_count_send(ts, tc, count, int(mission_type))
        last_send = time.monotonic()
        last_sent: int | None = None
        final_resends = 0
        highest = -1
        out_of_sequence = False  # an INVALID_SEQUENCE since the last request
        while True:
            now = time.monotonic()
            if now - last_progress > link.timeout_s:
                where = (f"after {_name(link, mission_type, highest)} ({highest + 1} of "
                         f"{count} sent)" if highest >= 0 else "to MISSION_COUNT")
                raise LinkError(f"{label} upload: vehicle stopped answering {where} "
                                f"(no reply for {link.timeout_s:g} s); upload incomplete")
            patience = RESTART_AFTER_NACK_S if out_of_sequence else RESTART_AFTER_S
            if last_sent is not None and (highest < count - 1 or out_of_sequence) and (
                now - last_progress > patience
            ):
                break  # the vehicle gave up re-requesting (MAVSDK: after 5): start again
            if now - last_send >= link.retry_s:
                if last_sent is None:
                    link.mav.mission_count_send(ts, tc, count, int(mission_type))
                elif highest == count - 1 and not out_of_sequence:
                    if final_resends >= RESENDS_BEFORE_RESTART:
                        return False
                    items[count - 1].send(link.mav, ts, tc)
                    final_resends += 1
                last_send = now
            try:
                msg = link.recv(
                    (*_MISSION_REQUESTS, "MISSION_ACK"),
                    min(last_send + link.retry_s, last_progress + link.timeout_s),
                    lambda m: getattr(m, "mission_type", 0) == int(mission_type),
                )
            except LinkClosed as err:
                where = (f"after {_name(link, mission_type, highest)} ({highest + 1} of "
                         f"{count} sent)" if highest >= 0 else "at its start")
                raise LinkError(f"{label} upload: {err} {where}; upload incomplete, upload "
                                "again once it is back") from None
            if msg is None:
                continue
            if msg.get_type() == "MISSION_ACK":
                if msg.type == mavlink.MAV_MISSION_ACCEPTED:
                    if highest == count - 1:
                        return True
                    continue  # a stale ACK from an earlier attempt
                name = mission_result_name(msg.type)
                at = (f" at {_name(link, mission_type, last_sent)}" if last_sent is not None
                      else "")
                if msg.type == mavlink.MAV_MISSION_INVALID_SEQUENCE and last_sent is not None:
                    out_of_sequence = True  # an item it did not ask for: it asks again
                    continue
                if msg.type == mavlink.MAV_MISSION_ERROR and highest == count - 1:
                    raise UnconfirmedUpload(f"{label} upload: vehicle rejected it with "
                                            f"{name}{at}", mission_type)
                if msg.type in _RESTARTABLE:
                    refusal = (int(msg.type), f"{label} upload: vehicle rejected it with "
                                              f"{name}{at}")
                    last_progress = time.monotonic()
                    break  # start the transfer again
                if msg.type == mavlink.MAV_MISSION_NO_SPACE and last_sent is None:
                    # ArduPilot says its room in a STATUSTEXT that may follow the ACK
                    link.recv((), time.monotonic() + 1.0)
                    room = _mission_room(link)
                    if room:
                        raise LinkError(f"{label} upload: vehicle rejected it with {name}: "
                                        f"it has room for {room} items, the plan needs "
                                        f"{count}")
                    if first_refusal is None:
                        first_refusal = time.monotonic()
                    patience = BOOT_PATIENCE_S if room == 0 else link.timeout_s
                    if time.monotonic() - first_refusal < patience:
                        last_progress = time.monotonic()  # booting: ask again
                        attempt -= 1
                        break
                raise LinkError(f"{label} upload: vehicle rejected it with {name}{at}")
            seq = int(msg.seq)
            if seq >= count:
                continue
            items[seq].send(link.mav, ts, tc)
            out_of_sequence = False
            last_sent, highest = seq, max(highest, seq)
            last_progress = last_send = time.monotonic()
    if refusal is not None and refusal[0] == mavlink.MAV_MISSION_ERROR:
        raise LinkError(refusal[1])  # refused every time: say so, as at the first
    raise LinkError(f"{label} upload: gave up after {TRANSFER_ATTEMPTS} attempts; "
                    "the link loses too many packets")


def _name(link: Connection, mission_type: MissionType, seq: int) -> str:
    """The item ``seq`` of a list as a person reads it: the same number from ArduPilot and PX4
    (:mod:`validator.item_numbers`)."""
    return list_item_label(seq, home_item=link.vehicle.is_ardupilot,
                           mission_type=int(mission_type))


def _is_answer(m: Any, mission_type: int, seq: int) -> bool:
    """Whether ``m`` answers a download of ``mission_type``; an item only when it is ``seq``."""
    if getattr(m, "mission_type", 0) != mission_type:
        return False
    return bool(m.get_type() != "MISSION_ITEM_INT" or int(m.seq) == seq)


def download_list(link: Connection, mission_type: MissionType) -> tuple[WireItem, ...]:
    """Download one list from the vehicle (we drive: one request per item, repeated after
    ``retry_s``; after ``RESTART_AFTER_S`` of silence the vehicle has given up on the transfer
    and MISSION_REQUEST_LIST opens it again)."""
    label = mission_type.label
    ts, tc = link.target
    mtype = int(mission_type)
    count: int | None = None
    out: list[WireItem] = []
    last_open = -math.inf  # of the last reopening MISSION_REQUEST_LIST
    opened = False  # a MISSION_REQUEST_LIST re-sent mid-download awaits its answer
    best = 0  # most items any attempt got
    fruitless = 0  # attempts in a row that got no further than ``best``
    nack = ""  # the last NACK passed over

    def request() -> None:
        nonlocal last_open, opened, best, fruitless
        now = time.monotonic()
        if count is not None and now - max(answers.since, last_open) > RESTART_AFTER_S:
            # Each reopen starts again at item 0: go on while attempts get further.
            fruitless = fruitless + 1 if len(out) <= best else 0
            best = max(best, len(out))
            if fruitless >= TRANSFER_ATTEMPTS:
                raise LinkError(f"{label} download: gave up after {TRANSFER_ATTEMPTS} "
                                "attempts without progress; the link loses too many packets")
            opened = True
            last_open = now
            link.mav.mission_request_list_send(ts, tc, mtype)
        elif count is None:
            link.mav.mission_request_list_send(ts, tc, mtype)
        if count is not None:
            link.mav.mission_request_int_send(ts, tc, len(out), mtype)

    answers = link.exchange(request, ("MISSION_COUNT", "MISSION_ITEM_INT", "MISSION_ACK"),
                            lambda m: _is_answer(m, mtype, len(out)))
    for msg in answers:
        if msg is None:
            pass  # silence: the request goes again
        elif msg.get_type() == "MISSION_ACK":
            if msg.type == mavlink.MAV_MISSION_ACCEPTED:
                pass  # a late ACK to another transfer
            elif opened and msg.type in _RESTARTABLE:
                out.clear()  # the vehicle wants the transfer from the start
            elif msg.type in _STALE_OR_BUSY:
                nack = mission_result_name(msg.type)  # ask on: the timeout decides
            else:
                raise LinkError(f"{label} download: vehicle refused it with "
                                f"{mission_result_name(msg.type)}")
        elif msg.get_type() == "MISSION_COUNT":
            if count is not None and int(msg.count) != count:
                raise LinkError(f"{label} download: the list changed during the download "
                                f"({count} then {msg.count} items)")
            if count is None:
                answers.progress()
            elif opened:
                out.clear()  # a reopened transfer starts at item 0 (MAVSDK insists)
            count = int(msg.count)
            opened = False
        else:
            out.append(WireItem.from_msg(msg))
            answers.progress()
        if count is not None and len(out) >= count:
            break
    else:
        what = ("MISSION_REQUEST_LIST" if count is None else
                f"the request for {_name(link, mission_type, len(out))} ({len(out) + 1} of "
                f"{count})")
        raise LinkError(f"{label} download: no answer to {what} within {link.timeout_s:g} s"
                        + (f" (last answer: {nack})" if nack else ""))
    link.mav.mission_ack_send(ts, tc, mavlink.MAV_MISSION_ACCEPTED, mtype)
    return tuple(out)
