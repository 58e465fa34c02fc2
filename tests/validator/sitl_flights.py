"""The shared ArduCopter 4.5.6 SITL flights of our own plans (``../shared/data/arducopter-sitl-2``).

One :class:`SitlFlight` per folder: the site, the flown plan, the ``.param`` it was flown
with, the simulator's truth track and the autopilot's events, as recorded (no project code
made them). Times are seconds from arming (the DataFlash ARM record); the current mission item
per truth sample is the last NAV item the autopilot started (its CMD log), as a 0-based
``.plan`` index. Used by the calibration tests and ``benchmarks/bench_validator.py``.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from validator.flight import Flight, resolve_flight
from validator.plan_format import Cmd, Plan, read_plan
from validator.replay import Track, track_from_geodetic
from validator.site import Site, load_site

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "arducopter-sitl-2"
PLAN_PARAMS = ("WPNAV_SPEED", "WPNAV_ACCEL", "WPNAV_JERK", "WPNAV_RADIUS")


def available() -> bool:
    return (DATA / "README.md").is_file()


def names() -> list[str]:
    """Folder names of the recorded flights (``<site>-<kind>``), sorted; none without data."""
    if not available():
        return []
    return sorted(p.name for p in DATA.iterdir() if (p / "events.csv").is_file())


@dataclass(frozen=True)
class SitlFlight:
    name: str
    site: Site
    plan: Plan
    flight: Flight
    params: dict[str, float]  # the plan's .param values as flown (autopilot units)
    t_s: NDArray[np.float64]  # truth samples, seconds from arming
    lat_deg: NDArray[np.float64]
    lon_deg: NDArray[np.float64]
    alt_m: NDArray[np.float64]  # truth altitude above home
    speed_mps: NDArray[np.float64]  # truth horizontal ground speed
    item: NDArray[np.int64]  # current NAV item (0-based plan index), -1 before AUTO
    events: tuple[dict[str, Any], ...]
    summary: dict[str, Any]

    def event_s(self, kind: str, **match: str) -> list[float]:
        """Times (s from arming) of the events of ``kind`` whose columns equal ``match``."""
        return [float(e["time_s"]) for e in self.events
                if e["type"] == kind and all(e[k] == v for k, v in match.items())]

    @property
    def mission_s(self) -> float:
        """Arming to land complete: what a replay from the start of NAV_TAKEOFF predicts."""
        return self.event_s("land_complete")[0]

    @property
    def cycle_s(self) -> float:
        """The recorded cycle (the data set's own measurement)."""
        return float(self.summary["cycle_s"])

    def track(self) -> Track:
        return track_from_geodetic(self.flight, self.site, self.t_s, self.lat_deg, self.lon_deg,
                                   self.item, alt_m=self.alt_m, source=f"sitl:{self.name}")


def _param_file(path: Path) -> dict[str, float]:
    out = {}
    for line in path.read_text().splitlines():
        parts = line.split("#", 1)[0].split()
        if len(parts) == 2 and parts[0] in PLAN_PARAMS:
            out[parts[0]] = float(parts[1])
    return out


@cache
def load(name: str) -> SitlFlight:
    folder = DATA / name
    site = load_site(folder / "site.yaml")
    plan = read_plan(folder / f"{name}.plan")
    flight = resolve_flight(plan, site)
    with open(folder / "truth_20hz.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    col = {k: np.array([float(r[k]) for r in rows]) for k in
           ("time_s", "lat", "lon", "alt_rel_m", "vn", "ve")}
    with open(folder / "events.csv", newline="") as f:
        events = tuple(csv.DictReader(f))
    nav = {int(c) for c in (Cmd.NAV_TAKEOFF, Cmd.NAV_WAYPOINT, Cmd.NAV_LAND,
                            Cmd.NAV_RETURN_TO_LAUNCH, Cmd.NAV_LOITER_TIME)}
    starts = [(float(e["time_s"]), int(e["plan_item"])) for e in events
              if e["type"] == "item_start" and float(e["time_s"]) > 0
              and int(plan.items[int(e["plan_item"])].command) in nav]
    disarm = min((float(e["time_s"]) for e in events if e["type"] == "disarmed"),
                 default=math.inf)
    starts = [s for s in starts if s[0] < disarm]  # the mission resets to item 1 on disarm
    t = col["time_s"]
    item = np.full(t.size, -1, dtype=np.int64)
    for at, idx in starts:
        item[t >= at] = idx
    return SitlFlight(
        name=name, site=site, plan=plan, flight=flight,
        params=_param_file(folder / f"{name}.param"),
        t_s=t, lat_deg=col["lat"], lon_deg=col["lon"], alt_m=col["alt_rel_m"],
        speed_mps=np.hypot(col["vn"], col["ve"]), item=item, events=events,
        summary=json.loads((folder / "summary.json").read_text()),
    )
