"""Killed and concurrent runs: no partial output file, no second study in one directory."""

from __future__ import annotations

import json
import os
import random
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mission_planner.study.store import LOCK_NAME, TrialLog, read_log
from validator.errors import InputError
from validator.fileio import write_all_atomic
from validator.plan_format import read_plan

ROOT = Path(__file__).parents[2]
SAMPLE = ROOT / "samples" / "paper-default.yaml"
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGKILL)


def _temporaries(folder: Path) -> list[Path]:
    return [p for p in folder.iterdir() if p.name.endswith(".tmp")]


def _leftovers_go_with_the_next_write(folder: Path, names: set[str], sig: signal.Signals) -> None:
    """What a killed writer may leave besides its files: only SIGKILL, only between linking a
    hidden temporary of a complete file and renaming it into place (``.NAME.<hex>.tmp``); the
    next write of those names removes it."""
    left = _temporaries(folder)
    if sig != signal.SIGKILL:
        assert left == []
    for p in left:
        assert any(re.fullmatch(rf"\.{re.escape(n)}\.[0-9a-f]{{12}}\.tmp", p.name)
                   for n in names), p.name
    write_all_atomic({folder / n: "next\n" for n in names})
    assert _temporaries(folder) == []


# --------------------------------------------------------------------------------------------
# plan-mission killed at a few moments


def _check_outputs(folder: Path) -> str:
    """Either none of the outputs or all of them, each complete; returns which."""
    names = {"m.plan", "m.param", "r.json", "f.png"}
    present = {p.name for p in folder.iterdir()} & names
    if not present:
        return "none"
    assert present == names, present
    assert read_plan(folder / "m.plan").items
    assert json.loads((folder / "r.json").read_text())["mission"]["items"] > 0
    png = (folder / "f.png").read_bytes()
    assert png.startswith(b"\x89PNG") and png.rstrip().endswith(b"IEND\xaeB`\x82")
    assert "WPNAV_SPEED" in (folder / "m.param").read_text()
    return "all"


def test_killed_plan_mission_leaves_no_partial_file(tmp_path: Path) -> None:
    rng = random.Random(14)
    runs = []
    for sig in SIGNALS:  # three runs side by side, each killed at its own moment
        out = tmp_path / sig.name
        out.mkdir()
        cmd = [sys.executable, "-m", "mission_planner.cli", str(SAMPLE), "-o", str(out / "m.plan"),
               "--report", str(out / "r.json"), "--plot", str(out / "f.png"),
               "--dynamics", "none"]
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        runs.append((sig, out, proc, rng.uniform(1.0, 8.0)))
    started = time.monotonic()
    for sig, _, proc, at_s in sorted(runs, key=lambda r: r[3]):
        time.sleep(max(0.0, started + at_s - time.monotonic()))
        if proc.poll() is None:
            proc.send_signal(sig)
    for sig, out, proc, _ in runs:
        proc.communicate(timeout=120)  # (a SIGINT during the imports prints a traceback)
        _check_outputs(out)
        _leftovers_go_with_the_next_write(out, {"m.plan", "m.param", "r.json", "f.png"}, sig)


# --------------------------------------------------------------------------------------------
# the atomic writer killed while it writes

_WRITER = """
import signal, sys
from pathlib import Path
# Python leaves SIGINT ignored when it starts with it ignored (a job a shell started in the
# background without job control): take the default KeyboardInterrupt, as at a terminal.
signal.signal(signal.SIGINT, signal.default_int_handler)
from validator.fileio import write_all_atomic
folder = Path(sys.argv[1])
print("ready", flush=True)
for gen in range(10**9):
    body = (str(gen) + "\\n") * 200_000
    write_all_atomic({folder / n: f"{gen}\\n{body}END {gen}\\n" for n in ("a.plan", "b.param",
                                                                      "c.json")})
"""


def _whole_generation(f: Path) -> str:
    text = f.read_text()
    gen = text.split("\n", 1)[0]
    assert text.endswith(f"END {gen}\n"), f"{f.name} is torn"
    return gen


