"""Commands: ``upload-mission``, ``download-mission``, ``sitl-vehicle`` (``validate-mission
--sitl`` is :mod:`validator.mavlink.sitl_check`).

    upload-mission PLAN --connect URL [--timeout S] [--sysid N] [--signing-key FILE]
                   [--params FILE] [--site SITE [--force]] [--allow-fence-off] [--quiet]
    download-mission --connect URL -o PLAN [--params-out FILE] [--timeout S] [--sysid N]
                     [--signing-key FILE] [--quiet]
    sitl-vehicle [--connect URL] --home LAT,LON,ALT [--speedup X] [--loss P] [--seed N]
                 [--autopilot ardupilot|px4 | --profile ideal] [--param NAME=VALUE ...]
                 [--sysid N] [--signing-key FILE] [--quiet]

Exit status: :data:`validator.cli_common.EXIT_STATUS` (0 done, 1 a plan the validator refuses
or a read-back that differs, 2 bad input or a failed link, 130 interrupted). Each command is a
thin wrapper over a documented function: :func:`validator.mavlink.link.upload_plan`,
:func:`~validator.mavlink.link.download_plan`, :class:`validator.mavlink.sim.SitlVehicle`.
pymavlink and MAVSDK are imported only when a command needs them, so ``validate-mission``
without ``--sitl`` starts as fast as before.
"""

from __future__ import annotations

import argparse
import ipaddress
import re
import signal
import sys
from collections.abc import Sequence
from pathlib import Path
from types import FrameType

from validator.cli_common import (
    EXIT_OK,
    EXIT_VERDICT,
    add_autopilot_arguments,
    add_deprecated,
    add_link_arguments,
    add_quiet_argument,
    command_parser,
    positive,
    read_signing_key_arg,
    run_command,
)
from validator.errors import InputError
from validator.output_paths import output_path
from validator.plan_format import Autopilot
from validator.site import MAX_ALT_M

# Profile parameters that are the model's, not an autopilot's: never sent with PARAM_SET.
MODEL_ONLY_PARAMS = frozenset({"VEHICLE_SPEED_MAX", "SPEED", "SPEED_UP", "SPEED_DN",
                               "VEHICLE_DRAG", "ALT_AMSL", "WIND_SPEED", "WIND_FROM",
                               "WIND_TURB"})

CONNECT_HELP = ("pymavlink connection string: udpin:0.0.0.0:14550, udpout:HOST:PORT, "
                "tcp:HOST:PORT, or a serial port such as /dev/ttyACM0")


# --------------------------------------------------------------------------------------------
# upload-mission


def upload_parser() -> argparse.ArgumentParser:
    p = command_parser(
        "upload-mission",
        "Upload a .plan's mission, geofence and rally points over MAVLink 2, then download all "
        "three again and compare them item by item. Succeeds (0) when the vehicle holds them as "
        "sent (by its own storage rules) with its geofence on and a safe breach action; a plan "
        "that fails the audit against --site is refused and a read-back that differs is a "
        "verdict (1); a failed link or a fence left off is 2.",
    )
    p.add_argument("plan", help="QGroundControl .plan file")
    add_link_arguments(p, connect_help=CONNECT_HELP, required=True)
    p.add_argument("--params", metavar="FILE",
                   help="the parameter file the vehicle flies with (NAME VALUE per line, "
                        ".param/.parm or QGC format, as plan-mission writes beside the plan): "
                        "set and read back before the mission")
    add_deprecated(p, "--set-params", "--params", dest="params", metavar="FILE")
    p.add_argument("--site", metavar="SITE",
                   help="audit the plan against this site first and refuse a violating plan")
    p.add_argument("--force", action="store_true", help="upload even if the audit fails")
    p.add_argument("--allow-fence-off", action="store_true",
                   help="succeed even when the vehicle's geofence stays off or its breach "
                        "action can fly across another zone (checked after the upload)")
    add_quiet_argument(p, "no notes on stderr (warnings, errors and the result still print)")
    return p


