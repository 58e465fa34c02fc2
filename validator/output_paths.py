"""Where a command may write: every command checks its output paths here before doing any
work, so bad paths cost no planning, flight or download, and leave no partial output."""

from __future__ import annotations

import argparse
import os
import stat
from collections.abc import Iterable, Mapping
from pathlib import Path

from validator.errors import InputError

__all__ = ["check_not_inputs", "check_output_paths", "output_path"]


def output_path(text: str) -> Path:
    """An argparse ``type`` for an output file option: ``Path('')`` would silently become
    ``.`` (the working folder), so the empty string is refused while it is still visible."""
    if not text:
        raise argparse.ArgumentTypeError("empty path")
    return Path(text)


def check_output_paths(
    outputs: Iterable[str | Path],
    inputs: Mapping[str, str | Path | None] | None = None,
) -> None:
    """Refuse, with an :class:`InputError` naming the path, outputs that cannot be written
    as a new regular file or that would destroy something: an empty path, a folder, a missing
    folder, an existing file that is not a regular file (a FIFO or a device would be replaced
    by the atomic rename), a path named for two outputs, or one of the command's ``inputs``
    (description -> path, e.g. ``{"the site file": site}``; None entries are skipped).

    Paths are compared resolved and, where both exist, by device and inode, so a symbolic or
    hard link to the same file is caught too."""
    seen: list[tuple[str | Path, Path]] = []
    for out in outputs:
        if not str(out):
            raise InputError("output path is empty")
        path = Path(out)
        _check_writable(out, path)
        check_not_inputs([out], inputs)
        for other, other_path in seen:
            if _same_file(path, other_path):
                raise InputError(f"{out}: named for two outputs"
                                 + ("" if str(other) == str(out) else f" (also as {other})"))
        seen.append((out, path))


def check_not_inputs(outputs: Iterable[str | Path],
                     inputs: Mapping[str, str | Path | None] | None) -> None:
    """Refuse an output that is one of ``inputs`` (as :func:`check_output_paths`), alone: for
    the files a command writes into a folder it may still have to make."""
    named = [(what, Path(p)) for what, p in (inputs or {}).items() if p is not None and str(p)]
    for out in outputs:
        for what, inp in named:
            if _same_file(Path(out), inp):
                raise InputError(f"{out}: is an input of this command ({what})")


def _check_writable(out: str | Path, path: Path) -> None:
    if path.is_dir():
        raise InputError(f"{out}: is a folder")
    folder = path.parent
    if not folder.resolve().is_dir():
        raise InputError(f"{out}: folder {folder} does not exist")
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return
    except OSError as err:
        raise InputError(f"{out}: {err.strerror or err}") from None
    if not stat.S_ISREG(mode):
        raise InputError(f"{out}: exists and is not a regular file")


def _same_file(a: Path, b: Path) -> bool:
    if a.resolve() == b.resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist yet: then only the names could clash
        return False
