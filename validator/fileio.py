"""Atomic output files: a reader never sees half a file, a failure or a kill leaves none behind.

Each file is written to an anonymous file in its folder (Linux ``O_TMPFILE``: it has no name,
so even SIGKILL leaves nothing) and synced; only then is it named: linked straight to its name
when that is free, else to a hidden temporary name ``.NAME.<12 hex>.tmp`` that is renamed over
the old file (Linux cannot link a file over an existing name). Where ``O_TMPFILE`` is missing
(other systems, some file systems) the hidden temporary file is written instead, and removed on
any exception.

A temporary name therefore exists only for complete, synced data, and only SIGKILL (or a power
cut) between its link and its rename can leave one behind. Such leftovers are removed by the
next write of the same file: every writer holds an ``flock`` on its temporary file from the
moment it exists until its name is gone, and the kernel drops that lock however the writer
dies, so a temporary whose lock can be taken belongs to a dead writer and is deleted, while a
live writer's is left alone.

:func:`write_all_atomic` writes a set of files all or nothing: every file is staged first, and
the naming runs with SIGINT and SIGTERM held back, so an interrupted run leaves either none of
the new files or all of them. Only SIGKILL, during the microseconds of the naming, can split
the set (and leave a hidden temporary for the next write to remove).
"""

from __future__ import annotations

import fcntl
import os
import re
import signal
import threading
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path


def write_atomic(path: str | Path, data: str | bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename."""
    write_all_atomic({Path(path): data})


def write_all_atomic(files: Mapping[Path, str | bytes]) -> None:
    """Write every ``path -> data`` of ``files``: all of them, or (if staging any fails) none.

    Temporaries of these files that a killed writer left behind are removed first."""
    remove_stale_temporaries(Path(p) for p in files)
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


def temporary_name(path: Path) -> Path:
    """A fresh hidden temporary name beside ``path``: ``.NAME.<12 hex>.tmp``."""
    return path.with_name(f".{path.name}.{os.urandom(6).hex()}.tmp")


def _is_temporary_of(entry: str, name: str) -> bool:
    return re.fullmatch(rf"\.{re.escape(name)}\.[0-9a-f]{{12}}\.tmp", entry) is not None


def remove_stale_temporaries(paths: Iterable[Path]) -> list[Path]:
    """Delete the hidden temporaries of ``paths`` (:func:`temporary_name`) whose writer is gone:
    those whose ``flock`` can be taken. Best effort (an unreadable folder or file is left as it
    is); returns what was removed."""
    by_folder: dict[Path, set[str]] = {}
    for p in paths:
        by_folder.setdefault(_folder(p), set()).add(p.name)
    removed = []
    for folder, names in by_folder.items():
        try:
            entries = os.listdir(folder)
        except OSError:
            continue
        for entry in entries:
            if any(_is_temporary_of(entry, n) for n in names) and _remove_if_abandoned(
                    folder / entry):
                removed.append(folder / entry)
    return removed


def _remove_if_abandoned(tmp: Path) -> bool:
    try:
        fd = os.open(tmp, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except OSError:  # gone already, a symlink, or not ours to read
        return False
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            return False  # its writer is alive
        mine, there = os.fstat(fd), os.lstat(tmp)
        if (mine.st_dev, mine.st_ino) != (there.st_dev, there.st_ino):
            return False  # renamed into place meanwhile, and the name reused
        tmp.unlink()
        return True
    except OSError:
        return False
    finally:
        os.close(fd)


class _Staged:
    """A complete, synced file waiting for its name, open as ``fd`` (which holds the file's
    ``flock``): anonymous (``tmp`` None until it is linked), or a hidden temporary ``tmp``."""

    def __init__(self, path: Path, fd: int, tmp: Path | None = None) -> None:
        self.path, self.fd, self.tmp = path, fd, tmp

    def publish(self) -> None:
        if self.tmp is None:
            # linkat with AT_SYMLINK_FOLLOW (os.link uses it only when given a dir fd) names
            # the anonymous file; straight to its name when that is free, else via a rename.
            dir_fd = os.open(_folder(self.path), os.O_RDONLY | os.O_DIRECTORY)
            try:
                src = f"/proc/self/fd/{self.fd}"
                try:
                    os.link(src, self.path, src_dir_fd=dir_fd)
                    return
                except FileExistsError:
                    pass
                tmp = temporary_name(self.path)
                os.link(src, tmp, src_dir_fd=dir_fd)
                self.tmp = tmp
            finally:
                os.close(dir_fd)
        os.replace(self.tmp, self.path)
        self.tmp = None

    def discard(self) -> None:
        # The name goes before the lock, so no cleaner mistakes a live temporary for a stale one.
        if self.tmp is not None:
            self.tmp.unlink(missing_ok=True)
            self.tmp = None
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


def _stage(path: Path, data: str | bytes) -> _Staged:
    """``data`` in a synced, locked temporary file beside ``path``."""
    payload = data if isinstance(data, bytes) else data.encode("utf-8")
    mode = _default_mode(path)
    fd = _open_anonymous(_folder(path))
    staged = _Staged(path, fd) if fd is not None else _Staged(path, *_open_temporary(path))
    try:
        fcntl.flock(staged.fd, fcntl.LOCK_EX)
        _write_all(staged.fd, payload)
        os.fchmod(staged.fd, mode)  # the mode a plain open() would give, not a private one
        os.fsync(staged.fd)
    except BaseException:
        staged.discard()
        raise
    return staged


def _open_temporary(path: Path) -> tuple[int, Path]:
    """A new hidden temporary file beside ``path``, open and locked."""
    while True:
        tmp = temporary_name(path)
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        fcntl.flock(fd, fcntl.LOCK_EX)
        if os.fstat(fd).st_nlink > 0:
            return fd, tmp
        # A cleaner took it for a dead writer's between its creation and our lock: again.
        os.close(fd)


def _folder(path: Path) -> Path:
    return path.parent if str(path.parent) else Path(".")


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
