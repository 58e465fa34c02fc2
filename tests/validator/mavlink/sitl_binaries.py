"""What the real-autopilot tests share: where they find a SITL binary built for this machine
(an environment variable, else a documented path: README, *Real autopilots*), and the sites
they plan."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[3]
PLAN_MISSION = shutil.which("plan-mission", path=str(Path(sys.executable).parent))


def sitl_binary(env: str, documented: Path) -> Path | None:
    """``$env`` if set, else ``documented``; None unless it is an executable file."""
    given = os.environ.get(env)
    path = Path(given) if given else documented
    return path if path.is_file() and os.access(path, os.X_OK) else None


def crossing_site(tmp: Path) -> Path:
    """Two nodes either side of a zone, few slots: the conventional plan hops across it."""
    site = yaml.safe_load((REPO / "samples" / "paper-default.yaml").read_text())
    site.update(name="crossing",
                uav={"altitude": 30.0, "max_speed": 10.0, "period": 40.0, "slots": 6},
                ground_nodes=[{"name": "W", "x": 0.0, "y": 0.0}, {"name": "E", "x": 240.0,
                                                                 "y": 0.0}],
                no_fly_zones=[{"name": "MID", "x": 120.0, "y": 0.0, "radius": 40.0}])
    site.pop("home", None)
    path = tmp / "crossing.yaml"
    path.write_text(yaml.safe_dump(site))
    return path


def plan_for(tmp: Path, site: Path, *extra: str) -> tuple[Path, Path]:
    """``plan-mission SITE -o TMP/SITE.plan EXTRA...`` as a user runs it: (plan, parameters)."""
    out = tmp / f"{site.stem}.plan"
    subprocess.run([str(PLAN_MISSION), str(site), "-o", str(out), *extra],
                   check=True, capture_output=True)
    return out, out.with_suffix(".param")
