"""PX4 v1.15.4 SIH flights of our own plans (``tests/data/px4-sih``), for the calibration tests
and ``benchmarks/bench_validator.py``: per folder the site, the plan, its parameter file and
the recorded track (:mod:`validator.track_file`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from validator.autopilot.param_file import read_params
from validator.flight import Flight, resolve_flight
from validator.plan_format import Plan, read_plan
from validator.replay import Track
from validator.site import Site, load_site
from validator.track_file import RecordedTrack, read_track

DATA = Path(__file__).resolve().parents[1] / "data" / "px4-sih"


def names() -> list[str]:
    """Folder names of the recorded flights, sorted."""
    return sorted(p.name for p in DATA.iterdir() if (p / "track.csv.gz").is_file())


@dataclass(frozen=True)
class Px4Flight:
    name: str
    site: Site
    plan: Plan
    flight: Flight
    params: dict[str, float]  # the parameter file the vehicle flew with (PX4 units)
    recorded: RecordedTrack

    def track(self) -> Track:
        return self.recorded.track(self.flight, self.site, source=f"px4-sih:{self.name}")

    @property
    def mission_s(self) -> float:
        """Takeoff to disarm (s): what a replay from the takeoff predicts (the last sample
        when the recording stopped at the landing, before the disarm)."""
        end = self.recorded.disarmed_s
        return end if math.isfinite(end) else float(self.recorded.t_s[-1])


@cache
def load(name: str) -> Px4Flight:
    folder = DATA / name
    site = load_site(folder / "site.yaml")
    plan = read_plan(folder / "mission.plan")
    flight = resolve_flight(plan, site, str(folder / "mission.plan"))
    return Px4Flight(name, site, plan, flight, read_params(folder / "mission.param"),
                     read_track(folder / "track.csv.gz"))
