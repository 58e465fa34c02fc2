"""Reading a user's file without trusting it: bounded size and structure, finite numbers.

Every reader of a site, plan or waypoints file goes through here, so the limits hold for all of
them by construction rather than by each parser's care:

- at most ``MAX_FILE_BYTES`` (64 MiB; site files ``MAX_SITE_BYTES``, 4 MiB) are read, checked
  before the file is read whole and again while reading (a FIFO or ``/dev/zero`` has no size);
- the text must be UTF-8 (a leading byte-order mark is allowed);
- a parsed document may nest at most ``MAX_DEPTH`` containers deep and hold at most
  ``MAX_VALUES`` values, YAML aliases counted every time they are used (so an alias bomb is
  refused, not expanded);
- every number must be finite: JSON's non-standard ``NaN`` / ``Infinity`` and numbers that
  overflow a double are refused, as are YAML's ``.nan`` / ``.inf``.

- a path written inside a file (:func:`resolve_referenced_path`, for the coming ``airspace:``
  key: no reader follows one yet) stays inside that file's folder, unless the user explicitly
  allows absolute paths.

Each breach raises :class:`~validator.errors.InputError` naming the file and, where there is
one, the field.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import yaml

from validator.errors import InputError

MAX_FILE_BYTES = 64 * 2**20
MAX_SITE_BYTES = 4 * 2**20  # a site of 1000 nodes and zones is ~100 kB; YAML parses slowly
MAX_DEPTH = 32  # a .plan nests 6 deep, a site 3
MAX_VALUES = 4_000_000  # values in one parsed document (a 65535-item plan has ~1.2 million)


def read_text(path: str | Path, what: str, max_bytes: int = MAX_FILE_BYTES) -> str:
    """The UTF-8 text of the ``what`` file ``path`` (e.g. "plan"), at most ``max_bytes`` long."""
    path = Path(path)
    try:
        with path.open("rb") as f:
            size = os.fstat(f.fileno()).st_size
            if size > max_bytes:
                raise InputError(f"{path}: {what} file too large ({_mib(size)}; the limit is "
                                 f"{_mib(max_bytes)})")
            data = f.read(max_bytes + 1)
    except OSError as err:
        raise InputError(f"{path}: cannot read {what} file ({err.strerror or err})") from None
    if len(data) > max_bytes:
        raise InputError(f"{path}: {what} file too large (over the limit of {_mib(max_bytes)})")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        line = data[: err.start].count(b"\n") + 1
        raise InputError(f"{path}: {what} file is not UTF-8 text (byte {err.start}, "
                         f"line {line})") from None


def _mib(n: int) -> str:
    return f"{n / 2**20:.3g} MiB"


def parse_json(text: str, source: str) -> object:
    """Parse JSON strictly (finite numbers only) and check its structure (:func:`check_tree`)."""

    def no_constant(name: str) -> float:
        raise _NonFinite(name)

    def finite_float(s: str) -> float:
        v = float(s)
        if not math.isfinite(v):
            raise _NonFinite(s)
        return v

    try:
        data = json.loads(text, parse_constant=no_constant, parse_float=finite_float,
                          object_pairs_hook=_unique_keys)
    except _NonFinite as err:
        raise InputError(f"{source}: {err.args[0]!r} is not a finite number") from None
    except _DuplicateKey as err:
        raise InputError(f"{source}: key {err.args[0]!r} given twice in one object") from None
    except json.JSONDecodeError as err:
        raise InputError(f"{source}: not valid JSON (line {err.lineno}: {err.msg})") from None
    except RecursionError:
        raise InputError(f"{source}: nested too deeply (at most {MAX_DEPTH} levels)") from None
    except ValueError as err:  # e.g. an integer of more than 4300 digits
        raise InputError(f"{source}: not valid JSON ({err})") from None
    check_tree(data, source)
    return data


def parse_yaml(text: str, source: str) -> object:
    """Parse YAML text safely (no Python objects) and check its structure (:func:`check_tree`)."""
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 - a safe loader
    except _DuplicateKey as err:
        raise InputError(f"{source}: line {err.args[1]}: key {err.args[0]!r} given twice")  \
            from None
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        line = f" at line {mark.line + 1}" if mark is not None else ""
        raise InputError(f"{source}: unreadable YAML{line}") from None
    except RecursionError:
        raise InputError(f"{source}: nested too deeply (at most {MAX_DEPTH} levels)") from None
    check_tree(data, source)
    return data


class _NonFinite(ValueError):
    pass


class _DuplicateKey(ValueError):
    """A key given twice in one mapping: both parsers keep the last one silently, so a
    second ``buffer_m`` or ``name`` had overridden the first without a word."""


def _unique_keys(pairs: list[tuple[str, object]]) -> dict[str, object]:
    out: dict[str, object] = {}
    for key, value in pairs:
        if key in out:
            raise _DuplicateKey(key)
        out[key] = value
    return out


class _UniqueKeyLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """The safe loader, refusing a key given twice in one mapping (a ``<<`` merge may still
    override the keys it brings)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[object] = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=deep)
            try:
                if key in seen:
                    raise _DuplicateKey(key, key_node.start_mark.line + 1)
                seen.add(key)
            except TypeError:  # an unhashable key: the base constructor says so
                pass
        return super().construct_mapping(node, deep=deep)


