"""A bad radio link on loopback: a UDP relay between a ground station and a vehicle that drops,
duplicates, reorders and delays MAVLink packets at random (seeded), each direction on its own.

::

    with LossyRelay("tcp:127.0.0.1:5760", LinkFaults.lossy(0.2), seed=1) as relay:
        upload_plan(plan, relay.url)          # relay.url is udpout:127.0.0.1:PORT

The ground station talks UDP to the relay's own loopback port (``relay.url``); the relay
talks to the vehicle at ``upstream``: ``tcp:HOST:PORT`` (ArduPilot SITL's SERIAL0: the byte
stream is cut into whole MAVLink packets, so a fault drops a packet, never half of one; the
relay connects again when the vehicle reboots and closes its port), ``udpout:HOST:PORT`` (a
vehicle listening there, e.g. ``sitl-vehicle``) or ``udpin:HOST:PORT`` (a vehicle sending
there, e.g. PX4's 14540 + N). Every address is loopback: the relay is a test tool, not a
router. It stops by itself after ``duration_s`` (and when the ``with`` block ends).

Faults, per packet and direction: dropped with probability ``drop``; otherwise sent twice with
probability ``duplicate``; held back a further ``reorder_s`` (so that later packets overtake
it) with probability ``reorder``; and every packet delayed by a uniform ``0..delay_s``.
:meth:`LossyRelay.cut` and :meth:`LossyRelay.restore` (or ``outages``) silence both
directions for a while: a link gap. ``python -m validator.mavlink.lossy_relay`` runs one for
a user's own ground station.
"""

from __future__ import annotations

import argparse
import heapq
import ipaddress
import random
import selectors
import socket
import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Self

from validator.errors import CommandParser, InputError, UserError, report_error

DEFAULT_DURATION_S = 600.0
RECONNECT_S = 0.5  # between attempts to reach a TCP vehicle that closed its port
_MAX_DATAGRAM = 65535
_V1, _V2 = 0xFE, 0xFD
_COMMAND_ACK = 77  # MAVLink message id


@dataclass(frozen=True)
class LinkFaults:
    """What happens to the packets of one direction (probabilities 0..1, seconds)."""

    drop: float = 0.0
    duplicate: float = 0.0
    reorder: float = 0.0
    reorder_s: float = 0.3
    delay_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("drop", "duplicate", "reorder"):
            p = getattr(self, name)
            if not 0.0 <= p < 1.0:
                raise InputError(f"--{name}: must be in [0, 1), got {p:g}")
        for name in ("reorder_s", "delay_s"):
            if not 0.0 <= getattr(self, name) <= 10.0:
                raise InputError(f"--{name.replace('_s', '')}: must be 0..10 s, "
                                 f"got {getattr(self, name):g}")

    @classmethod
    def lossy(cls, rate: float) -> LinkFaults:
        """The bad link the loss-rate figures are measured on: ``rate`` of the packets
        dropped, a quarter as many duplicated and as many overtaken (held 0.3 s), every packet
        delayed by up to 50 ms."""
        return cls(drop=rate, duplicate=rate / 4, reorder=rate / 4, delay_s=0.05)


@dataclass
class DirectionStats:
    """Packets of one direction: passed on (counting duplicates once), dropped (also during
    an outage), duplicated and held back to be overtaken."""

    passed: int = 0
    dropped: int = 0
    duplicated: int = 0
    reordered: int = 0


@dataclass
class _Direction:
    faults: LinkFaults
    rng: random.Random
    stats: DirectionStats = field(default_factory=DirectionStats)


def _loopback_address(url: str, what: str) -> tuple[str, str, int]:
    """(scheme, host, port) of ``url``; only loopback hosts and the schemes the relay knows."""
    scheme, _, rest = url.partition(":")
    host, _, port = rest.rpartition(":")
    if scheme not in ("tcp", "udpout", "udpin") or not host or not port.isdigit():
        raise InputError(f"{what} {url}: expected tcp:HOST:PORT, udpout:HOST:PORT or "
                         "udpin:HOST:PORT")
    try:
        loopback = host == "localhost" or ipaddress.ip_address(host).is_loopback
    except ValueError:
        loopback = False
    if not loopback:
        raise InputError(f"{what} {url}: the relay only joins loopback addresses")
    return scheme, "127.0.0.1" if host == "localhost" else host, int(port)


