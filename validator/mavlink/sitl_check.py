"""``validate-mission --sitl``: its options, and the plan flown on the vehicle they choose
(the built-in model, an ArduCopter or PX4 SITL binary, or a vehicle at a URL) and scored.

The command chooses with :func:`validator.mavlink.vehicles.choose_vehicle` and flies with
:func:`fly_validation`, which starts the vehicle with
:func:`~validator.mavlink.vehicles.start_vehicle` as :func:`validator.api.fly_plan` does, so a
vehicle started here is stopped however the flight ends (Ctrl-C too).
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from validator.cli_common import (
    LINK_TIMEOUT_S,
    SIGNING_KEY_HELP,
    add_link_arguments,
    deprecation,
    positive,
)
from validator.errors import InputError
from validator.mavlink import NETWORK_URL
from validator.mavlink.cli import MODEL_ONLY_PARAMS
from validator.mavlink.sitl_process import BINARY_ENV, DEFAULTS_ENV, PX4_BINARY_ENV, is_px4
from validator.mavlink.vehicles import (
    DEFAULT_BINARY_SPEEDUP,
    DEFAULT_PX4_SPEEDUP,
    DEFAULT_SITL_SPEEDUP,
    VehicleChoice,
    VehicleKind,
    start_vehicle,
)
from validator.output_paths import output_path

if TYPE_CHECKING:
    from validator.mavlink.faults import FaultInjector
    from validator.validation import Validation
    from validator.wind import Wind

FaultKind = Literal["rc-loss", "gcs-loss", "battery-low", "gps-loss"]
FAULTS: tuple[FaultKind, ...] = ("rc-loss", "gcs-loss", "battery-low", "gps-loss")


def _is_connection(text: str) -> bool:
    """Whether ``text`` reads as a connection string: a network link or a serial port."""
    return bool(NETWORK_URL.match(text) or re.match(r"^/dev/|^COM\d", text))


def split_sitl_url(argv: Sequence[str]) -> list[str]:
    """``--sitl URL`` (the old spelling) as ``--sitl --connect URL``, with a deprecation line
    on stderr; a ``--sitl`` followed by anything that is not a connection string stays a flag,
    so it no longer swallows the plan path."""
    out: list[str] = []
    items = list(argv)
    i = 0
    while i < len(items):
        a = items[i]
        if a.startswith("--sitl="):
            a, items[i + 1:i + 1] = "--sitl", [a.split("=", 1)[1]]
        if a == "--sitl" and i + 1 < len(items) and _is_connection(items[i + 1]):
            deprecation("--sitl URL", "--connect URL")
            out += ["--sitl", "--connect", items[i + 1]]
            i += 2
            continue
        out.append(a)
        i += 1
    return out


def add_sitl_arguments(p: argparse.ArgumentParser) -> None:
    """Add ``--sitl``, its options and the MAVLink link (``--connect`` ...) to
    ``validate-mission``'s parser."""
    g = p.add_argument_group("flight on a MAVLink vehicle")
    g.add_argument("--sitl", action="store_true",
                   help="upload, fly and score the mission on a vehicle: the one at --connect, "
                        f"else the autopilot SITL binary of --sitl-binary (default "
                        f"${BINARY_ENV}, ${PX4_BINARY_ENV} for PX4 plans), else the built-in "
                        "model vehicle")
    g.add_argument("--sitl-binary", metavar="PATH",
                   help="start this SITL binary (ArduCopter's arducopter, or PX4's "
                        "build/px4_sitl_default/bin/px4 with its SIH quadrotor) at the plan's "
                        "home for the flight and stop it afterwards; implies --sitl")
    g.add_argument("--sitl-defaults", metavar="FILE",
                   help="the SITL's default parameter file (default $" + DEFAULTS_ENV +
                        ", else Tools/autotest/default_params/copter.parm of the binary's "
                        "source tree)")
    g.add_argument("--sitl-speedup", type=positive, default=None, metavar="X",
                   help=f"simulated seconds per wall second (default {DEFAULT_SITL_SPEEDUP:g} "
                        f"for the built-in vehicle, {DEFAULT_BINARY_SPEEDUP:g} for ArduCopter "
                        f"SITL, {DEFAULT_PX4_SPEEDUP:g} for PX4 SIH)")
    g.add_argument("--sitl-time-limit", type=positive, metavar="S",
                   help="longest mission to record, vehicle seconds (default: twice the "
                        "replayed mission plus 120 s)")
    g.add_argument("--track", type=output_path, metavar="OUT.csv",
                   help="also write what the vehicle flew (position, velocity, mission item "
                        "per report; .gz compresses) for scoring or plotting later")
    g.add_argument("--fault", choices=FAULTS,
                   help="on an autopilot SITL (--sitl-binary or --connect): inject this fault "
                        "as the vehicle passes the point whose straight return comes closest "
                        "to a zone, and score the flight that follows (zone clearance, where "
                        "and how it ended)")
    add_link_arguments(
        p, connect_help="fly on an autopilot someone else runs (ArduPilot or PX4 SITL, or a "
                        "vehicle) at this pymavlink address, e.g. tcp:127.0.0.1:5760; implies "
                        "--sitl",
        sysid_help="with --connect: the vehicle's system id (default: the first one heard)",
        signing_help="with --connect: " + SIGNING_KEY_HELP,
        old={"--connect": "--sitl-url", "--timeout": "--sitl-timeout",
             "--sysid": "--sitl-sysid"})


