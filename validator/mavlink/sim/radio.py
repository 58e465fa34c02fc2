"""The simulated vehicle's radio: one UDP socket, seeded packet loss each way, optional signing.

Everything the vehicle sends goes through one :class:`LossyWriter`, so ``loss`` applies to
MAVSDK's mission-protocol answers as to our own telemetry. With a signing key the vehicle signs
all it sends (MAVSDK's answers re-signed as a second stream, link id 1) and its parser refuses
every packet not signed with that key, as ArduPilot does on a signed port
(:mod:`validator.mavlink.signing`).
"""

from __future__ import annotations

import random
import threading
from collections.abc import Iterator
from typing import Any

from validator.mavlink.signing import sign_and_verify
from validator.mavlink.sim.config import VehicleConfig
from validator.mavlink.wire import mavlink, mavutil


class LossyWriter:
    """A ``write(bytes)`` target that drops packets at random (thread-safe, seeded)."""

    def __init__(self, conn: Any, loss: float, rng: random.Random) -> None:
        self.conn = conn
        self.loss = loss
        self.rng = rng
        self.lock = threading.Lock()
        self.sent = 0
        self.dropped = 0

    def write(self, buf: bytes) -> None:
        with self.lock:
            if self.loss > 0 and self.rng.random() < self.loss:
                self.dropped += 1
                return
            self.sent += 1
            try:
                self.conn.write(buf)
            except OSError:
                # No peer yet, or it went away: a radio would lose this packet too.
                self.dropped += 1


class Radio:
    """The vehicle's end of the link: ``mav`` sends (lossy, signed with a key), ``received()``
    yields what reaches the vehicle, :meth:`forward` sends a packet MAVSDK built."""

    def __init__(self, listen_url: str, config: VehicleConfig) -> None:
        self.config = config
        self.conn = mavutil.mavlink_connection(listen_url, source_system=config.system_id,
                                               source_component=1)
        # one seed, split so that each direction's losses repeat whatever the other does
        rng = random.Random(config.seed)
        self._rx_rng = random.Random(rng.random())
        self.writer = LossyWriter(self.conn, config.loss, random.Random(rng.random()))
        self.mav = mavlink.MAVLink(self.writer, srcSystem=config.system_id, srcComponent=1)
        self.rx_dropped = 0
        # MAVSDK's answers, re-signed as a second stream (link id 1) when signing is on
        self._mavsdk_signer: Any = None
        self._mavsdk_signer_lock = threading.Lock()
        if config.signing_key is not None:
            sign_and_verify(self.conn.mav, config.signing_key)  # refuses unsigned input
            sign_and_verify(self.mav, config.signing_key)
            self._mavsdk_signer = mavlink.MAVLink(self.writer, srcSystem=config.system_id,
                                                  srcComponent=1)
            sign_and_verify(self._mavsdk_signer, config.signing_key, link_id=1)

    @property
    def address(self) -> tuple[str, int]:
        host, port = self.conn.port.getsockname()[:2]
        return str(host), int(port)

    def fileno(self) -> int:
        return int(self.conn.port.fileno())

    def received(self) -> Iterator[Any]:
        """The packets waiting for this vehicle, after the receive-side losses; ends when
        none is left."""
        while True:
            try:
                msg = self.conn.recv_msg()
            except OSError:
                return
            if msg is None:
                return
            if msg.get_type() == "BAD_DATA":
                continue
            if self.config.loss > 0 and self._rx_rng.random() < self.config.loss:
                self.rx_dropped += 1
                continue
            target = getattr(msg, "target_system", None)
            if target not in (None, 0, self.config.system_id):
                continue
            yield msg

    def forward(self, msg: Any) -> None:
        """Send a packet MAVSDK built (called from MAVSDK's thread): as it is, or re-signed."""
        if self._mavsdk_signer is None:
            self.writer.write(bytes(msg.get_msgbuf()))
        else:
            with self._mavsdk_signer_lock:
                self._mavsdk_signer.send(msg)

    def close(self) -> None:
        self.conn.close()
