"""The one exception type for mistakes a user can make in their inputs, and how every command
reports one."""

import argparse
import sys
from typing import NoReturn


class InputError(ValueError):
    """Bad user input: a site file, a plan file, a command-line value or a dead link.

    The message is one line that names the file, field or item at fault. Command-line entry
    points print it and exit with status 2. Control characters and line breaks a hostile file
    put into a key or value are shown escaped, so the message stays one line by construction.
    """

    def __init__(self, message: object = "") -> None:
        super().__init__(_one_line(str(message)))


def _one_line(text: str) -> str:
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def report_error(prog: str, err: BaseException) -> int:
    """Print ``err`` as every command does (one line on stderr: ``PROG: MESSAGE``; a failed
    file operation names the file) and return exit status 2."""
    if isinstance(err, OSError) and not isinstance(err, InputError):
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
