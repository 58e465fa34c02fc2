"""Commands: ``upload-mission``, ``download-mission``, ``sitl-vehicle`` (``validate-mission
--sitl`` is :mod:`validator.mavlink.sitl_check`).

    upload-mission PLAN --connect URL [--timeout S] [--sysid N] [--signing-key FILE]
                   [--set-params FILE] [--site SITE [--force]] [--allow-fence-off]
    download-mission --connect URL -o PLAN [--params OUT] [--timeout S] [--sysid N]
                     [--signing-key FILE]
    sitl-vehicle [--listen URL] --home LAT,LON,ALT [--speedup X] [--loss P] [--seed N]
                 [--profile NAME] [--param NAME=VALUE ...] [--sysid N] [--signing-key FILE]

Exit status: 0 success, 1 a plan the validator rejects (upload refused), 2 bad input or a
failed link (one line on stderr; no output file). Each command is a thin wrapper over a
documented function: :func:`validator.mavlink.link.upload_plan`,
:func:`~validator.mavlink.link.download_plan`, :class:`validator.mavlink.sim.SitlVehicle`,
:func:`validator.mavlink.driver.fly_and_score`. pymavlink and MAVSDK are imported only when a
command needs them, so ``validate-mission`` without ``--sitl`` starts as fast as before.
"""

from __future__ import annotations

import argparse
import ipaddress
import re
import signal
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from validator.errors import CommandParser, InputError, UserError, report_error

if TYPE_CHECKING:
    pass

# Profile parameters that are the model's, not an autopilot's: never sent with PARAM_SET.
MODEL_ONLY_PARAMS = frozenset({"VEHICLE_SPEED_MAX", "SPEED", "SPEED_UP", "SPEED_DN",
                               "VEHICLE_DRAG", "ALT_AMSL", "WIND_SPEED", "WIND_FROM"})


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def _sysid(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not 1 <= value <= 255:
        raise argparse.ArgumentTypeError(f"must be 1..255, got {text}")
    return value


SIGNING_KEY_HELP = (
    "sign every packet (MAVLink 2 signing) and refuse every packet from the vehicle that is "
    "not signed with this key. FILE holds one line: a passphrase of printable ASCII without "
    "spaces, whose SHA-256 is the key, as MAVProxy's 'signing setup PASSPHRASE' gives it to "
    "the vehicle"
)


def _signing_key_arg(p: argparse.ArgumentParser | argparse._ArgumentGroup, help: str) -> None:
    p.add_argument("--signing-key", metavar="FILE", help=help)


def _signing_key(args: argparse.Namespace) -> bytes | None:
    """The key of ``--signing-key FILE``, or None (:class:`InputError` for a bad file)."""
    from validator.mavlink.signing import key_file_exposure, read_signing_key

    if not args.signing_key:
        return None
    key = read_signing_key(args.signing_key)
    warning = key_file_exposure(args.signing_key)
    if warning is not None:
        print(warning, file=sys.stderr)
    return key


def _link_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--connect", required=True, metavar="URL",
                   help="pymavlink connection string: udpin:0.0.0.0:14550, udpout:HOST:PORT, "
                        "tcp:HOST:PORT, or a serial port such as /dev/ttyACM0")
    p.add_argument("--timeout", type=_positive, default=10.0, metavar="S",
                   help="give up when the vehicle does not answer for S seconds (default 10)")
    p.add_argument("--sysid", type=_sysid, metavar="N",
                   help="MAVLink system id of the vehicle (default: the first one heard)")
    _signing_key_arg(p, SIGNING_KEY_HELP)


# --------------------------------------------------------------------------------------------
# upload-mission


def upload_parser() -> argparse.ArgumentParser:
    p = CommandParser(
        prog="upload-mission",
        description="Upload a .plan's mission, geofence and rally points over MAVLink 2, then "
                    "download all three again and compare them item by item.",
        epilog="Exit status: 0 uploaded, held by the vehicle as sent (by its own storage "
               "rules) and its geofence on with a safe breach action; 1 refused (the plan "
               "fails the audit against --site); 2 bad input, a failed link, a read-back "
               "difference or a fence left off.",
    )
    p.add_argument("plan", help="QGroundControl .plan file")
    _link_args(p)
    p.add_argument("--set-params", metavar="FILE",
                   help="parameter file (NAME VALUE per line, .param/.parm or QGC format) to set "
                        "and read back before the mission")
    p.add_argument("--site", metavar="SITE",
                   help="audit the plan against this site first and refuse a violating plan")
    p.add_argument("--force", action="store_true", help="upload even if the audit fails")
    p.add_argument("--allow-fence-off", action="store_true",
                   help="succeed even when the vehicle's geofence stays off or its breach "
                        "action can fly across another zone (checked after the upload)")
    return p


