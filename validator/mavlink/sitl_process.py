"""Start a real autopilot's SITL binary for one flight, and always stop it again.

``validate-mission --sitl-binary PATH`` (or ``$ARDUPILOT_SITL``, ``$PX4_SITL`` for PX4 plans)
flies a plan on the autopilot firmware itself, built for this host, instead of our model
vehicle. :func:`autopilot_sitl` picks the launcher by the binary's name (``px4`` is PX4,
anything else ArduCopter). :func:`ardupilot_sitl` starts ArduCopter SITL the way its own tools
do::

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

:func:`px4_sih` starts PX4's ``px4_sitl_default`` build with its built-in SIH quadrotor
(``PX4_SIMULATOR=sihsim PX4_SIM_MODEL=sihsim_quadx px4 -d -i N ETC``, ``ETC`` the build's
``etc`` beside ``bin/``) in a fresh temporary directory, so parameters and the stored mission
start clean; home is SIH_LOC_LAT0/LON0 (``PX4_HOME_LAT``/``PX4_HOME_LON`` in degrees x 1e7)
and SIH_LOC_H0 (set by a ``px4-rc.params`` the start-up script sources), the speed-up
``PX4_SIM_SPEED_FACTOR``. Instance ``N`` sends MAVLink to UDP ``14540 + N``.
"""

from __future__ import annotations

import fcntl
import math
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
from validator.geodesy import to_int_e7
from validator.wind import Wind

BINARY_ENV = "ARDUPILOT_SITL"
PX4_BINARY_ENV = "PX4_SITL"
DEFAULTS_ENV = "ARDUPILOT_SITL_DEFAULTS"
PX4_ONBOARD_BASE_PORT = 14540  # PX4 instance N's onboard link sends to UDP 14540 + N
PX4_ONBOARD_LISTEN_PORT = 14580  # ... and listens on 14580 + N
PX4_LOCK_PATH = "/tmp/px4_lock"  # PX4's per-instance server lock
SERIAL0_BASE_PORT = 5760  # instance N listens on 5760 + 10 N (SERIAL0), +2 and +3 (SERIAL1/2)
INSTANCE_PORT_STEP = 10
MAX_INSTANCE = 50
STOP_GRACE_S = 5.0
DEFAULTS_RELATIVE = ("Tools", "autotest", "default_params", "copter.parm")


def find_binary(path: str | None, px4: bool = False) -> Path | None:
    """The SITL binary to run: ``path``, else ``$ARDUPILOT_SITL`` (``$PX4_SITL`` for a PX4
    plan), else None (no autopilot available: the caller flies the built-in model); an
    absolute path, as a path relative to here means nothing in the simulator's directory."""
    env = PX4_BINARY_ENV if px4 else BINARY_ENV
    chosen = path or os.environ.get(env) or None
    if chosen is None:
        return None
    p = Path(chosen).expanduser()
    if not p.is_file() or not os.access(p, os.X_OK):
        source = "--sitl-binary" if path else f"${env}"
        raise InputError(f"{source} {chosen}: not an executable file")
    return p.absolute()  # the simulator runs in a working directory of its own


def find_defaults(binary: Path, path: str | None = None) -> Path:
    """The SITL's default parameter file: ``path``, ``$ARDUPILOT_SITL_DEFAULTS``, or
    ``copter.parm`` in the ArduPilot source tree the binary was built in (``build/sitl/bin/``
    under it) or beside the binary; an absolute path (a relative one given here had the
    simulator, in its own directory, start without it and never answer)."""
    given = path or os.environ.get(DEFAULTS_ENV)
    if given:
        p = Path(given).expanduser()
        if not p.is_file():
            raise InputError(f"--sitl-defaults {given}: no such file")
        return p.absolute()  # read by the simulator, which runs in a directory of its own
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
def _workdir(prefix: str) -> Iterator[Path]:
    """A fresh temporary directory for one run (the simulator's state and log), removed after."""
    workdir = Path(tempfile.mkdtemp(prefix=prefix))
    try:
        yield workdir
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


@contextmanager
def _started(binary: Path, argv: list[str], workdir: Path,
             env: dict[str, str] | None = None) -> Iterator[tuple[subprocess.Popen[bytes], Path]]:
    """``argv`` running in ``workdir`` in its own process group, output to ``sitl.log`` there;
    yields the process and the log, and stops the whole group when the block ends."""
    log = workdir / "sitl.log"
    try:
        with open(log, "wb") as out:
            proc = subprocess.Popen(argv, cwd=workdir, env=env, stdout=out,
                                    stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                    start_new_session=True)
    except OSError as err:
        raise InputError(f"--sitl-binary {binary}: cannot start ({err.strerror})") from None
    try:
        yield proc, log
    finally:
        _stop(proc)


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
    argv = [str(binary), "--model", "+", "--speedup", f"{speedup:g}", "--defaults",
            str(defaults), "-w", "--home", f"{lat:.9f},{lon:.9f},{alt:.3f},0",
            "-I", str(instance)]
    with _workdir("nfz-sitl-") as workdir, _started(binary, argv, workdir) as (proc, log):
        _wait_listening(port, proc, log, start_patience_s)
        yield f"tcp:127.0.0.1:{port}"


