"""The exceptions for what a user can put right (bad input, a failed link), and how every
command reports one."""

import argparse
import sys
from collections.abc import Sequence
from typing import Any, NoReturn


class UserError(Exception):
    """A failure the user can act on: bad input (:class:`InputError`) or a failed link
    (:class:`validator.mavlink.connection.LinkError`).

    The message is one line that names the file, field, item or vehicle at fault.
    Command-line entry points print it (:func:`report_error`) and exit with status 2. Control
    characters and line breaks a hostile file put into a key or value are shown escaped, so
    the message stays one line by construction. A few are a verdict on the mission rather than
    a fault of the input (a vehicle that holds something other than what was sent): those set
    ``exit_status`` to 1.
    """

    exit_status = 2

    def __init__(self, message: object = "") -> None:
        super().__init__(_one_line(str(message)))


class InputError(UserError, ValueError):
    """Bad user input: a site file, a plan file, a parameter file or a command-line value."""


def _one_line(text: str) -> str:
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def report_error(prog: str, err: BaseException) -> int:
    """Print ``err`` as every command does (one line on stderr: ``PROG: MESSAGE``; a failed
    file operation names the file) and return exit status 2."""
    if isinstance(err, OSError):
        name = getattr(err, "filename", None)
        text = f"{name}: {err.strerror or err}" if name else str(err.strerror or err)
    else:
        text = str(err)
    print(f"{prog}: {_one_line(text)}", file=sys.stderr)
    return 2


class CommandParser(argparse.ArgumentParser):
    """An argument parser that reports a command-line mistake as every other user error: one
    line ``PROG: MESSAGE`` on stderr, exit status 2 (argparse's own prints the usage first).

    An option that takes a value may be given once (:func:`given_once`): argparse keeps the
    last of ``--wind 5@270 --wind 7@90`` and drops the first without a word, so a script that
    adds a flag to a command line that already has it would plan for a wind nobody sees.
    Options meant to repeat (``action="append"``) and switches (``--force``: a second one says
    nothing new) are untouched."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # registered rather than asked of each flag: every plain add_argument("--x", ...),
        # in argument groups and subcommands too, then refuses a repeat without being told
        self.register("action", None, _StoreOnce)
        self.register("action", "store", _StoreOnce)

    # typeshed overloads the namespace's type; every command passes none
    def parse_known_args(self, args: Sequence[str] | None = None,  # type: ignore[override]
                         namespace: argparse.Namespace | None = None
                         ) -> tuple[argparse.Namespace, list[str]]:
        parsed, rest = super().parse_known_args(args, namespace)
        parsed.__dict__.pop(_GIVEN, None)  # this parse's bookkeeping, not an option
        return parsed, rest

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: {_one_line(message)}\n")


_GIVEN = "_options_given"  # in the namespace being filled: dest -> the spelling that set it


def given_once(parser: argparse.ArgumentParser, namespace: argparse.Namespace, dest: str,
               option_string: str | None) -> None:
    """Refuse a second value for ``dest`` in this parse: ``--wind given twice`` (``--output
    given twice (first as --out)`` when an alias gave the first). Every action that stores one
    value calls this, custom ones too, for the ``dest`` they set."""
    given: dict[str, str] = namespace.__dict__.setdefault(_GIVEN, {})
    used = option_string or dest
    first = given.get(dest)
    if first is not None:
        parser.error(f"{used} given twice" + ("" if first == used else f" (first as {first})"))
    given[dest] = used


class _StoreOnce(argparse._StoreAction):
    """argparse's ``store``, refusing a second value (:func:`given_once`)."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        if option_string is not None:  # a positional is filled once by argparse itself
            given_once(parser, namespace, self.dest, option_string)
        super().__call__(parser, namespace, values, option_string)