def message_id(packet: bytes) -> int | None:
    """The message id of one whole MAVLink 1/2 packet (None: not a packet)."""
    if len(packet) >= 6 and packet[0] == _V1:
        return packet[5]
    if len(packet) >= 10 and packet[0] == _V2:
        return packet[7] | packet[8] << 8 | packet[9] << 16
    return None


def acked_command(packet: bytes) -> int | None:
    """The command a COMMAND_ACK packet answers (None: not a COMMAND_ACK); ``command`` is the
    payload's first field, a little-endian uint16 (MAVLink 2 trims trailing zero bytes, so an
    ACCEPTED answer to a command below 256 carries one byte)."""
    if message_id(packet) != _COMMAND_ACK:
        return None
    start = 6 if packet[0] == _V1 else 10
    payload = packet[start:start + min(packet[1], 2)]
    return int.from_bytes(payload, "little")


def split_packets(buf: bytearray) -> list[bytes]:
    """Take the whole MAVLink 1/2 packets off the front of ``buf`` (a TCP byte stream; bytes
    before a start marker are skipped, an incomplete packet stays for the next read). The
    checksum is the receiver's to check."""
    out: list[bytes] = []
    while buf:
        if buf[0] not in (_V1, _V2):
            del buf[0]
            continue
        if len(buf) < 3:
            break
        if buf[0] == _V1:
            size = 6 + buf[1] + 2
        else:
            size = 10 + buf[1] + 2 + (13 if buf[2] & 0x01 else 0)
        if len(buf) < size:
            break
        out.append(bytes(buf[:size]))
        del buf[:size]
    return out


