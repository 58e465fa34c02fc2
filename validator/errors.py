"""The exceptions for what a user can put right (bad input, a failed link), and how every
command reports one."""

import argparse
import sys
from typing import NoReturn


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
    line ``PROG: MESSAGE`` on stderr, exit status 2 (argparse's own prints the usage first)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: {_one_line(message)}\n")
