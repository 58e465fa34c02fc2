"""Autopilot parameter files: read and write, in ArduPilot's and QGroundControl's formats.

ArduPilot tools (Mission Planner, MAVProxy) write ``NAME VALUE`` (or ``NAME,VALUE``) per line;
QGroundControl saves PX4 parameters as ``SYSID COMPID NAME VALUE TYPE``, tab-separated. ``#``
starts a comment in both. :func:`parse_params` reads either, into a :class:`ParamFile` that
remembers each value's line, so that whoever refuses a value later (a flight model's bounds)
names the file and line; :func:`format_params` writes the one that suits the autopilot.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping
from pathlib import Path

from validator.autopilot.spec import MAV_PARAM_TYPE_REAL32
from validator.errors import InputError
from validator.input_files import read_text

_PARAM_NAME = re.compile(r"^[A-Za-z0-9_]{1,16}$")


def _at(source: str, lineno: int) -> str:
    """Where in a parameter file, as every message about one starts."""
    return f"{source}:{lineno}"


class ParamFile(dict[str, float]):
    """A parameter file's values by name (autopilot units), as a dict, with the file's name
    (``source``) and the line each value was read from (the last, for a name given twice)."""

    def __init__(self, source: str) -> None:
        super().__init__()
        self.source = source
        self.lines: dict[str, int] = {}

    def where(self, name: str) -> str:
        """``FILE:LINE: NAME``: how a message about ``name``'s value starts."""
        return f"{_at(self.source, self.lines[name])}: {name}"


def parse_params(text: str, source: str = "params") -> ParamFile:
    """Parameters from a ``.param`` / ``.parm`` file (``NAME VALUE`` or ``NAME,VALUE`` per line,
    as ArduPilot tools write) or a QGroundControl parameter file (``SYSID COMPID NAME VALUE
    TYPE``, tab-separated, as PX4 users save). ``#`` starts a comment."""
    out = ParamFile(source)
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        parts = [p for p in re.split(r"[\s,]+", line) if p]
        if len(parts) == 5 and parts[0].isdigit() and parts[1].isdigit():
            parts = parts[2:4]
        if len(parts) != 2:
            raise InputError(f"{_at(source, lineno)}: expected 'NAME VALUE', got "
                             f"{raw.strip()!r}")
        name, value_text = parts
        if not _PARAM_NAME.match(name):
            raise InputError(f"{_at(source, lineno)}: {name!r} is not a parameter name "
                             "(letters, digits, _; at most 16)")
        try:
            value = float(value_text)
        except ValueError:
            raise InputError(f"{_at(source, lineno)}: {name}: {value_text!r} is not a "
                             "number") from None
        if not math.isfinite(value):
            raise InputError(f"{_at(source, lineno)}: {name}: value must be finite")
        out[name] = value
        out.lines[name] = lineno
    return out


def read_params(path: str | Path) -> ParamFile:
    """Read a parameter file (see :func:`parse_params`); size and encoding are checked as for
    every input file (:func:`validator.input_files.read_text`)."""
    return parse_params(read_text(path, "parameter"), str(path))


def format_params(values: Mapping[str, float], autopilot: str,
                  comments: Iterable[str] = (), types: Mapping[str, int] | None = None) -> str:
    """The file text for ``values``: ArduPilot ``NAME VALUE`` lines, or for ``px4`` a
    QGroundControl parameter file (``1 1 NAME VALUE TYPE``, tab-separated, TYPE the
    MAV_PARAM_TYPE from ``types``, default REAL32); each comment line is written first, after
    ``# ``."""
    head = [f"# {c}" for c in comments]
    if autopilot == "px4":
        head.append("# Vehicle-Id Component-Id Name Value Type")
        kinds = types or {}
        body = [f"1\t1\t{n}\t{v:.9g}\t{kinds.get(n, MAV_PARAM_TYPE_REAL32)}"
                for n, v in values.items()]
    else:
        width = max((len(n) for n in values), default=0)
        body = [f"{n:<{width}} {v:.9g}" for n, v in values.items()]
    return "\n".join(head + body) + "\n"