@dataclass(frozen=True)
class SitlFlight:
    """How a ``--sitl`` flight went (its scored track is ``Validation.sitl``): which
    ``vehicle`` answered ("ArduPilot system 1") of which ``kind``, the ``binary`` started,
    the built-in vehicle's flight ``profile``, the ``upload`` summary, the parameters set,
    the telemetry's sample count and ``end`` reason, the samples outside the fence, the
    vehicle's own mode changes and messages (vehicle seconds), and a note on the air it flew
    in when that is not the ``--wind`` asked for."""

    vehicle: str
    kind: VehicleKind
    binary: Path | None
    profile: str | None
    upload: str
    params_set: dict[str, float]
    samples: int
    end: str
    fence_breach_samples: int
    mode_changes: tuple[tuple[float, str], ...]
    messages: tuple[tuple[float, str], ...]
    wind_note: str | None = None

    def as_dict(self) -> dict[str, object]:
        """The report's ``sitl_flight`` section."""
        return {
            "vehicle": self.vehicle,
            "kind": self.kind,
            "builtin": self.kind == "builtin",
            "binary": str(self.binary) if self.binary is not None else None,
            "profile": self.profile,
            "upload": self.upload,
            "params_set": dict(self.params_set),
            "samples": self.samples,
            "end": self.end,
            "fence_breach_samples": self.fence_breach_samples,
            "mode_changes": [{"t_s": t, "mode": m} for t, m in self.mode_changes],
            "messages": [{"t_s": t, "text": m} for t, m in self.messages],
        }


def flight_params(choice: VehicleChoice, sent: Mapping[str, float], wind: Wind | None
                  ) -> tuple[dict[str, float], str | None]:
    """The parameters to set on the vehicle ``choice`` before a flight (``sent``, a parameter
    file's values, plus what the simulator needs) in ``wind`` (the layer at the flight
    altitude, :attr:`validator.site.Site.flight_wind`), and a note on the air it flies in when
    that is not ``wind``."""
    from validator.mavlink.sitl_process import sitl_wind_params, sped_up_link_params

    out, note = dict(sent), None
    if choice.kind == "external":
        if wind is not None:
            note = "an external vehicle flies in its own air (--wind: the replay)"
    elif choice.kind == "sitl-binary":
        assert choice.binary is not None
        px4 = is_px4(choice.binary)
        # our wall-clock heartbeats are sparse in a sped-up SITL's time: widen its timeout
        out = {**sped_up_link_params(choice.speedup_x, px4), **out}
        if px4:
            if wind is not None:
                note = "PX4's SIH has no wind model: flown in still air"
        else:  # ArduPilot SITL flies in the flight's wind (SIM_WIND_*)
            out = {**out, **sitl_wind_params(wind)}
    return out, note


