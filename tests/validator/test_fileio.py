"""Atomic writes: whole files or none, with ordinary permissions."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from validator import fileio
from validator.fileio import write_all_atomic, write_atomic


def test_writes_text_and_bytes(tmp_path: Path) -> None:
    write_atomic(tmp_path / "a.txt", "héllo")
    write_atomic(tmp_path / "b.bin", b"\x00\x01")
    assert (tmp_path / "a.txt").read_text(encoding="utf-8") == "héllo"
    assert (tmp_path / "b.bin").read_bytes() == b"\x00\x01"


def test_new_file_gets_the_umask_mode_not_a_private_one(tmp_path: Path) -> None:
    old = os.umask(0o022)
    try:
        write_atomic(tmp_path / "m.plan", "{}")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "m.plan").stat().st_mode) == 0o644


def test_failed_write_leaves_no_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def broken_fsync(fd: int) -> None:
        raise OSError("disk full")

    monkeypatch.setattr(os, "fsync", broken_fsync)
    with pytest.raises(OSError, match="disk full"):
        write_atomic(tmp_path / "x.plan", "data")
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------------------------
# temporaries a killed writer leaves behind

ROOT = Path(__file__).parents[2]

# Replacing an existing file links the anonymous file to a hidden name and renames that over
# the old one; these writers stop in between (killed, or asleep while the test writes).
_STOPPED_BEFORE_RENAME = """
import os, signal, sys, time
from pathlib import Path
from validator import fileio
def stop(src, dst):
    if sys.argv[2] == "kill":
        os.kill(os.getpid(), signal.SIGKILL)
    print("linked", flush=True)
    time.sleep(60)
os.replace = stop
fileio.write_atomic(Path(sys.argv[1]), "new\\n")
"""


def _temporaries(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.name.endswith(".tmp"))


def test_temporary_of_a_killed_writer_is_removed_by_the_next_write(tmp_path: Path) -> None:
    target = tmp_path / "x.plan"
    target.write_text("old\n")
    proc = subprocess.run([sys.executable, "-c", _STOPPED_BEFORE_RENAME, str(target), "kill"],
                          cwd=ROOT, timeout=60)
    assert proc.returncode == -signal.SIGKILL
    left = _temporaries(tmp_path)
    assert [p.name[:8] for p in left] == [".x.plan."]  # hidden, named after its file ...
    assert left[0].read_text() == "new\n" and target.read_text() == "old\n"  # ... and whole
    write_atomic(target, "newer\n")
    assert _temporaries(tmp_path) == [] and target.read_text() == "newer\n"


def test_temporary_of_a_live_writer_is_left_alone(tmp_path: Path) -> None:
    target = tmp_path / "x.plan"
    target.write_text("old\n")
    proc = subprocess.Popen([sys.executable, "-c", _STOPPED_BEFORE_RENAME, str(target), "wait"],
                            stdout=subprocess.PIPE, cwd=ROOT)
    try:
        assert proc.stdout is not None and proc.stdout.readline() == b"linked\n"
        write_atomic(target, "other\n")
        assert len(_temporaries(tmp_path)) == 1  # its writer still holds it
        assert target.read_text() == "other\n"
    finally:
        proc.kill()
        proc.wait()
    write_atomic(target, "last\n")
    assert _temporaries(tmp_path) == []


def test_without_o_tmpfile_stale_temporaries_go_and_other_files_stay(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(fileio, "_open_anonymous", lambda folder: None)
    stale = tmp_path / ".x.plan.0123456789ab.tmp"  # as a killed writer leaves it: unlocked
    keep = [tmp_path / ".x.plan.backup.tmp", tmp_path / ".y.plan.0123456789ab.tmp",
            tmp_path / "x.plan.0123456789ab.tmp"]
    for p in (stale, *keep):
        p.write_text("stale\n")
    write_all_atomic({tmp_path / "x.plan": "a\n", tmp_path / "z.param": "b\n"})
    assert (tmp_path / "x.plan").read_text() == "a\n"
    assert (tmp_path / "z.param").read_text() == "b\n"
    assert _temporaries(tmp_path) == sorted(keep)