def upload_mission_main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``upload-mission``; returns the exit status."""
    return run_command("upload-mission", lambda: _upload(upload_parser().parse_args(argv)))


def _upload(args: argparse.Namespace) -> int:
    from validator.autopilot.param_file import read_params
    from validator.mavlink.link import upload_plan
    from validator.plan_format import read_plan

    plan = read_plan(args.plan)
    params = read_params(args.params) if args.params else None
    key = read_signing_key_arg(args.signing_key)
    if args.site:
        from validator.validation import audit_refusal

        refused = audit_refusal(args.plan, args.site, params)
        if refused and not args.force:
            print(f"upload-mission: {refused}; --force uploads it anyway", file=sys.stderr)
            return EXIT_VERDICT
    elif params is not None and not args.quiet:
        print("upload-mission: --params without --site: the failsafe paths are not "
              "audited (add --site SITE)", file=sys.stderr)
    report = upload_plan(plan, args.connect, timeout_s=args.timeout, sysid=args.sysid,
                         params=params, require_fence=not args.allow_fence_off, signing_key=key,
                         source=args.plan)
    print(report.summary())
    return EXIT_OK


# --------------------------------------------------------------------------------------------
# download-mission


def download_parser() -> argparse.ArgumentParser:
    p = command_parser(
        "download-mission",
        "Download the mission, geofence and rally points a vehicle holds and write them as a "
        "QGroundControl .plan (to audit with validate-mission). A vehicle that reports no home "
        "gets its first positioned item as the plan's home, with a warning.",
    )
    add_link_arguments(p, connect_help=CONNECT_HELP, required=True)
    p.add_argument("-o", "--output", type=output_path, required=True, metavar="PLAN",
                   help="the .plan to write")
    p.add_argument("--params-out", type=output_path, metavar="FILE",
                   help="also fetch every parameter the vehicle holds and write them as a "
                        "parameter file (ArduPilot NAME VALUE lines, QGroundControl format for "
                        "PX4), to audit with validate-mission --params")
    add_deprecated(p, "--params", "--params-out", dest="params_out", type=output_path,
                   metavar="FILE")
    add_quiet_argument(p, "no notes on stderr (warnings, errors and the result still print)")
    return p


def download_mission_main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``download-mission``; returns the exit status."""
    return run_command("download-mission",
                       lambda: _download(download_parser().parse_args(argv)))


def _download(args: argparse.Namespace) -> int:
    from validator.fileio import write_all_atomic
    from validator.mavlink.link import download_plan
    from validator.mavlink.param_download import download_params_text
    from validator.output_paths import check_output_paths
    from validator.plan_format import dumps_plan

    check_output_paths([out for out in (args.output, args.params_out) if out is not None],
                       {"the --signing-key file": args.signing_key})
    key = read_signing_key_arg(args.signing_key)
    # a warning, not a note (so also with --quiet): the plan's home is not where the vehicle
    # would return to, and an audit of the plan judges its returns to it
    plan = download_plan(args.connect, timeout_s=args.timeout, sysid=args.sysid,
                         signing_key=key, note=lambda text: print(
                             f"download-mission: warning: {text}", file=sys.stderr))
    text = (download_params_text(args.connect, timeout_s=args.timeout, sysid=args.sysid,
                                 signing_key=key) if args.params_out else None)
    files: dict[Path, str | bytes] = {Path(args.output): dumps_plan(plan)}
    if args.params_out and text is not None:
        files[Path(args.params_out)] = text[1]
    write_all_atomic(files)  # both or neither, also when interrupted
    print(f"wrote {args.output}: {len(plan.items)} mission items, {len(plan.circles)} fence "
          f"circle(s), {len(plan.polygons)} polygon(s), {len(plan.rally)} rally point(s)")
    if args.params_out and text is not None:
        print(f"wrote {args.params_out}: {text[0]} parameters")
    return EXIT_OK


# --------------------------------------------------------------------------------------------
# sitl-vehicle


def parse_home(text: str) -> tuple[float, float, float]:
    """``LAT,LON,ALT`` (degrees, degrees, metres AMSL) from the command line."""
    parts = text.split(",")
    try:
        lat, lon, alt = (float(p) for p in parts)
    except ValueError:
        raise InputError(f"--home {text}: expected LAT,LON,ALT (degrees, degrees, m AMSL)"
                         ) from None
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise InputError(f"--home {text}: latitude or longitude out of range")
    if not abs(alt) <= MAX_ALT_M:  # (NaN too) as a site's origin: it travels in mm as int32
        raise InputError(f"--home {text}: altitude must be within ±{MAX_ALT_M:g} m")
    return lat, lon, alt


def _glue_home(argv: list[str]) -> list[str]:
    """``--home -35.36,149.16,584`` as ``--home=...``: argparse takes a value starting with
    '-' for an option unless it is a plain number."""
    out: list[str] = []
    it = iter(argv)
    for a in it:
        if a == "--home":
            value = next(it, None)
            out.append(a if value is None else f"--home={value}")
        else:
            out.append(a)
    return out


DEFAULT_LISTEN = "udpin:127.0.0.1:14550"
LOOPBACK = "127.0.0.1"