def fly_validation(
    v: Validation,
    choice: VehicleChoice,
    *,
    vehicle_params: Mapping[str, float] | None = None,
    overrides: Mapping[str, float] | None = None,
    fault: FaultKind | None = None,
    timeout_s: float = LINK_TIMEOUT_S,
    time_limit_s: float | None = None,
    progress: Callable[[str], None] | None = None,
) -> SitlFlight:
    """Fly ``v``'s plan on the vehicle ``choice`` (started for the flight and stopped
    afterwards) and put the scored track into ``v.sitl`` and ``v.recorded``.

    ``vehicle_params`` (a parameter file's values) and the autopilot's own ``overrides``
    (``--param``; the model's own names are not sent) are set on the vehicle before the
    flight. ``fault`` is injected where a straight return comes closest to a zone, a GPS
    loss where its coast does (:mod:`validator.mavlink.faults`; an autopilot
    only). ``time_limit_s`` bounds the mission
    in vehicle seconds (default: twice the replayed mission plus two minutes)."""
    from validator.mavlink.driver import default_time_limit_s, fly_and_score
    from validator.mavlink.faults import fault_watch, record_fault
    from validator.motion.limits import site_limits
    from validator.motion.profile import make_profile
    from validator.validation import default_profile_name

    model = dict(overrides or {})
    profile = v.profile or make_profile(default_profile_name(v.plan), site_limits(v.site), model)
    limit = time_limit_s or default_time_limit_s(v.flight, profile)
    if not v.flight.legs:
        raise InputError(f"{v.plan_path}: nothing to fly (no navigation items)")
    sent = {**(vehicle_params or {}),
            **{k: x for k, x in model.items() if k not in MODEL_ONLY_PARAMS}}
    injector: list[FaultInjector] = []  # the fault's, once the link is open
    watch = fault_watch(fault, v.plan, v.site, v.flight, vehicle_params, injector,
                        autopilot=choice.kind != "builtin", failsafe=v.failsafe,
                        site_source=v.site_path) if fault else None
    sent, wind_note = flight_params(choice, sent, v.flight_wind)
    if choice.kind == "sitl-binary":
        from validator.mavlink.sitl_process import terminate_on_sigterm

        terminate_on_sigterm()  # a killed command stops its SITL as Ctrl-C does
    with start_vehicle(choice, v.plan, profile) as running:
        result = fly_and_score(v.plan, v.site, v.flight, running.url, time_limit_s=limit,
                               timeout_s=timeout_s, sysid=choice.sysid, params=sent or None,
                               progress=progress, wait_ready=running.wait_ready,
                               signing_key=choice.signing_key, watch=watch)
    v.sitl = result.report
    if injector:
        record_fault(v, injector[0], result.telemetry)
    v.recorded = result.recorded()
    t = result.telemetry
    return SitlFlight(
        vehicle=result.vehicle, kind=choice.kind, binary=choice.binary,
        profile=profile.name if choice.kind == "builtin" else None,
        upload=result.upload_summary, params_set=dict(sent), samples=t.samples,
        end=t.end_reason, fence_breach_samples=int(t.fence_breach.sum()),
        mode_changes=tuple(t.mode_changes), messages=tuple(t.messages), wind_note=wind_note)


def progress_printer(prog: str, quiet: bool) -> Callable[[str], None] | None:
    """A flight's progress lines on stderr (``PROG: TEXT``), shown on a terminal unless
    ``quiet``, as ``plan-mission``'s progress is."""
    if quiet or not sys.stderr.isatty():
        return None
    return lambda text: print(f"{prog}: {text}", file=sys.stderr, flush=True)