def check_tree(data: object, source: str) -> None:
    """Refuse a parsed document that nests deeper than ``MAX_DEPTH``, holds more than
    ``MAX_VALUES`` values (shared YAML aliases counted at each use) or a non-finite number.

    Iterative, so no depth of nesting can exhaust the interpreter's stack.
    """
    if isinstance(data, float) and not math.isfinite(data):
        raise InputError(f"{source}: {data!r} is not a finite number")
    stack: list[tuple[dict[object, object] | list[object], int]] = (
        [(data, 0)] if isinstance(data, (dict, list)) else [])
    count = 1
    while stack:
        node, depth = stack.pop()
        if depth >= MAX_DEPTH:
            raise InputError(f"{source}: {_where(_path_to(data, node))}: nested too deeply "
                             f"(at most {MAX_DEPTH} levels)")
        count += len(node)
        if count > MAX_VALUES:
            raise InputError(f"{source}: too many values (more than {MAX_VALUES})")
        items = node.items() if isinstance(node, dict) else enumerate(node)
        for key, child in items:
            if isinstance(child, (dict, list)):
                stack.append((child, depth + 1))
            elif isinstance(child, float) and not math.isfinite(child):
                where = _where((*_path_to(data, node), _key(key)))
                raise InputError(f"{source}: {where}: {child!r} is not a finite number")
            if isinstance(key, float) and not math.isfinite(key):
                raise InputError(f"{source}: {_where(_path_to(data, node))}: {key!r} is not a "
                                 "finite number")


def _key(key: object) -> str | int:
    return key if isinstance(key, int) and not isinstance(key, bool) else str(key)


def _path_to(root: object, target: object) -> tuple[str | int, ...]:
    """The keys from ``root`` to the container ``target`` (only called to word an error)."""
    stack: list[tuple[dict[object, object] | list[object], tuple[str | int, ...]]] = (
        [(root, ())] if isinstance(root, (dict, list)) else [])
    while stack:
        node, path = stack.pop()
        if node is target:
            return path
        if len(path) > MAX_DEPTH:
            continue
        items = node.items() if isinstance(node, dict) else enumerate(node)
        for key, child in items:
            if isinstance(child, (dict, list)):
                stack.append((child, (*path, _key(key))))
    return ()


def _where(path: tuple[str | int, ...]) -> str:
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else part)
    return out or "top level"


def resolve_referenced_path(base_file: str | Path, ref: object, *, field: str,
                            allow_absolute: bool = False) -> Path:
    """The file that a path inside the user's file ``base_file`` names (such as a site's
    ``airspace:`` key, at ``field``), resolved; :class:`InputError` naming ``base_file`` and
    ``field`` when it may not be used.

    No input file can make the tool read or write outside the paths the user named: a relative
    ``ref`` is taken from the folder of ``base_file`` (not the working directory) and must stay
    inside that folder once ``..`` and symbolic links are resolved (a symbolic link out of the
    folder, as an unpacked archive can hold, is refused too). An absolute ``ref`` is refused
    unless ``allow_absolute``, which only an explicit choice of the user may set (a command-line
    option), and is then taken as it stands. ``~`` is not expanded.
    """
    source = f"{base_file}: {field}"
    if not isinstance(ref, str) or not ref:
        raise InputError(f"{source}: expected a file path relative to the file's folder, "
                         f"got {ref!r}")
    if "\0" in ref:
        raise InputError(f"{source}: the path holds a NUL character")
    folder = Path(base_file).parent
    try:
        root = folder.resolve()
        if Path(ref).is_absolute():
            if not allow_absolute:
                raise InputError(f"{source}: {ref!r} is an absolute path; name the file "
                                 f"relative to {root}")
            return Path(ref).resolve()
        resolved = (folder / ref).resolve()
    except (OSError, RuntimeError) as err:  # RuntimeError: a symbolic link loop
        raise InputError(f"{source}: cannot resolve {ref!r} ({err})") from None
    if not resolved.is_relative_to(root):
        raise InputError(f"{source}: {ref!r} resolves to {resolved}, outside {root} (the "
                         "folder of the file that names it)")
    return resolved