@pytest.mark.parametrize("sig", SIGNALS, ids=[s.name for s in SIGNALS])
def test_killed_writer_leaves_whole_files_of_one_generation(tmp_path: Path,
                                                            sig: signal.Signals) -> None:
    rng = random.Random(sig.value)
    names = {"a.plan", "b.param", "c.json"}
    for _ in range(3):  # each writer starts by removing what the one killed before left
        proc = subprocess.Popen([sys.executable, "-c", _WRITER, str(tmp_path)],
                                stdout=subprocess.PIPE, cwd=ROOT)
        assert proc.stdout is not None and proc.stdout.readline() == b"ready\n"
        time.sleep(rng.uniform(0.05, 1.0))
        proc.send_signal(sig)
        proc.wait(timeout=60)
        files = sorted(p for p in tmp_path.iterdir() if p.name in names)
        gens = {_whole_generation(f) for f in files}
        left = _temporaries(tmp_path)
        assert len(files) + len(left) == len(list(tmp_path.iterdir()))
        for f in left:  # SIGKILL's leftovers are complete files too
            _whole_generation(f)
        if sig != signal.SIGKILL:  # SIGKILL may split the set in the renames' microseconds
            assert len(gens) <= 1 and len(files) in (0, 3)
    _leftovers_go_with_the_next_write(tmp_path, names, sig)


# --------------------------------------------------------------------------------------------
# nfz-study: one run per directory, resumed after a kill

_HOLDER = """
import os, signal, sys, time
from mission_planner.study.store import TrialLog
log = TrialLog(sys.argv[1]).__enter__()
log.append({"key": "t1", "value": 1})
log._file.write('{"key": "t2", "val')  # torn: killed mid-row
log._file.flush()
print("holding", flush=True)
if sys.argv[2] == "kill":
    os.kill(os.getpid(), signal.SIGKILL)
time.sleep(60)
"""


def test_second_study_on_one_directory_is_refused(tmp_path: Path) -> None:
    proc = subprocess.Popen([sys.executable, "-c", _HOLDER, str(tmp_path), "hold"],
                            stdout=subprocess.PIPE, cwd=ROOT)
    try:
        assert proc.stdout is not None and proc.stdout.readline() == b"holding\n"
        with pytest.raises(InputError, match=rf"another nfz-study \(pid {proc.pid}\)"):
            with TrialLog(tmp_path):
                pass
    finally:
        proc.kill()
        proc.wait()
    with TrialLog(tmp_path) as log:  # free again once the holder is gone
        log.append({"key": "t3"})
    assert set(read_log(tmp_path)) == {"t1", "t3"}


def test_killed_study_resumes_cleanly(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-c", _HOLDER, str(tmp_path), "kill"],
                          capture_output=True, cwd=ROOT, timeout=60)
    assert proc.returncode == -signal.SIGKILL
    assert set(read_log(tmp_path)) == {"t1"}  # the torn row is not a finished trial
    with TrialLog(tmp_path) as log:
        log.append({"key": "t2", "value": 2})
    assert read_log(tmp_path)["t2"]["value"] == 2
    assert (tmp_path / LOCK_NAME).read_text().strip() == str(os.getpid())


# --------------------------------------------------------------------------------------------
# plan-mission on hostile site files


@pytest.mark.parametrize("content, message", [
    (b"\xff\xd8\xff\xe0JFIF" * 40, "not UTF-8"),
    (SAMPLE.read_bytes().replace(b"period: 50.0", b"period: .nan"), "uav.period"),
    (b"a: &a [1, 2]\n" + b"".join(b"a%d: &a%d [*a%d, *a%d, *a%d, *a%d, *a%d, *a%d, *a%d, *a%d]\n"
                                  % ((i, i) + (i - 1 if i > 1 else 0,) * 8)
                                  for i in range(1, 9)).replace(b"*a0", b"*a"),
     "too many values"),
])
def test_plan_mission_hostile_site_exits_2(tmp_path: Path, content: bytes, message: str) -> None:
    site = tmp_path / "site.yaml"
    site.write_bytes(content)
    proc = subprocess.run([sys.executable, "-m", "mission_planner.cli", str(site), "-o",
                           str(tmp_path / "m.plan")], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and message in proc.stderr, proc.stderr
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["site.yaml"]
