"""The notebook-style examples run from start to end on their quick path, using only the front
door (:mod:`mission_planner.api`), and say what they found."""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "examples" / "plan_and_check.py"


def test_the_example_imports_only_the_front_door():
    tree = ast.parse(EXAMPLE.read_text(encoding="utf-8"))
    project = {(node.module or "") if isinstance(node, ast.ImportFrom) else a.name
               for node in ast.walk(tree) if isinstance(node, (ast.Import, ast.ImportFrom))
               for a in node.names}
    assert {m for m in project if m.split(".")[0] in ("validator", "mission_planner")} == {
        "mission_planner"}


def test_plan_and_check_runs_on_its_quick_path(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("ARDUPILOT_SITL", "PX4_SITL")}
    done = subprocess.run([sys.executable, str(EXAMPLE), str(tmp_path), "--quick"], cwd=tmp_path,
                          env={**env, "MPLBACKEND": "Agg"}, capture_output=True, text=True,
                          timeout=900, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    assert {p.name for p in tmp_path.iterdir()} >= {"mission.plan", "mission.param",
                                                    "report.json", "view.html", "flown.csv.gz"}
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["mission"]["items"] > 0 and "flight" in report
    assert "audit: CLEAR" in done.stdout
    assert "flown by ArduPilot system 1 (builtin)" in done.stdout, done.stdout