class LossyRelay:
    """The relay, running in a thread from construction until :meth:`stop` or ``duration_s``
    (use as a context manager). ``down`` and ``up`` are the faults of the two directions
    (ground station to vehicle, vehicle to ground station; ``up`` defaults to ``down``), each
    with its own random stream drawn from ``seed``. ``outages``: (start_s, length_s) windows,
    from the relay's start, in which nothing passes."""

    def __init__(self, upstream: str, down: LinkFaults, up: LinkFaults | None = None, *,
                 seed: int = 0, duration_s: float = DEFAULT_DURATION_S,
                 outages: Sequence[tuple[float, float]] = ()) -> None:
        if not 0 < duration_s <= 24 * 3600:
            raise InputError(f"--duration: must be in (0, 86400] s, got {duration_s:g}")
        self.upstream = upstream
        self._scheme, host, port = _loopback_address(upstream, "--upstream")
        self._vehicle_addr: tuple[str, int] | None = (host, port)
        rng = random.Random(seed)
        self.down = _Direction(down, random.Random(rng.random()))
        self.up = _Direction(up if up is not None else down, random.Random(rng.random()))
        self.started = time.monotonic()
        self.deadline = self.started + duration_s
        self._outages = [(self.started + a, self.started + a + b) for a, b in outages]
        self._cut = False
        self.outage_drops = 0
        # the message ids a gap kept from the vehicle, in order: a test can wait for what the
        # ground station does while cut off (its LAND, say) instead of timing it
        self.swallowed_to_vehicle: list[int] = []
        # the commands whose COMMAND_ACK reached the ground station, in order: a test can cut
        # the link once the ground station knows the mission started, not a guess after it
        self.acked_to_gcs: list[int] = []
        self._pending: list[tuple[float, int, bool, bytes]] = []  # (due, n, to_vehicle, data)
        self._counter = 0
        self._stream = bytearray()
        self._gcs_addr: tuple[str, int] | None = None
        self._stop = threading.Event()
        self._sel = selectors.DefaultSelector()
        self._gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._gcs.bind(("127.0.0.1", 0))
        self._gcs.setblocking(False)
        self._sel.register(self._gcs, selectors.EVENT_READ, "gcs")
        self._vehicle: socket.socket | None = None
        self._next_connect = 0.0
        if self._scheme != "tcp":
            self._vehicle = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            if self._scheme == "udpin":
                self._vehicle.bind((host, port))
                self._vehicle_addr = None  # learnt from the vehicle's first packet
            self._vehicle.setblocking(False)
            self._sel.register(self._vehicle, selectors.EVENT_READ, "vehicle")
        self.thread = threading.Thread(target=self._run, name="lossy-relay", daemon=True)
        self.thread.start()

    @property
    def port(self) -> int:
        return int(self._gcs.getsockname()[1])

    @property
    def url(self) -> str:
        """Where a ground station connects: pymavlink's ``udpout`` to the relay's port."""
        return f"udpout:127.0.0.1:{self.port}"

    @property
    def stats(self) -> tuple[DirectionStats, DirectionStats]:
        """(ground station to vehicle, vehicle to ground station)."""
        return self.down.stats, self.up.stats

    def cut(self) -> None:
        """Silence the link both ways until :meth:`restore`."""
        self._cut = True

    def restore(self) -> None:
        self._cut = False

    def stop(self) -> None:
        self._stop.set()
        if threading.current_thread() is not self.thread:
            self.thread.join(5.0)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # -- the relay's thread -----------------------------------------------------------------

    def _silenced(self, now: float) -> bool:
        return self._cut or any(a <= now < b for a, b in self._outages)

    def _take(self, data: bytes, to_vehicle: bool, now: float) -> None:
        """Pass ``data`` (one packet) through the faults of its direction."""
        d = self.down if to_vehicle else self.up
        if self._silenced(now):
            d.stats.dropped += 1
            self.outage_drops += 1
            msgid = message_id(data)
            if to_vehicle and msgid is not None:
                self.swallowed_to_vehicle.append(msgid)
            return
        f, rng = d.faults, d.rng
        if f.drop and rng.random() < f.drop:
            d.stats.dropped += 1
            return
        copies = 1
        if f.duplicate and rng.random() < f.duplicate:
            copies, d.stats.duplicated = 2, d.stats.duplicated + 1
        held = 0.0
        if f.reorder and rng.random() < f.reorder:
            held, d.stats.reordered = f.reorder_s, d.stats.reordered + 1
        d.stats.passed += 1
        for _ in range(copies):
            self._counter += 1
            due = now + held + (rng.uniform(0.0, f.delay_s) if f.delay_s else 0.0)
            heapq.heappush(self._pending, (due, self._counter, to_vehicle, data))

    def _deliver(self, now: float) -> None:
        while self._pending and self._pending[0][0] <= now:
            _, _, to_vehicle, data = heapq.heappop(self._pending)
            try:
                if not to_vehicle:
                    if self._gcs_addr is not None:
                        self._gcs.sendto(data, self._gcs_addr)
                        command = acked_command(data)
                        if command is not None:
                            self.acked_to_gcs.append(command)
                elif self._scheme == "tcp":
                    if self._vehicle is not None:
                        self._vehicle.sendall(data)
                elif self._vehicle is not None and self._vehicle_addr is not None:
                    self._vehicle.sendto(data, self._vehicle_addr)
            except OSError:
                if to_vehicle and self._scheme == "tcp":
                    self._drop_tcp()  # the vehicle went away: a radio loses this packet too

    def _drop_tcp(self) -> None:
        if self._vehicle is not None:
            self._sel.unregister(self._vehicle)
            self._vehicle.close()
            self._vehicle = None
            self._stream.clear()
            self._next_connect = time.monotonic() + RECONNECT_S

    def _connect_tcp(self, now: float) -> None:
        if self._vehicle is not None or now < self._next_connect:
            return
        assert self._vehicle_addr is not None
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.settimeout(0.2)
        try:
            s.connect(self._vehicle_addr)
        except OSError:
            s.close()
            self._next_connect = now + RECONNECT_S
            return
        s.setblocking(False)
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._vehicle = s
        self._sel.register(s, selectors.EVENT_READ, "vehicle")

    def _read(self, key: selectors.SelectorKey, now: float) -> None:
        """Read what waits on ``key``'s socket: everything, so that a burst does not
        overflow the socket's buffer and lose packets the statistics never saw."""
        for _ in range(1000):
            if not self._read_one(key, now):
                return

    def _read_one(self, key: selectors.SelectorKey, now: float) -> bool:
        sock: socket.socket = key.fileobj  # type: ignore[assignment]
        try:
            if key.data == "vehicle" and self._scheme == "tcp":
                data = sock.recv(_MAX_DATAGRAM)
                if not data:
                    self._drop_tcp()
                    return False
                self._stream += data
                for packet in split_packets(self._stream):
                    self._take(packet, False, now)
                return True
            data, addr = sock.recvfrom(_MAX_DATAGRAM)
        except (BlockingIOError, InterruptedError):
            return False
        except OSError:
            if key.data == "vehicle" and self._scheme == "tcp":
                self._drop_tcp()
            return False
        if not ipaddress.ip_address(addr[0]).is_loopback:
            return True  # bound to loopback, but say it: nothing from elsewhere is relayed
        if key.data == "gcs":
            self._gcs_addr = addr
            self._take(data, True, now)
        else:
            if self._scheme == "udpin":
                self._vehicle_addr = addr
            self._take(data, False, now)
        return True

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                now = time.monotonic()
                if now >= self.deadline:
                    break
                if self._scheme == "tcp":
                    self._connect_tcp(now)
                self._deliver(now)
                wait = 0.05 if not self._pending else min(0.05, self._pending[0][0] - now)
                for key, _ in self._sel.select(max(wait, 0.0)):
                    self._read(key, time.monotonic())
        finally:
            self._sel.close()
            self._gcs.close()
            if self._vehicle is not None:
                self._vehicle.close()
            self._stop.set()


