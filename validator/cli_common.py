"""What the six commands share, so they agree: the exit-status table, one wrapper that maps
every failure onto it, and the option groups more than one command adds (a MAVLink link,
``--autopilot``, ``--quiet``, the parameter file), with the old spellings kept one release.

The six: ``plan-mission``, ``validate-mission``, ``upload-mission``, ``download-mission``,
``sitl-vehicle``, ``nfz-study``. Each builds its parser with :func:`command_parser` (every
``--help`` ends with :data:`EXIT_STATUS`) and runs its work through :func:`run_command`.
Results go to stdout; progress, notes, warnings and errors to stderr.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
import textwrap
from collections.abc import Callable, Sequence
from typing import Any

from validator.errors import CommandParser, InputError, UserError, given_once, report_error
from validator.mavlink import DEFAULT_TIMEOUT_S
from validator.plan_format import Autopilot

__all__ = ["EXIT_INTERRUPTED", "EXIT_INPUT", "EXIT_OK", "EXIT_STATUS", "EXIT_VERDICT",
           "LINK_TIMEOUT_S", "AutopilotOrProfile", "Deprecated", "add_autopilot_arguments",
           "add_deprecated", "add_link_arguments", "add_quiet_argument", "command_parser",
           "deprecation", "positive", "read_signing_key_arg", "run_command", "sysid"]

EXIT_OK = 0
EXIT_VERDICT = 1
EXIT_INPUT = 2
EXIT_INTERRUPTED = 130

HELP_WIDTH = 79

EXIT_STATUS = """\
exit status (the same for every nfz-mission command):
  0    done: the mission is clear, written, uploaded as sent
  1    a verdict against the mission: a violation, a refused or unsafe plan,
       a read-back that differs from what was sent, a study with a failed
       trial (each sweep point that lost trials named on stderr; the table
       keeps each trial's error and every point's result)
  2    the user's input or environment: a bad file, flag or value, a failed
       link, a missing tool (one line on stderr, no output file)
  130  interrupted (Ctrl-C): nothing half-written, a vehicle started here
       is stopped"""

# how long a vehicle may stay silent before a command gives up: the link's own default
LINK_TIMEOUT_S = DEFAULT_TIMEOUT_S

SIGNING_KEY_HELP = (
    "sign every packet (MAVLink 2 signing) and refuse every packet from the vehicle that is "
    "not signed with this key. FILE holds one line: a passphrase of printable ASCII without "
    "spaces, whose SHA-256 is the key, as MAVProxy's 'signing setup PASSPHRASE' gives it to "
    "the vehicle"
)


def command_parser(prog: str, description: str) -> argparse.ArgumentParser:
    """A command's parser: a mistake is one line and exit 2 (:class:`CommandParser`), and its
    ``--help`` ends with :data:`EXIT_STATUS`."""
    # the epilog's table keeps its lines (RawDescriptionHelpFormatter), so the one-paragraph
    # description is wrapped here
    return CommandParser(prog=prog, description=textwrap.fill(description, HELP_WIDTH),
                         epilog=EXIT_STATUS, formatter_class=argparse.RawDescriptionHelpFormatter)


def run_command(prog: str, work: Callable[[], int], *, interrupted: str = "interrupted") -> int:
    """Run a command's ``work`` (parse, act, print) and return its exit status by
    :data:`EXIT_STATUS`: a :class:`UserError` or a failed file operation is one line
    ``PROG: MESSAGE`` on stderr and 2 (1 for the errors that are a verdict, such as
    :class:`validator.mavlink.link.ReadBackMismatch`); Ctrl-C is one line ``PROG: interrupted``
    (or ``PROG: INTERRUPTED``, what a resumable command adds) and 130
    (outputs are written atomically and vehicles stopped by their context managers, so
    nothing is left half-done); argparse's own exits (``--help``, a bad flag) return their
    status so the entry point can be called in-process."""
    try:
        return work()
    except (UserError, OSError) as err:
        report_error(prog, err)
        return err.exit_status if isinstance(err, UserError) else EXIT_INPUT
    except KeyboardInterrupt:
        print(f"{prog}: {interrupted}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except SystemExit as done:
        code = done.code
        return code if isinstance(code, int) else (EXIT_OK if code is None else EXIT_INPUT)


# --------------------------------------------------------------------------------------------
# deprecated spellings


def deprecation(old: str, new: str) -> None:
    """The one line an old spelling prints on stderr."""
    print(f"warning: {old} is deprecated; use {new}", file=sys.stderr)


class Deprecated(argparse.Action):
    """An old spelling of an option: stores into the new option's ``dest`` as the new one
    does (a value, or ``const`` for a flag) and prints :func:`deprecation` once per run."""

    def __init__(self, option_strings: Sequence[str], dest: str, *, new: str,
                 nargs: int | str | None = None, const: object = None, **kwargs: Any) -> None:
        self.new = new
        super().__init__(option_strings, dest, nargs=nargs, const=const, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: object, option_string: str | None = None) -> None:
        if self.nargs != 0:  # a switch given twice says nothing new
            given_once(parser, namespace, self.dest, option_string)
        warned: set[str] = namespace.__dict__.setdefault("_deprecations_warned", set())
        if option_string not in warned:
            warned.add(option_string or "")
            deprecation(option_string or self.dest, self.new)
        setattr(namespace, self.dest, self.const if self.nargs == 0 else values)


def add_deprecated(p: argparse.ArgumentParser | argparse._ArgumentGroup, old: str, new: str,
                   *, dest: str, flag: bool = False, type: Callable[[str], object] | None = None,
                   metavar: str | None = None) -> None:
    """Accept ``old`` as a hidden alias of ``new`` (stored in ``dest``) for one release."""
    if flag:
        p.add_argument(old, action=Deprecated, new=new, dest=dest, nargs=0, const=True,
                       default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    else:
        p.add_argument(old, action=Deprecated, new=new, dest=dest, type=type or str,
                       metavar=metavar, default=argparse.SUPPRESS, help=argparse.SUPPRESS)


# --------------------------------------------------------------------------------------------
# values


def positive(text: str) -> float:
    """A number > 0 from the command line."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value > 0 and math.isfinite(value)):  # inf: a timeout or speed-up never reached
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def sysid(text: str) -> int:
    """A MAVLink system id, 1..255."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not 1 <= value <= 255:
        raise argparse.ArgumentTypeError(f"must be 1..255, got {text}")
    return value


def connect_url(text: str) -> str:
    """A connection string whose UDP or TCP port (``[SCHEME:][HOST:]PORT``), if it names one,
    is one a socket takes: 0..65535 (else the socket library raised OverflowError)."""
    m = re.fullmatch(r"(?:[a-z]+:)?(?:[^:]*:)?(-?\d+)", text)
    if m is not None and not 0 <= int(m.group(1)) <= 65535:
        raise argparse.ArgumentTypeError(f"port {m.group(1)} is outside 0..65535")
    return text


def _autopilot(text: str) -> Autopilot:
    try:
        return Autopilot.named(text)
    except InputError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


# --------------------------------------------------------------------------------------------
# option groups


def add_link_arguments(
    p: argparse.ArgumentParser,
    *,
    connect_help: str,
    required: bool = False,
    timeout: bool = True,
    sysid_help: str = "MAVLink system id of the vehicle (default: the first one heard)",
    sysid_default: int | None = None,
    signing_help: str = SIGNING_KEY_HELP,
    old: dict[str, str] | None = None,
) -> None:
    """The MAVLink link of a command that talks to a vehicle: ``--connect URL``,
    ``--timeout S`` (unless ``timeout`` is False), ``--sysid N``, ``--signing-key FILE``, in
    one argument group. ``old`` maps a new option to its former spelling in this command
    (``{"--connect": "--sitl-url"}``), kept as a deprecated alias."""
    g = p.add_argument_group("MAVLink link")
    g.add_argument("--connect", type=connect_url, required=required, metavar="URL",
                   help=connect_help)
    if timeout:
        g.add_argument("--timeout", type=positive, default=LINK_TIMEOUT_S, metavar="S",
                       help="give up when the vehicle does not answer for S seconds "
                            f"(default {LINK_TIMEOUT_S:g})")
    g.add_argument("--sysid", type=sysid, default=sysid_default, metavar="N", help=sysid_help)
    g.add_argument("--signing-key", metavar="FILE", help=signing_help)
    types: dict[str, Callable[[str], object] | None] = {
        "--connect": connect_url, "--timeout": positive, "--sysid": sysid, "--signing-key": None}
    for new, former in (old or {}).items():
        add_deprecated(g, former, new, dest=new[2:].replace("-", "_"), type=types[new])


def read_signing_key_arg(path: str | None) -> bytes | None:
    """The key of ``--signing-key FILE`` (None without it), with a warning on stderr when
    others can read the file; :class:`InputError` for a bad file."""
    if not path:
        return None
    from validator.mavlink.signing import key_file_exposure, read_signing_key

    key = read_signing_key(path)
    warning = key_file_exposure(path)
    if warning is not None:
        print(warning, file=sys.stderr)
    return key


class AutopilotOrProfile(argparse.Action):
    """``--profile``: ``ideal`` (the kinematic model, the only flight model that is not an
    autopilot's) is stored; ``arducopter``/``px4``, the old words for an autopilot's model, set
    ``--autopilot`` with a deprecation line."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: object, option_string: str | None = None) -> None:
        given_once(parser, namespace, self.dest, option_string)
        if values == "ideal":
            namespace.profile = "ideal"
            return
        autopilot = Autopilot.PX4 if values == "px4" else Autopilot.ARDUPILOTMEGA
        given_once(parser, namespace, "autopilot", option_string)  # beside --autopilot too
        deprecation(f"{option_string} {values}", f"--autopilot {autopilot.key}")
        namespace.autopilot = autopilot


def add_autopilot_arguments(p: argparse.ArgumentParser, *, help: str,
                            default: Autopilot | None = None, profile: str | None = None
                            ) -> None:
    """``--autopilot {ardupilot,px4}``, parsed into :class:`Autopilot`; with ``profile`` (its
    help) also ``--profile ideal``, the kinematic model (see :class:`AutopilotOrProfile`)."""
    p.add_argument("--autopilot", type=_autopilot, default=default, metavar="{ardupilot,px4}",
                   help=help)
    if profile is not None:
        p.add_argument("--profile", action=AutopilotOrProfile, default=None,
                       choices=("ideal", "arducopter", "px4"), metavar="ideal", help=profile)


def add_quiet_argument(p: argparse.ArgumentParser, help: str) -> None:
    """``--quiet`` (and the deprecated ``--no-progress``): no progress and no notes on
    stderr; warnings, errors and results still print."""
    p.add_argument("--quiet", action="store_true", help=help)
    add_deprecated(p, "--no-progress", "--quiet", dest="quiet", flag=True)
