"""A ground station's connection to one vehicle: open it, find the vehicle by its HEARTBEAT,
receive its messages, and ask it things (send, wait, send again) including COMMAND_LONG.

:class:`Connection` opens a connection string as pymavlink takes it (``udpin:HOST:PORT``,
``udpout:HOST:PORT``, ``tcp:HOST:PORT``, a serial port) and waits for the vehicle's HEARTBEAT.
Timing: every request is repeated after ``retry_s`` without an answer, and an exchange whose
vehicle has not answered for ``timeout_s`` fails with :class:`LinkError`; nothing waits longer.
"""

from __future__ import annotations

import contextlib
import io
import select
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Self

from validator.errors import InputError, UserError
from validator.mavlink import DEFAULT_TIMEOUT_S, NETWORK_URL
from validator.mavlink.signing import RefusedTraffic, carries_signature, sign_and_verify
from validator.mavlink.wire import mavlink, mavutil

GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = 190  # MAV_COMP_ID_MISSIONPLANNER, as ground stations use
DEFAULT_RETRY_S = 0.5


class LinkError(UserError):
    """The link or the vehicle failed: no heartbeat, silence, a NACK, a read-back mismatch.

    Not bad input, but something the user can act on: commands report it like one, on one line
    with exit status 2 (:class:`~validator.errors.UserError`).
    """


class LinkClosed(LinkError):
    """The vehicle closed a TCP connection: it rebooted, or its process stopped. Nothing sent
    after that reached it; a new connection (a new command) can reach it again."""


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
        with contextlib.redirect_stdout(io.StringIO()):  # pymavlink prints each TCP retry
            return mavutil.mavlink_connection(
                url,
                source_system=source_system,
                source_component=source_component,
                autoreconnect=False,
                retries=max(0, int(timeout_s) - 1),
            )
    except Exception as err:  # pymavlink raises OSError, ValueError, SerialException...
        raise LinkError(f"--connect {url}: cannot open ({err})") from None


def command_name(command: int) -> str:
    entry = mavlink.enums["MAV_CMD"].get(int(command))
    return entry.name if entry is not None else str(command)


class Connection:
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
        self.closed = False  # the vehicle closed the TCP connection
        if hasattr(self.conn, "handle_eof"):
            # pymavlink prints a line and retries at every read of a closed TCP socket
            self.conn.handle_eof = self.conn.handle_disconnect = self._peer_closed
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

    def close(self) -> None:
        try:
            self.conn.close()
        except Exception:  # closing twice or a serial port gone: nothing left to do
            pass

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _peer_closed(self) -> None:
        self.closed = True

    def _keep_statustext(self, msg: Any) -> None:
        if msg.get_type() == "STATUSTEXT":
            self.statustexts.append(str(msg.text))

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
            if self.closed:
                raise LinkClosed("the vehicle closed the connection (it rebooted or stopped)")
            self._heartbeat_if_due()
            try:
                msg = self.conn.recv_msg()
            except OSError as err:  # a TCP reset: pymavlink re-raises it after handle_disconnect
                if self.closed:
                    continue
                raise LinkError(f"--connect {self.url}: {err.strerror or err}") from None
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

    def exchange(self, send: Callable[[], None], types: Iterable[str],
                 accept: Callable[[Any], bool] | None = None, *,
                 resend_s: float | None = None) -> Exchange:
        """Ask the vehicle something until it answers: see :class:`Exchange`; ``resend_s``
        defaults to the link's ``retry_s``."""
        return Exchange(self, send, tuple(types), accept,
                        self.retry_s if resend_s is None else resend_s)

    # -- commands --------------------------------------------------------------------------

    def command(self, command: int, *params: float, accept_in_progress: bool = True) -> int:
        """Send COMMAND_LONG (repeated on silence) and return the MAV_RESULT of its ACK."""
        p = [float(v) for v in params] + [0.0] * (7 - len(params))
        ts, tc = self.target
        confirmation = 0

        def send() -> None:
            nonlocal confirmation
            self.mav.command_long_send(ts, tc, command, confirmation, *p)
            confirmation = min(confirmation + 1, 255)

        # a command is slower to answer than a message: allow three retry periods per send, but
        # send at least three times within the timeout (--timeout 3 left two sends, 1.5 s
        # apart: on 5 % loss both were lost about once a hundred commands)
        answers = self.exchange(send, ["COMMAND_ACK"], lambda m: int(m.command) == int(command),
                                resend_s=min(3 * self.retry_s, self.timeout_s / 3))
        for msg in answers:
            if msg is None:
                continue
            if msg.result == mavlink.MAV_RESULT_IN_PROGRESS and accept_in_progress:
                answers.progress()  # the vehicle is working on it: wait a timeout more
                continue
            return int(msg.result)
        raise LinkError(f"command {command_name(command)}: no COMMAND_ACK within "
                        f"{self.timeout_s:g} s")

    def command_ok(self, command: int, *params: float) -> None:
        """:meth:`command`, raising :class:`LinkError` unless the vehicle accepts it."""
        result = self.command(command, *params)
        if result != mavlink.MAV_RESULT_ACCEPTED:
            name = mavlink.enums["MAV_RESULT"][result].name if result in mavlink.enums[
                "MAV_RESULT"] else str(result)
            raise LinkError(f"command {command_name(command)}: vehicle answered {name}")


class Exchange:
    """One request-and-answer exchange, the ground station's side of every MAVLink protocol:
    ``send()`` the request, wait up to ``resend_s`` for a message of ``types`` that
    ``accept`` takes, send again, and so on. Iterating yields each answer, or None after a
    silence; it ends once the vehicle has given no useful answer for the connection's
    ``timeout_s``: since the exchange began, or since the caller last called
    :meth:`progress` (a useful answer that is not yet the end)."""

    def __init__(self, connection: Connection, send: Callable[[], None], types: tuple[str, ...],
                 accept: Callable[[Any], bool] | None, resend_s: float) -> None:
        self.connection = connection
        self.send = send
        self.types = types
        self.accept = accept
        self.resend_s = resend_s
        self.since = time.monotonic()  # of the last progress

    def progress(self) -> None:
        self.since = time.monotonic()

    def __iter__(self) -> Iterator[Any | None]:
        c = self.connection
        while True:
            self.send()
            yield c.recv(self.types, min(time.monotonic() + self.resend_s,
                                         self.since + c.timeout_s), self.accept)
            if time.monotonic() - self.since > c.timeout_s:
                return
