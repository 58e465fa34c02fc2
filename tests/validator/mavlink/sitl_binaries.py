"""Where the real-autopilot tests find a SITL binary built for this machine: an environment
variable, else a documented path (README, *Real autopilots*)."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
PLAN_MISSION = shutil.which("plan-mission", path=str(Path(sys.executable).parent))


def sitl_binary(env: str, documented: Path) -> Path | None:
    """``$env`` if set, else ``documented``; None unless it is an executable file."""
    given = os.environ.get(env)
    path = Path(given) if given else documented
    return path if path.is_file() and os.access(path, os.X_OK) else None
