"""``validate-mission --sitl``: its options, and the plan flown on the vehicle they choose
(the built-in model, an ArduCopter or PX4 SITL binary, or a vehicle at a URL) and scored."""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from validator.errors import InputError
from validator.mavlink import NETWORK_URL
from validator.mavlink.cli import (
    MODEL_ONLY_PARAMS,
    SIGNING_KEY_HELP,
    _positive,
    _signing_key,
    _signing_key_arg,
    _sysid,
)
from validator.mavlink.sitl_process import BINARY_ENV, DEFAULTS_ENV, PX4_BINARY_ENV
from validator.mavlink.vehicles import (
    DEFAULT_BINARY_SPEEDUP,
    DEFAULT_PX4_SPEEDUP,
    DEFAULT_SITL_SPEEDUP,
    choose_vehicle,
)

if TYPE_CHECKING:
    from validator.mavlink.faults import FaultInjector
    from validator.validation import Validation


def _is_connection(text: str) -> bool:
    """Whether ``text`` reads as a connection string: a network link or a serial port."""
    return bool(NETWORK_URL.match(text) or re.match(r"^/dev/|^COM\d", text))


def split_sitl_url(argv: Sequence[str]) -> list[str]:
    """``--sitl URL`` (the old spelling) as ``--sitl --sitl-url URL``, with a deprecation line
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
            print("validate-mission: --sitl URL is deprecated: use --sitl-url URL",
                  file=sys.stderr)
            out += ["--sitl", "--sitl-url", items[i + 1]]
            i += 2
            continue
        out.append(a)
        i += 1
    return out


def add_sitl_arguments(p: argparse.ArgumentParser) -> None:
    """Add ``--sitl`` and its options to ``validate-mission``'s parser."""
    g = p.add_argument_group("flight on a MAVLink vehicle")
    g.add_argument("--sitl", action="store_true",
                   help="upload, fly and score the mission on a vehicle: the autopilot SITL "
                        f"binary of --sitl-binary (default ${BINARY_ENV}, ${PX4_BINARY_ENV} "
                        "for PX4 plans), else the built-in model vehicle")
    g.add_argument("--sitl-binary", metavar="PATH",
                   help="start this SITL binary (ArduCopter's arducopter, or PX4's "
                        "build/px4_sitl_default/bin/px4 with its SIH quadrotor) at the plan's "
                        "home for the flight and stop it afterwards; implies --sitl")
    g.add_argument("--sitl-defaults", metavar="FILE",
                   help="the SITL's default parameter file (default $" + DEFAULTS_ENV +
                        ", else Tools/autotest/default_params/copter.parm of the binary's "
                        "source tree)")
    g.add_argument("--sitl-url", metavar="URL",
                   help="fly on an autopilot someone else runs (ArduPilot or PX4 SITL, or a "
                        "vehicle) at this pymavlink address, e.g. tcp:127.0.0.1:5760; "
                        "implies --sitl")
    g.add_argument("--sitl-speedup", type=_positive, default=None, metavar="X",
                   help=f"simulated seconds per wall second (default {DEFAULT_SITL_SPEEDUP:g} "
                        f"for the built-in vehicle, {DEFAULT_BINARY_SPEEDUP:g} for ArduCopter "
                        f"SITL, {DEFAULT_PX4_SPEEDUP:g} for PX4 SIH)")
    g.add_argument("--sitl-timeout", type=_positive, default=10.0, metavar="S",
                   help="give up when the vehicle does not answer for S seconds (default 10)")
    g.add_argument("--sitl-time-limit", type=_positive, metavar="S",
                   help="longest mission to record, vehicle seconds (default: twice the "
                        "replayed mission plus 120 s)")
    g.add_argument("--track", metavar="OUT.csv",
                   help="also write what the vehicle flew (position, velocity, mission item "
                        "per report; .gz compresses) for scoring or plotting later")
    g.add_argument("--sitl-sysid", type=_sysid, metavar="N",
                   help="external vehicle's system id (default: the first one heard)")
    _signing_key_arg(g, "with --sitl-url: " + SIGNING_KEY_HELP)
    g.add_argument("--fault", choices=("rc-loss", "gcs-loss", "battery-low", "gps-loss"),
                   help="on an autopilot SITL (--sitl-binary or --sitl-url): inject this fault "
                        "as the vehicle passes the point whose straight return comes closest "
                        "to a zone, and score the flight that follows (zone clearance, where "
                        "and how it ended)")


