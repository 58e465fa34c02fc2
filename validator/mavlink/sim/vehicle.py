"""The simulated vehicle as a process: a :class:`~.copter.Copter` on a :class:`~.radio.Radio`
with a MAVSDK mission server, run in simulated time in a thread or in the foreground."""

from __future__ import annotations

import select
import threading
import time
from collections.abc import Callable
from typing import Any

from validator.geodesy import LocalFrame
from validator.mavlink.sim.commands import Commands
from validator.mavlink.sim.config import VehicleConfig
from validator.mavlink.sim.copter import Copter
from validator.mavlink.sim.mission_server import MissionServer
from validator.mavlink.sim.params import ParamTable
from validator.mavlink.sim.radio import Radio

MISSION_CURRENT_PERIOD_S = 0.2  # simulated seconds; HEARTBEAT and the rest once a second


class SitlVehicle(Copter):
    """The simulated ArduCopter. ``start()`` runs it in a background thread, ``stop()`` ends
    it; or call :meth:`run` in the foreground. ``address`` is the bound (host, port)."""

    def __init__(self, listen_url: str, config: VehicleConfig) -> None:
        if not config.speedup > 0:
            raise ValueError("speedup must be > 0")
        if not 0.0 <= config.loss < 1.0:
            raise ValueError("loss must be in [0, 1)")
        if not listen_url.startswith(("udpin:", "udp:")):
            raise ValueError("listen on UDP, e.g. udpin:127.0.0.1:14550")
        frame = LocalFrame(*config.home)
        # parameters first: a bad --param is refused before a socket is opened
        param_table = ParamTable(config, config.limits)
        self.radio = Radio(listen_url, config)
        self.conn = self.radio.conn
        self.writer = self.radio.writer
        self.mission_server = MissionServer(config.system_id, self.radio.mav, self.radio.forward,
                                            lambda: self.home_lla)
        super().__init__(config, frame, param_table, self.radio.mav, self.mission_server.lists)
        self.commands = Commands(self)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def rx_dropped(self) -> int:
        """Packets to the vehicle dropped by the simulated loss."""
        return self.radio.rx_dropped

    @property
    def address(self) -> tuple[str, int]:
        return self.radio.address

    # -- lifecycle -------------------------------------------------------------------------

    def start(self) -> SitlVehicle:
        """Run in a daemon thread; returns at once."""
        self.mission_server.start()
        self._thread = threading.Thread(target=self._loop, name="sitl-vehicle", daemon=True)
        self._thread.start()
        return self

    def run(self) -> None:
        """Run in the calling thread until :meth:`stop` (or KeyboardInterrupt)."""
        self.mission_server.start()
        try:
            self._loop()
        finally:
            self._close()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
            self._close()

    def __enter__(self) -> SitlVehicle:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _close(self) -> None:
        self.mission_server.close()
        self.radio.close()

    # -- main loop -------------------------------------------------------------------------

    def _loop(self) -> None:
        cfg = self.config
        step_s = 1.0 / cfg.telemetry_hz
        wall0 = time.monotonic()
        next_step = 0.0
        last_slow_wall = -1.0
        last_slow_sim = -1.0
        last_current_sim = -1.0
        fd = self.radio.fileno()
        while not self._stop.is_set():
            for msg in self.radio.received():
                self._handle(msg)
            for mission_type in self.mission_server.updates():
                self.list_changed(mission_type)
            now = time.monotonic()
            sim_now = (now - wall0) * cfg.speedup
            if sim_now - next_step > 1.0 * cfg.speedup:
                # Starved of CPU: let simulated time slip rather than burst.
                wall0 += (sim_now - next_step) / cfg.speedup
                sim_now = next_step
            # A catch-up may hold up to a wall second of simulated time, far more than a wall
            # second of work at a high speed-up (x1e4: 200 000 steps), and it grows while the
            # machine cannot keep up: stop between steps, or stop() (SIGTERM) waits it out.
            while next_step <= sim_now and not self._stop.is_set():
                self.step(next_step, step_s)
                if next_step - last_slow_sim >= 1.0 or now - last_slow_wall >= 1.0:
                    self.send_slow()
                    last_slow_sim, last_slow_wall = next_step, now
                elif next_step - last_current_sim >= MISSION_CURRENT_PERIOD_S:
                    # often enough that a short leg shows up in a lossy recording
                    self.send_mission_current()
                    last_current_sim = next_step
                next_step += step_s
            wait = wall0 + next_step / cfg.speedup - time.monotonic()
            if wait > 0:
                select.select([fd], [], [], min(wait, 0.02))

    def _handle(self, msg: Any) -> None:
        if self.mission_server.handle(msg):
            return
        mav = self.mav
        handler: Callable[[Any], None] | None = {
            "COMMAND_LONG": self.commands.on_command,
            "COMMAND_INT": self.commands.on_command,
            "SET_MODE": self.commands.on_set_mode,
            "PARAM_REQUEST_LIST": lambda m: self.param_table.on_list(mav, m),
            "PARAM_REQUEST_READ": lambda m: self.param_table.on_read(mav, m),
            "PARAM_SET": lambda m: self.param_table.on_set(mav, m),
            "MISSION_SET_CURRENT": self.commands.on_set_current,
        }.get(msg.get_type())
        if handler is not None:
            handler(msg)
