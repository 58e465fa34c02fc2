"""validate-mission on hostile files, as a user runs it: exit 2, one line, no traceback, no file."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from tests.validator.builders import make_site, service_plan
from validator.plan_format import plan_to_dict
from validator.site import site_to_dict


def _plan_dict() -> dict:
    site = make_site()
    q = [(0, 60), (60, 60), (60, 100), (0, 60)]
    return plan_to_dict(service_plan(site, q, [6.0, 4.0, 8.0], [0.1] * 3, ["GN1", None, "GN2"]))


def _nan_latitude(p: Path) -> None:
    d = _plan_dict()
    d["mission"]["items"][2]["params"][4] = "@"
    p.write_text(json.dumps(d).replace('"@"', "NaN"))


def _version_99(p: Path) -> None:
    d = _plan_dict()
    d["version"] = 99
    p.write_text(json.dumps(d))


CASES = {
    "binary site": ("site", lambda p: p.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe" * 50),
                    "not UTF-8"),
    "deep plan": ("plan", lambda p: p.write_text("[" * 50_000 + "]" * 50_000),
                  "nested too deeply"),
    "NaN latitude": ("plan", _nan_latitude, "'NaN' is not a finite number"),
    "version 99": ("plan", _version_99, "version: expected 1, got 99"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_hostile_file_exits_2_with_one_line(tmp_path: Path, case: str) -> None:
    which, write, message = CASES[case]
    site, plan, report = tmp_path / "site.yaml", tmp_path / "m.plan", tmp_path / "r.json"
    site.write_text(yaml.safe_dump(site_to_dict(make_site())))
    plan.write_text(json.dumps(_plan_dict()))
    write(site if which == "site" else plan)
    proc = subprocess.run(
        [sys.executable, "-m", "validator.cli", str(plan), "--site", str(site), "--report",
         str(report)],
        capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1 and message in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr and proc.stdout == ""
    assert not report.exists()