def listen_url(text: str | None) -> str:
    """The connection string ``sitl-vehicle`` listens on for ``--connect TEXT``: loopback unless
    a host is named. None is :data:`DEFAULT_LISTEN`; ``PORT`` and ``udpin::PORT`` (which
    pymavlink would bind on every interface) listen on 127.0.0.1; ``HOST:PORT`` is
    ``udpin:HOST:PORT``; any other string is used as it is."""
    if text is None:
        return DEFAULT_LISTEN
    scheme, rest = "udpin", text
    for prefix in ("udpin:", "udp:"):
        if text.startswith(prefix):
            scheme, rest = prefix[:-1], text[len(prefix):]
    m = re.fullmatch(r"(?:([^:]*):)?(\d+)", rest)
    if m is None:
        return text
    return f"{scheme}:{m.group(1) or LOOPBACK}:{m.group(2)}"


def is_loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return host == "localhost"


def sitl_parser() -> argparse.ArgumentParser:
    p = command_parser(
        "sitl-vehicle",
        "A simulated multicopter that speaks MAVLink 2 as ArduCopter does and flies uploaded "
        "missions in AUTO with the validator's flight model. Runs until interrupted (then 0).",
    )
    add_link_arguments(
        p, timeout=False, sysid_default=1, sysid_help="MAVLink system id (default 1)",
        connect_help=f"where to listen (default {DEFAULT_LISTEN}): udpin:HOST:PORT, HOST:PORT "
                     "or PORT (port 0: any free port); loopback unless a host is named, e.g. "
                     "udpin:0.0.0.0:14550 for every interface",
        signing_help="sign every packet (MAVLink 2 signing) and ignore every packet not signed "
                     "with this key; FILE as for upload-mission --signing-key",
        old={"--connect": "--listen"})
    p.add_argument("--home", required=True, metavar="LAT,LON,ALT",
                   help="home position: degrees, degrees, metres AMSL")
    p.add_argument("--speedup", type=positive, default=1.0, metavar="X",
                   help="simulated seconds per wall second (default 1)")
    p.add_argument("--loss", type=float, default=0.0, metavar="P",
                   help="drop this fraction of packets at random, each way (default 0)")
    p.add_argument("--seed", type=int, default=0, help="random seed for --loss (default 0)")
    add_autopilot_arguments(
        p, help="whose navigation the flight model in AUTO imitates (default ardupilot; the "
                "vehicle always speaks ArduCopter's MAVLink)",
        profile="fly the kinematic model instead (top speed only, no autopilot's navigation)")
    p.add_argument("--param", action="append", metavar="NAME=VALUE",
                   help="initial parameter value, e.g. WPNAV_ACCEL=500 (repeatable)")
    add_quiet_argument(p, "no notes on stderr (warnings, errors and the listening address "
                          "still print)")
    return p


def sitl_vehicle_main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``sitl-vehicle``; runs until SIGINT or SIGTERM, then returns 0."""
    return run_command("sitl-vehicle", lambda: _sitl_vehicle(sitl_parser().parse_args(
        _glue_home(list(sys.argv[1:] if argv is None else argv)))))


def _sitl_vehicle(args: argparse.Namespace) -> int:
    from validator.mavlink.sim import SitlVehicle, VehicleConfig
    from validator.motion.profile import parse_param_overrides

    if not 0.0 <= args.loss < 1.0:
        raise InputError(f"--loss: must be in [0, 1), got {args.loss}")
    profile = args.profile or (args.autopilot or Autopilot.ARDUPILOTMEGA).profile_name
    config = VehicleConfig(
        home=parse_home(args.home),
        system_id=args.sysid,
        speedup=args.speedup,
        loss=args.loss,
        seed=args.seed,
        profile=profile,
        params=parse_param_overrides(args.param),
        signing_key=read_signing_key_arg(args.signing_key),
    )
    url = listen_url(args.connect)
    try:
        vehicle = SitlVehicle(url, config)
    except (OSError, ValueError) as err:
        raise InputError(f"--connect {url}: cannot listen ({err})") from None
    host, port = vehicle.address
    if not is_loopback(host):
        print(f"sitl-vehicle: listening on {host}, not loopback: any machine that reaches "
              "this port can command the vehicle", file=sys.stderr)

    def stop(_sig: int, _frame: FrameType | None) -> None:
        vehicle.stop()

    # Before the address is printed: whoever read it may signal at once. SIGINT too, not left
    # to KeyboardInterrupt: a process started with SIGINT ignored (a background job of a
    # shell without job control) keeps it ignored, and both then stop between two steps.
    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    scheme = url.split(":", 1)[0]
    signed = ", signed" if args.signing_key else ""
    print(f"sitl-vehicle: listening on {scheme}:{host}:{port} (ArduCopter, system "
          f"{args.sysid}, {profile}, x{args.speedup:g}{signed})", flush=True)
    vehicle.run()  # until a signal's stop: the way to end it, not an interruption of a job
    return EXIT_OK
