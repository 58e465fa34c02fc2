"""Which vehicle a plan flies on, and that vehicle running for one flight.

Three kinds, chosen by :func:`choose_vehicle` the way ``validate-mission --sitl`` chooses:

``external``
    An autopilot someone else runs (ArduPilot or PX4 SITL, or a real vehicle) at a pymavlink
    connection string (``--connect``); nothing is started or stopped.
``sitl-binary``
    A real autopilot's SITL binary (``--sitl-binary``, else ``$ARDUPILOT_SITL``, or
    ``$PX4_SITL`` for a PX4 plan) started at the plan's home for the flight
    (:func:`validator.mavlink.sitl_process.autopilot_sitl`); it must pass its pre-arm checks
    before the upload.
``builtin``
    The validator's own simulated multicopter (:mod:`validator.mavlink.sim`), flying the
    replay's flight model: a model, not an autopilot. Chosen when no binary is found.

:func:`start_vehicle` is the context manager that runs the chosen vehicle for a ``with`` block
and always stops what it started. Speed-ups are simulated seconds per wall second.
pymavlink is imported only when a vehicle starts.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from validator.errors import InputError
from validator.mavlink.sitl_process import autopilot_sitl, find_binary, is_px4
from validator.motion.profile import Profile
from validator.plan_format import Autopilot, Plan

__all__ = ["DEFAULT_BINARY_SPEEDUP", "DEFAULT_PX4_SPEEDUP", "DEFAULT_SITL_SPEEDUP",
           "RunningVehicle", "VehicleChoice", "VehicleKind", "choose_vehicle", "start_vehicle"]

DEFAULT_SITL_SPEEDUP = 20.0  # the built-in vehicle: a model, cheap to run fast
DEFAULT_BINARY_SPEEDUP = 10.0  # ArduCopter SITL in lockstep; the shared real flights used 10
# PX4 SIH at 10x on a busy 2-core machine: telemetry and parameter answers dropped, and the
# flown cycle 11-13 % longer than at 4x (SIH's lockstep does not hold the navigator's timing)
DEFAULT_PX4_SPEEDUP = 4.0

VehicleKind = Literal["builtin", "sitl-binary", "external"]


@dataclass(frozen=True)
class VehicleChoice:
    """The vehicle to fly on: its ``kind`` and what that kind needs.

    ``url`` (external): the pymavlink connection string; ``sysid`` its MAVLink system id (None:
    the first heard) and ``signing_key`` the MAVLink 2 signing key (32 bytes) of that link.
    ``binary`` (sitl-binary): the executable; ``defaults`` ArduCopter SITL's default parameter
    file (None: found beside its source tree). ``speedup``: simulated seconds per wall second
    of a vehicle started here.
    """

    kind: VehicleKind
    url: str | None = None
    binary: Path | None = None
    speedup_x: float = DEFAULT_SITL_SPEEDUP
    defaults: str | None = None
    sysid: int | None = None
    signing_key: bytes | None = None

    @property
    def starts_here(self) -> bool:
        """Whether :func:`start_vehicle` starts (and stops) a process or thread for it."""
        return self.kind != "external"

    def describe(self) -> str:
        if self.kind == "external":
            return f"the vehicle at {self.url}"
        if self.kind == "sitl-binary":
            return f"SITL binary {self.binary} at x{self.speedup_x:g}"
        return f"the built-in model vehicle at x{self.speedup_x:g}"


def choose_vehicle(
    plan: Plan,
    *,
    url: str | None = None,
    binary: str | Path | None = None,
    speedup_x: float | None = None,
    defaults: str | None = None,
    sysid: int | None = None,
    signing_key: bytes | None = None,
) -> VehicleChoice:
    """The vehicle ``plan`` flies on: the one at ``url`` if given; else the SITL binary
    ``binary`` (default ``$ARDUPILOT_SITL``, ``$PX4_SITL`` for a PX4 plan); else the built-in
    model vehicle. ``speedup_x`` defaults by kind (:data:`DEFAULT_SITL_SPEEDUP`,
    :data:`DEFAULT_BINARY_SPEEDUP`, :data:`DEFAULT_PX4_SPEEDUP`). Raises :class:`InputError`
    for a binary that is not an executable, and for a signing key or system id without ``url``
    (the vehicles started here run on loopback, unsigned, as system 1)."""
    if url:
        return VehicleChoice("external", url=url, sysid=sysid, signing_key=signing_key)
    if signing_key is not None:
        raise InputError("--signing-key: only with --connect (the vehicles --sitl starts "
                         "itself run on loopback, unsigned)")
    if sysid is not None:
        raise InputError("--sysid: only with --connect")
    found = find_binary(str(binary) if binary is not None else None,
                        px4=Autopilot.of(plan) is Autopilot.PX4)
    if found is not None:
        default = DEFAULT_PX4_SPEEDUP if is_px4(found) else DEFAULT_BINARY_SPEEDUP
        return VehicleChoice("sitl-binary", binary=found, speedup_x=speedup_x or default,
                             defaults=defaults)
    return VehicleChoice("builtin", speedup_x=speedup_x or DEFAULT_SITL_SPEEDUP)


@dataclass(frozen=True)
class RunningVehicle:
    """A vehicle up for one flight: where to reach it, and whether it must first pass its
    pre-arm checks (a freshly started autopilot answers heartbeats before its estimator has
    a position)."""

    url: str
    choice: VehicleChoice
    wait_ready: bool


@contextmanager
def start_vehicle(choice: VehicleChoice, plan: Plan,
                  profile: Profile | None = None) -> Iterator[RunningVehicle]:
    """Run ``choice`` at ``plan``'s home for a ``with`` block, stopping whatever was started
    however the block ends. ``profile`` is the built-in vehicle's flight model (required for
    it; the replay's, so it flies as the replay does)."""
    home = (plan.home_lat_deg, plan.home_lon_deg, plan.home_alt_m)
    if choice.kind == "external":
        assert choice.url is not None
        yield RunningVehicle(choice.url, choice, wait_ready=False)
    elif choice.kind == "sitl-binary":
        assert choice.binary is not None
        with autopilot_sitl(choice.binary, home, speedup=choice.speedup_x,
                            defaults=choice.defaults) as url:
            yield RunningVehicle(url, choice, wait_ready=True)
    else:
        if profile is None:
            raise ValueError("the built-in vehicle needs a flight profile")
        from validator.mavlink.driver import builtin_vehicle  # pymavlink, only to fly

        with builtin_vehicle(plan, profile=profile, speedup=choice.speedup_x) as url:
            yield RunningVehicle(url, choice, wait_ready=False)