def run_sitl(v: Validation, args: argparse.Namespace,
             vehicle_params: Mapping[str, float] | None = None) -> None:
    """Fly ``v``'s plan as ``args`` say and put the scored track into ``v.sitl``.

    ``vehicle_params`` (a parameter file's values and the autopilot's own ``--param``
    overrides) are set on the vehicle before the flight."""
    from validator.mavlink.driver import builtin_vehicle, default_time_limit_s, fly_and_score
    from validator.mavlink.faults import fault_watch, record_fault
    from validator.mavlink.sitl_process import (
        autopilot_sitl,
        is_px4,
        sitl_wind_params,
        sped_up_link_params,
        terminate_on_sigterm,
    )
    from validator.motion.limits import site_limits
    from validator.motion.profile import make_profile, parse_param_overrides
    from validator.validation import default_profile_name

    key = _signing_key(args)
    if key is not None and not args.sitl_url:
        raise InputError("--signing-key: only with --sitl-url (the vehicles --sitl starts "
                         "itself run on loopback, unsigned)")
    overrides = parse_param_overrides(getattr(args, "param", None))
    profile = v.profile or make_profile(getattr(args, "profile", None)
                                        or default_profile_name(v.plan), site_limits(v.site),
                                        overrides)
    limit = args.sitl_time_limit or default_time_limit_s(v.flight, profile)
    if not v.flight.legs:
        raise InputError(f"{v.plan_path}: nothing to fly (no navigation items)")
    sent = {**(vehicle_params or {}),
            **{k: x for k, x in overrides.items() if k not in MODEL_ONLY_PARAMS}}
    choice = choose_vehicle(v.plan, url=args.sitl_url, binary=args.sitl_binary,
                            speedup_x=args.sitl_speedup)
    binary = choice.binary
    home = (v.plan.home_lat_deg, v.plan.home_lon_deg, v.plan.home_alt_m)
    injector: list[FaultInjector] = []  # the fault's, once the link is open
    watch = fault_watch(v, args.fault, vehicle_params, injector, autopilot=bool(
        binary or args.sitl_url)) if getattr(args, "fault", None) else None
    if args.sitl_url:
        kind = "external"
        if v.flown_wind is not None:
            v.extra["sitl_wind"] = "an external vehicle flies in its own air (--wind: the replay)"
        result = fly_and_score(v.plan, v.site, v.flight, args.sitl_url, time_limit_s=limit,
                               timeout_s=args.sitl_timeout, sysid=args.sitl_sysid,
                               params=sent or None, signing_key=key, watch=watch)
    elif binary is not None:
        kind = "sitl-binary"
        speedup = args.sitl_speedup or (DEFAULT_PX4_SPEEDUP if is_px4(binary)
                                        else DEFAULT_BINARY_SPEEDUP)
        # our wall-clock heartbeats are sparse in a sped-up SITL's time: widen its timeout
        sent = {**sped_up_link_params(speedup, is_px4(binary)), **sent}
        terminate_on_sigterm()
        if is_px4(binary):
            if v.flown_wind is not None:
                v.extra["sitl_wind"] = "PX4's SIH has no wind model: flown in still air"
        else:  # ArduPilot SITL flies in the flight's wind (SIM_WIND_*)
            sent = {**sent, **sitl_wind_params(v.flown_wind)}
        with autopilot_sitl(binary, home, speedup=speedup, defaults=args.sitl_defaults) as url:
            result = fly_and_score(v.plan, v.site, v.flight, url, time_limit_s=limit,
                                   timeout_s=args.sitl_timeout, params=sent or None,
                                   wait_ready=True, watch=watch)
    else:
        kind = "builtin"
        with builtin_vehicle(v.plan, profile=profile, speedup=choice.speedup_x) as url:
            result = fly_and_score(v.plan, v.site, v.flight, url, time_limit_s=limit,
                                   timeout_s=args.sitl_timeout, params=sent or None)
    v.sitl = result.report
    if injector:
        record_fault(v, injector[0], result.telemetry)
    v.recorded = result.recorded()
    v.extra["sitl_flight"] = {
        "vehicle": result.vehicle,
        "kind": kind,
        "builtin": kind == "builtin",
        "binary": str(binary) if binary is not None else None,
        "profile": profile.name if kind == "builtin" else None,
        "upload": result.upload_summary,
        "params_set": dict(sent),
        "samples": result.telemetry.samples,
        "end": result.telemetry.end_reason,
        "fence_breach_samples": int(result.telemetry.fence_breach.sum()),
        "mode_changes": [{"t_s": t, "mode": m} for t, m in result.telemetry.mode_changes],
        "messages": [{"t_s": t, "text": m} for t, m in result.telemetry.messages],
    }

