"""Start a real autopilot's SITL binary for one flight, and always stop it again.

``validate-mission --sitl-binary PATH`` (or ``$ARDUPILOT_SITL``) flies a plan on the autopilot
firmware itself, built for this host, instead of our model vehicle. :func:`ardupilot_sitl`
starts ArduCopter SITL the way its own tools do::

    arducopter --model + --speedup S --defaults copter.parm -w --home LAT,LON,ALT,0 -I N

in a fresh temporary directory (it writes ``eeprom.bin`` and logs to its working directory;
``-w`` starts from the defaults, not from an earlier run), with the built-in ``+`` quad physics,
which runs in lockstep with the autopilot at ``speedup`` simulated seconds per wall second.
Instance ``N`` is the first whose ports are free: SERIAL0, the link we use, listens on TCP
``5760 + 10 N``. The process and everything it starts run in their own process group, which is
terminated when the ``with`` block ends, however it ends (an error, Ctrl-C, SIGTERM through
:func:`terminate_on_sigterm`).

The default parameter file is the one ArduPilot's autotest uses
(``Tools/autotest/default_params/copter.parm`` in its source): found beside the binary's
source tree, or given with ``--sitl-defaults`` / ``$ARDUPILOT_SITL_DEFAULTS``.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import FrameType

from validator.errors import InputError

BINARY_ENV = "ARDUPILOT_SITL"
DEFAULTS_ENV = "ARDUPILOT_SITL_DEFAULTS"
SERIAL0_BASE_PORT = 5760  # instance N listens on 5760 + 10 N (SERIAL0), +2 and +3 (SERIAL1/2)
INSTANCE_PORT_STEP = 10
MAX_INSTANCE = 50
STOP_GRACE_S = 5.0
DEFAULTS_RELATIVE = ("Tools", "autotest", "default_params", "copter.parm")


def find_binary(path: str | None) -> Path | None:
    """The SITL binary to run: ``path``, else ``$ARDUPILOT_SITL``, else None (no autopilot
    available: the caller flies the built-in model)."""
    chosen = path or os.environ.get(BINARY_ENV) or None
    if chosen is None:
        return None
    p = Path(chosen).expanduser()
    if not p.is_file() or not os.access(p, os.X_OK):
        source = "--sitl-binary" if path else f"${BINARY_ENV}"
        raise InputError(f"{source} {chosen}: not an executable file")
    return p


def find_defaults(binary: Path, path: str | None = None) -> Path:
    """The SITL's default parameter file: ``path``, ``$ARDUPILOT_SITL_DEFAULTS``, or
    ``copter.parm`` in the ArduPilot source tree the binary was built in (``build/sitl/bin/``
    under it) or beside the binary."""
    given = path or os.environ.get(DEFAULTS_ENV)
    if given:
        p = Path(given).expanduser()
        if not p.is_file():
            raise InputError(f"--sitl-defaults {given}: no such file")
        return p
    real = binary.resolve()
    candidates = [real.parents[3].joinpath(*DEFAULTS_RELATIVE)] if len(real.parents) > 3 else []
    candidates += [binary.parent / "copter.parm", real.parent / "copter.parm"]
    for c in candidates:
        if c.is_file():
            return c
    raise InputError(f"--sitl-binary {binary}: no default parameter file found (looked for "
                     f"{', '.join(str(c) for c in candidates)}); pass --sitl-defaults "
                     "PATH/TO/Tools/autotest/default_params/copter.parm")


def _port_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def free_instance() -> int:
    """The first SITL instance number whose SERIAL0-2 ports are all free."""
    for n in range(MAX_INSTANCE):
        base = SERIAL0_BASE_PORT + INSTANCE_PORT_STEP * n
        if all(_port_free(base + k) for k in (0, 2, 3)):
            return n
    raise InputError(f"no free SITL instance: TCP ports {SERIAL0_BASE_PORT}.."
                     f"{SERIAL0_BASE_PORT + INSTANCE_PORT_STEP * MAX_INSTANCE} are all taken")


def _wait_listening(port: int, proc: subprocess.Popen[bytes], log: Path, patience_s: float) -> None:
    deadline = time.monotonic() + patience_s
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise InputError(f"the SITL exited with status {proc.returncode} before listening "
                             f"({_tail(log)})")
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            s.settimeout(0.2)
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.1)
    raise InputError(f"the SITL did not open TCP port {port} within {patience_s:g} s "
                     f"({_tail(log)})")


def _tail(log: Path, lines: int = 2) -> str:
    try:
        text = log.read_text(errors="replace").strip().splitlines()
    except OSError:
        return "no output"
    return " | ".join(text[-lines:]) or "no output"


def _stop(proc: subprocess.Popen[bytes]) -> None:
    """Terminate the SITL's process group, killing it if it lingers."""
    if proc.poll() is not None:
        return
    try:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(STOP_GRACE_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    except ProcessLookupError:
        pass


@contextmanager
def ardupilot_sitl(
    binary: Path,
    home: tuple[float, float, float],
    *,
    speedup: float,
    defaults: Path,
    start_patience_s: float = 30.0,
) -> Iterator[str]:
    """Run ArduCopter SITL at ``home`` (lat deg, lon deg, alt m AMSL) for a ``with`` block;
    yields the pymavlink connection string of its SERIAL0 (``tcp:127.0.0.1:PORT``)."""
    lat, lon, alt = home
    instance = free_instance()
    port = SERIAL0_BASE_PORT + INSTANCE_PORT_STEP * instance
    workdir = Path(tempfile.mkdtemp(prefix="nfz-sitl-"))
    log = workdir / "sitl.log"
    argv = [str(binary), "--model", "+", "--speedup", f"{speedup:g}", "--defaults",
            str(defaults), "-w", "--home", f"{lat:.9f},{lon:.9f},{alt:.3f},0",
            "-I", str(instance)]
    try:
        with open(log, "wb") as out:
            proc = subprocess.Popen(argv, cwd=workdir, stdout=out, stderr=subprocess.STDOUT,
                                    stdin=subprocess.DEVNULL, start_new_session=True)
    except OSError as err:
        shutil.rmtree(workdir, ignore_errors=True)
        raise InputError(f"--sitl-binary {binary}: cannot start ({err.strerror})") from None
    try:
        _wait_listening(port, proc, log, start_patience_s)
        yield f"tcp:127.0.0.1:{port}"
    finally:
        _stop(proc)
        shutil.rmtree(workdir, ignore_errors=True)


def terminate_on_sigterm() -> None:
    """Turn SIGTERM into KeyboardInterrupt, so ``with`` blocks (and the SITL they started)
    are left as on Ctrl-C."""

    def handler(_sig: int, _frame: FrameType | None) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, handler)