def upload_mission_main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``upload-mission``; returns the exit status."""
    args = upload_parser().parse_args(argv)
    try:
        from validator.autopilot.param_file import read_params
        from validator.mavlink.link import upload_plan
        from validator.plan_format import read_plan

        plan = read_plan(args.plan)
        params = read_params(args.set_params) if args.set_params else None
        key = _signing_key(args)
        if args.site:
            from validator.validation import audit_refusal

            refused = audit_refusal(args.plan, args.site, params)
            if refused and not args.force:
                print(f"upload-mission: {refused}; --force uploads it anyway", file=sys.stderr)
                return 1
        elif params is not None:
            print("upload-mission: --set-params without --site: the failsafe paths are not "
                  "audited (add --site SITE)", file=sys.stderr)
        report = upload_plan(plan, args.connect, timeout_s=args.timeout, sysid=args.sysid,
                             params=params, require_fence=not args.allow_fence_off,
                             signing_key=key)
    except UserError as err:
        return report_error("upload-mission", err)
    print(report.summary())
    return 0


# --------------------------------------------------------------------------------------------
# download-mission


def download_parser() -> argparse.ArgumentParser:
    p = CommandParser(
        prog="download-mission",
        description="Download the mission, geofence and rally points a vehicle holds and write "
                    "them as a QGroundControl .plan (to audit with validate-mission).",
        epilog="Exit status: 0 written, 2 bad input or a failed link (no file written).",
    )
    _link_args(p)
    p.add_argument("-o", "--output", required=True, metavar="PLAN", help="the .plan to write")
    p.add_argument("--params", metavar="OUT",
                   help="also fetch every parameter the vehicle holds and write them as a "
                        "parameter file (ArduPilot NAME VALUE lines, QGroundControl format for "
                        "PX4), to audit with validate-mission --params")
    return p


def download_mission_main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``download-mission``; returns the exit status."""
    args = download_parser().parse_args(argv)
    try:
        from validator.mavlink.link import download_plan
        from validator.plan_format import write_plan

        key = _signing_key(args)
        plan = download_plan(args.connect, timeout_s=args.timeout, sysid=args.sysid,
                             signing_key=key)
        from validator.mavlink.param_download import download_params_text

        text = (download_params_text(args.connect, timeout_s=args.timeout, sysid=args.sysid,
                                     signing_key=key) if args.params else None)
        write_plan(plan, args.output)
        if args.params and text is not None:
            from validator.fileio import write_atomic

            write_atomic(args.params, text[1])
    except UserError as err:
        return report_error("download-mission", err)
    except OSError as err:
        name = err.filename or args.output
        return report_error("download-mission", InputError(f"{name}: {err.strerror}"))
    print(f"wrote {args.output}: {len(plan.items)} mission items, {len(plan.circles)} fence "
          f"circle(s), {len(plan.polygons)} polygon(s), {len(plan.rally)} rally point(s)")
    if args.params and text is not None:
        print(f"wrote {args.params}: {text[0]} parameters")
    return 0


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
    """The connection string ``sitl-vehicle`` listens on for ``--listen TEXT``: loopback unless
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
    from validator.motion.profile import PROFILES

    p = CommandParser(
        prog="sitl-vehicle",
        description="A simulated multicopter that speaks MAVLink 2 as ArduCopter does and flies "
                    "uploaded missions in AUTO with the validator's flight model. Runs until "
                    "interrupted.",
    )
    p.add_argument("--listen", metavar="URL",
                   help=f"where to listen (default {DEFAULT_LISTEN}): udpin:HOST:PORT, "
                        "HOST:PORT or PORT (port 0: any free port); loopback unless a host "
                        "is named, e.g. udpin:0.0.0.0:14550 for every interface")
    p.add_argument("--home", required=True, metavar="LAT,LON,ALT",
                   help="home position: degrees, degrees, metres AMSL")
    p.add_argument("--speedup", type=_positive, default=1.0, metavar="X",
                   help="simulated seconds per wall second (default 1)")
    p.add_argument("--loss", type=float, default=0.0, metavar="P",
                   help="drop this fraction of packets at random, each way (default 0)")
    p.add_argument("--seed", type=int, default=0, help="random seed for --loss (default 0)")
    p.add_argument("--profile", choices=PROFILES, default="arducopter",
                   help="flight model in AUTO (default arducopter)")
    p.add_argument("--param", action="append", metavar="NAME=VALUE",
                   help="initial parameter value, e.g. WPNAV_ACCEL=500 (repeatable)")
    p.add_argument("--sysid", type=_sysid, default=1, help="MAVLink system id (default 1)")
    _signing_key_arg(p, "sign every packet (MAVLink 2 signing) and ignore every packet not "
                        "signed with this key; FILE as for upload-mission --signing-key")
    return p


def sitl_vehicle_main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``sitl-vehicle``; runs until SIGINT or SIGTERM, then returns 0."""
    args = sitl_parser().parse_args(_glue_home(list(sys.argv[1:] if argv is None else argv)))
    try:
        from validator.mavlink.sim import SitlVehicle, VehicleConfig
        from validator.motion.profile import parse_param_overrides

        if not 0.0 <= args.loss < 1.0:
            raise InputError(f"--loss: must be in [0, 1), got {args.loss}")
        config = VehicleConfig(
            home=parse_home(args.home),
            system_id=args.sysid,
            speedup=args.speedup,
            loss=args.loss,
            seed=args.seed,
            profile=args.profile,
            params=parse_param_overrides(args.param),
            signing_key=_signing_key(args),
        )
        url = listen_url(args.listen)
        try:
            vehicle = SitlVehicle(url, config)
        except (OSError, ValueError) as err:
            raise InputError(f"--listen {url}: cannot listen ({err})") from None
    except UserError as err:
        return report_error("sitl-vehicle", err)
    host, port = vehicle.address
    if not is_loopback(host):
        print(f"sitl-vehicle: listening on {host}, not loopback: any machine that reaches "
              "this port can command the vehicle", file=sys.stderr)
    scheme = url.split(":", 1)[0]
    signed = ", signed" if args.signing_key else ""
    print(f"sitl-vehicle: listening on {scheme}:{host}:{port} (ArduCopter, system "
          f"{args.sysid}, {args.profile}, x{args.speedup:g}{signed})", flush=True)

    def stop(_sig: int, _frame: Any) -> None:
        vehicle.stop()

    signal.signal(signal.SIGTERM, stop)
    try:
        vehicle.run()
    except KeyboardInterrupt:
        pass
    return 0


# --------------------------------------------------------------------------------------------
# validate-mission --sitl