# -- python -m validator.mavlink.lossy_relay ---------------------------------------------------


def _parser() -> argparse.ArgumentParser:
    p = CommandParser(
        prog="python -m validator.mavlink.lossy_relay",
        description="Relay MAVLink between a ground station and a vehicle on this machine "
                    "through a bad link: packets dropped, duplicated, reordered and delayed "
                    "at random (seeded), to try a ground station's link handling.",
    )
    p.add_argument("--upstream", required=True, metavar="URL",
                   help="the vehicle: tcp:127.0.0.1:5760 (ArduPilot SITL), udpout:HOST:PORT "
                        "or udpin:HOST:PORT; loopback only")
    p.add_argument("--loss", type=float, default=0.2, metavar="P",
                   help="drop P of the packets each way, duplicate and reorder P/4, delay up "
                        "to 50 ms (default 0.2); the options below override parts of it")
    for name, what in (("drop", "drop this fraction"), ("duplicate", "send this fraction twice"),
                       ("reorder", "hold back this fraction 0.3 s")):
        p.add_argument(f"--{name}", type=float, metavar="P", help=what)
    p.add_argument("--delay", type=float, metavar="S", help="delay each packet up to S s")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--duration", type=float, default=DEFAULT_DURATION_S, metavar="S",
                   help=f"stop after S seconds (default {DEFAULT_DURATION_S:g})")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the relay until ``--duration`` passes or Ctrl-C; exit 2 on bad input."""
    args = _parser().parse_args(argv)
    try:
        if not 0.0 <= args.loss < 1.0:
            raise InputError(f"--loss: must be in [0, 1), got {args.loss:g}")
        base = LinkFaults.lossy(args.loss)
        faults = LinkFaults(
            drop=base.drop if args.drop is None else args.drop,
            duplicate=base.duplicate if args.duplicate is None else args.duplicate,
            reorder=base.reorder if args.reorder is None else args.reorder,
            delay_s=base.delay_s if args.delay is None else args.delay,
        )
        relay = LossyRelay(args.upstream, faults, seed=args.seed, duration_s=args.duration)
    except UserError as err:
        return report_error("lossy_relay", err)
    except OSError as err:
        return report_error("lossy_relay", InputError(f"--upstream {args.upstream}: {err}"))
    print(f"relaying {relay.url} <-> {args.upstream} for {args.duration:g} s", flush=True)
    try:
        relay.thread.join()
    except KeyboardInterrupt:
        pass
    relay.stop()
    down, up = relay.stats
    print(f"to vehicle: {down.passed} passed, {down.dropped} dropped; to ground station: "
          f"{up.passed} passed, {up.dropped} dropped")
    return 0


if __name__ == "__main__":
    sys.exit(main())
