"""Atomic output files: a reader never sees half a file, a failure or a kill leaves none behind.

Each file is written to an anonymous file in its folder (Linux ``O_TMPFILE``: it has no name,
so even SIGKILL leaves nothing) and synced; only then is it named: linked straight to its name
when that is free, else to a hidden temporary name that is renamed over the old file. Where
``O_TMPFILE`` is missing (other systems, some file systems) a hidden named temporary file
``.NAME.*.tmp`` is written instead, removed on any exception (SIGKILL can leave it behind).

:func:`write_all_atomic` writes a set of files all or nothing: every file is staged first, and
the naming runs with SIGINT and SIGTERM held back, so an interrupted run leaves either none of
the new files or all of them. Only SIGKILL, during the microseconds of the naming, can split
the set or leave a hidden temporary file.
"""

from __future__ import annotations

import os
import signal
import tempfile
import threading
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path


def write_atomic(path: str | Path, data: str | bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename."""
    write_all_atomic({Path(path): data})


def write_all_atomic(files: Mapping[Path, str | bytes]) -> None:
    """Write every ``path -> data`` of ``files``: all of them, or (if staging any fails) none."""
    staged: list[_Staged] = []
    try:
        for path, data in files.items():
            staged.append(_stage(Path(path), data))
        with _signals_held():
            for s in staged:
                s.publish()
    finally:
        for s in staged:
            s.discard()


class _Staged:
    """A complete, synced file waiting for its name: an open anonymous file (``fd``) or a
    hidden temporary file (``tmp``)."""

    def __init__(self, path: Path, fd: int | None = None, tmp: Path | None = None) -> None:
        self.path, self.fd, self.tmp = path, fd, tmp

    def publish(self) -> None:
        if self.fd is not None:
            # linkat with AT_SYMLINK_FOLLOW (os.link uses it only when given a dir fd) names
            # the anonymous file; straight to its name when that is free, else via a rename.
            folder = self.path.parent if str(self.path.parent) else Path(".")
            dir_fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
            try:
                src = f"/proc/self/fd/{self.fd}"
                try:
                    os.link(src, self.path, src_dir_fd=dir_fd)
                    return
                except FileExistsError:
                    pass
                tmp = folder / f".{self.path.name}.{os.urandom(6).hex()}.tmp"
                os.link(src, tmp, src_dir_fd=dir_fd)
                self.tmp = tmp
            finally:
                os.close(dir_fd)
        assert self.tmp is not None
        os.replace(self.tmp, self.path)
        self.tmp = None

    def discard(self) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None
        if self.tmp is not None:
            self.tmp.unlink(missing_ok=True)
            self.tmp = None


def _stage(path: Path, data: str | bytes) -> _Staged:
    """``data`` in a synced temporary file beside ``path``."""
    payload = data if isinstance(data, bytes) else data.encode("utf-8")
    folder = path.parent if str(path.parent) else Path(".")
    mode = _default_mode(path)
    fd = _open_anonymous(folder)
    if fd is not None:
        staged = _Staged(path, fd=fd)
        try:
            _write_all(fd, payload)
            os.fchmod(fd, mode)
            os.fsync(fd)
        except BaseException:
            staged.discard()
            raise
        return staged
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    staged = _Staged(path, tmp=Path(name))
    try:
        # mkstemp makes the file private (0600); give it the mode a plain open() would.
        os.fchmod(fd, mode)
        _write_all(fd, payload)
        os.fsync(fd)
    except BaseException:
        staged.discard()
        raise
    finally:
        os.close(fd)
    return staged


def _open_anonymous(folder: Path) -> int | None:
    flag = getattr(os, "O_TMPFILE", None)
    if flag is None or not Path("/proc/self/fd").is_dir():
        return None
    try:
        return os.open(folder, flag | os.O_WRONLY, 0o600)
    except OSError as err:
        if isinstance(err, (FileNotFoundError, NotADirectoryError, PermissionError)):
            raise
        return None  # EOPNOTSUPP / EISDIR / EINVAL: the file system has no O_TMPFILE


def _write_all(fd: int, payload: bytes) -> None:
    view = memoryview(payload)
    while view:
        view = view[os.write(fd, view):]


@contextmanager
def _signals_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back (main thread only) until the block ends."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held = {signal.SIGINT, signal.SIGTERM}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _default_mode(path: Path) -> int:
    """The existing file's permissions, else 0666 less the process umask."""
    try:
        return path.stat().st_mode & 0o777
    except OSError:
        mask = os.umask(0)
        os.umask(mask)
        return 0o666 & ~mask