def sitl_wind_params(wind: Wind | None) -> dict[str, float]:
    """ArduPilot SITL's simulated wind for ``wind`` (its flight-altitude layer): SIM_WIND_SPD
    (m/s), SIM_WIND_DIR (degrees the wind comes FROM, as ours: SIM_Aircraft's update_wind
    negates the vector), SIM_WIND_TURB (m/s), and SIM_WIND_T 1, a flat wind at every height
    (its default 0 scales the wind by sqrt(alt / 60 m) below 60 m: 0.71 of it at 30 m).
    Still air: all zero, which also undoes a wind left from an earlier flight."""
    if wind is None:
        return {"SIM_WIND_SPD": 0.0, "SIM_WIND_TURB": 0.0}
    return {"SIM_WIND_SPD": wind.speed_mps, "SIM_WIND_DIR": wind.from_deg,
            "SIM_WIND_TURB": wind.turbulence_mps, "SIM_WIND_T": 1.0}


# Our ground station's heartbeat comes once a second of wall time (validator.mavlink.connection);
# a SITL sped up S times sees it every S of its own seconds.
GCS_HEARTBEAT_PERIOD_S = 1.0
GCS_HEARTBEATS_MISSED = 3  # how many a sped-up ArduCopter may miss before declaring GCS loss
FS_GCS_TIMEOUT_MAX_S = 120.0  # ArduCopter's documented range: 2-120 s


def sped_up_link_params(speedup: float, px4: bool) -> dict[str, float]:
    """Parameters that keep a sped-up SITL from declaring our link lost between heartbeats:
    ArduCopter's FS_GCS_TIMEOUT (5 s of its time; the .param's FS_GCS_ENABLE acts on it) is
    raised to cover :data:`GCS_HEARTBEATS_MISSED` heartbeats. PX4's COM_DL_LOSS_T (10 s) holds
    2.5 heartbeats at its default speedup of 4: nothing to change."""
    if px4:
        return {}
    timeout = math.ceil(GCS_HEARTBEATS_MISSED * GCS_HEARTBEAT_PERIOD_S * speedup)
    return {"FS_GCS_TIMEOUT": float(min(max(timeout, 5), FS_GCS_TIMEOUT_MAX_S))}


def is_px4(binary: Path) -> bool:
    """Whether ``binary`` is PX4's SITL (its executable is called ``px4``)."""
    return binary.name == "px4" or binary.resolve().name == "px4"


def _udp_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def _px4_instance_free(n: int) -> bool:
    """Whether PX4 instance ``n`` is free: nobody holds its server lock (``/tmp/px4_lock-N``,
    an fcntl lock) and its MAVLink receive port (14580 + N) is free."""
    try:
        fd = os.open(f"{PX4_LOCK_PATH}-{n}", os.O_RDWR | os.O_CREAT, 0o666)
    except OSError:
        return False
    try:
        fcntl.lockf(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    finally:
        os.close(fd)  # closing drops our lock too
    return _udp_free(PX4_ONBOARD_LISTEN_PORT + n)


@contextmanager
def px4_sih(binary: Path, home: tuple[float, float, float], *, speedup: float) -> Iterator[str]:
    """Run PX4 SITL with its SIH quadrotor at ``home`` (lat deg, lon deg, alt m AMSL) for a
    ``with`` block; yields the pymavlink connection string of its onboard link
    (``udpin:127.0.0.1:PORT``)."""
    etc = binary.resolve().parent.parent / "etc"
    if not (etc / "init.d-posix").is_dir():
        raise InputError(f"--sitl-binary {binary}: no PX4 start-up files at {etc} (expected a "
                         "px4_sitl_default build: bin/px4 beside etc/)")
    instance = next((n for n in range(MAX_INSTANCE) if _px4_instance_free(n)), None)
    if instance is None:
        raise InputError("no free PX4 instance: UDP ports 14540.. are all taken")
    port = PX4_ONBOARD_BASE_PORT + instance
    with _workdir("nfz-px4-") as workdir:
        rc = workdir / "rc"
        rc.mkdir()
        # SIH takes its home altitude from SIH_LOC_H0; the start-up script sources
        # px4-rc.params from the PATH after the airframe, before it starts the simulator.
        (rc / "px4-rc.params").write_text(f"#!/bin/sh\nparam set SIH_LOC_H0 {home[2]:.3f}\n")
        (rc / "px4-rc.params").chmod(0o755)
        env = {**os.environ, "PX4_SIMULATOR": "sihsim", "PX4_SIM_MODEL": "sihsim_quadx",
               "PX4_HOME_LAT": str(int(to_int_e7(home[0]))),
               "PX4_HOME_LON": str(int(to_int_e7(home[1]))),
               "PX4_SIM_SPEED_FACTOR": f"{speedup:g}",
               "PATH": f"{rc}{os.pathsep}{os.environ.get('PATH', '')}"}
        argv = [str(binary), "-d", "-i", str(instance), str(etc)]
        with _started(binary, argv, workdir, env) as (proc, log):
            time.sleep(0.5)
            if proc.poll() is not None:
                raise InputError(f"PX4 exited with status {proc.returncode} at start "
                                 f"({_tail(log)})")
            yield f"udpin:127.0.0.1:{port}"


@contextmanager
def autopilot_sitl(binary: Path, home: tuple[float, float, float], *, speedup: float,
                   defaults: str | None = None) -> Iterator[str]:
    """:func:`px4_sih` for PX4's binary, else :func:`ardupilot_sitl` (with its default
    parameter file, :func:`find_defaults`)."""
    if is_px4(binary):
        with px4_sih(binary, home, speedup=speedup) as url:
            yield url
    else:
        with ardupilot_sitl(binary, home, speedup=speedup,
                            defaults=find_defaults(binary, defaults)) as url:
            yield url


def terminate_on_sigterm() -> None:
    """Turn SIGTERM into KeyboardInterrupt, so ``with`` blocks (and the SITL they started)
    are left as on Ctrl-C."""

    def handler(_sig: int, _frame: FrameType | None) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, handler)
