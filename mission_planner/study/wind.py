"""A wind study: one site planned for and flown in a sweep of wind speeds and directions.

Each trial plans the site for one wind (``--dynamics vehicle``, as ``plan-mission --wind``)
and flies it there with the validator's model of the autopilot; beside it the site's
still-air plan (made once per worker process) is flown in the same wind. A row: the planned
and flown min rate (per flown second), the flown cycle over T, the least flown clearance and
the flight's take-off to landing time (``mission_s``, to hold against ``uav.endurance``) of
each. Trials run on the study executors (local processes or Dask, resumable: see
:func:`~mission_planner.study.executors.run_trials`); the site travels as YAML text in each
spec, so a Dask worker needs no file. Wind speed 0 is one trial whatever the directions.
"""

from __future__ import annotations

import functools
import hashlib
import math
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import yaml

from mission_planner.study.executors import StudyRun, check_scheduler, run_trials
from mission_planner.study.store import FILES as STORE_FILES
from mission_planner.study.store import check_table_format, write_table
from mission_planner.study.trials import PartialPoint, Row, is_failed
from validator.errors import InputError
from validator.motion.speed_model import check_wind_flyable
from validator.site import Site, loads_site, site_to_dict
from validator.wind import MAX_WIND_MPS, Wind

if TYPE_CHECKING:
    from mission_planner.flight_report import FlightCheck
    from mission_planner.mission import Mission
    from mission_planner.optimize import PlannerOptions

WIND_COLUMNS = (
    "key", "site", "autopilot", "speed_mps", "from_deg", "turbulence_mps",
    "min_rate_bps_hz", "flown_min_rate_bps_hz", "cycle_ratio", "clearance_min_m", "mission_s",
    "blind_flown_min_rate_bps_hz", "blind_cycle_ratio", "blind_clearance_min_m",
    "blind_mission_s", "solve_seconds", "error",
)
AUTOPILOTS = ("ardupilot", "px4")


@dataclass(frozen=True)
class WindTrialSpec:
    """A trial: the site (``site_yaml``, YAML text) planned for and flown in one wind."""

    site_yaml: str
    speed_mps: float
    from_deg: float
    turbulence_mps: float = 0.0
    autopilot: str = "ardupilot"

    @property
    def key(self) -> str:
        digest = hashlib.sha256(self.site_yaml.encode()).hexdigest()[:12]
        return (f"wind/site={digest}/ap={self.autopilot}/speed={self.speed_mps!r}"
                f"/from={self.from_deg!r}/turb={self.turbulence_mps!r}")


def wind_specs(site: Site, speeds_mps: Sequence[float], directions_deg: Sequence[float],
               turbulence_mps: float = 0.0, autopilot: str = "ardupilot"
               ) -> list[WindTrialSpec]:
    """The trials of a sweep (still air once, whatever the directions); refuses bad figures."""
    if autopilot not in AUTOPILOTS:
        raise InputError(f"--autopilot: expected one of {', '.join(AUTOPILOTS)}, "
                         f"got {autopilot!r}")
    for s in speeds_mps:
        if not (math.isfinite(s) and 0 <= s <= MAX_WIND_MPS):
            raise InputError(f"--speeds: {s:g} is not a wind speed (0 to {MAX_WIND_MPS:g} m/s)")
    for d in directions_deg:
        if not (math.isfinite(d) and 0 <= d <= 360):
            raise InputError(f"--directions: {d:g} is not a direction (0 to 360 degrees)")
    if not (math.isfinite(turbulence_mps) and 0 <= turbulence_mps <= MAX_WIND_MPS):
        raise InputError(f"--turbulence: must be 0 to {MAX_WIND_MPS:g} m/s")
    text = yaml.safe_dump(site_to_dict(site.with_limits(wind=None)), sort_keys=True)
    out = []
    for s in speeds_mps:
        for d in directions_deg:
            calm = float(s) == 0.0
            out.append(WindTrialSpec(text, float(s), 0.0 if calm else float(d) % 360.0,
                                     0.0 if calm else float(turbulence_mps), autopilot))
    for spec in out:
        # A wind at or above the top airspeed (which the autopilot and its parameters set)
        # has no plan: each of its trials failed late, one by one. The planner's own rule,
        # asked once here, refuses it before any trial.
        if spec.speed_mps > 0:
            wind = Wind(spec.speed_mps, spec.from_deg, spec.turbulence_mps)
            check_wind_flyable(site.with_limits(wind=wind), autopilot, "--speeds")
    return list(dict.fromkeys(out))


def _flown(mission: Mission, wind: Wind | None) -> FlightCheck:
    """``mission`` replayed by its autopilot's model, at its own parameter file, in ``wind``."""
    from mission_planner.autopilot_params import recommended_params
    from mission_planner.flight_report import replay_mission

    site = mission.solution.site.with_limits(wind=wind)
    return replay_mission(replace(mission, solution=replace(mission.solution, site=site)),
                          recommended_params(mission))


@functools.lru_cache(maxsize=4)
def _still_plan(site_yaml: str, autopilot: str) -> Mission:
    """The site's still-air plan (one per worker process and site)."""
    from mission_planner.cli import plan_and_build
    from mission_planner.mission import MissionOptions

    return plan_and_build(loads_site(site_yaml), options=MissionOptions(autopilot=autopilot))


def _clearance(flight: FlightCheck) -> float | None:
    values = list(flight.clearance_by_nfz_m.values())
    return min(values) if values else None


def run_wind_trial(spec: WindTrialSpec, options: PlannerOptions | None = None) -> Row:
    """Run one wind trial and return its row (keys :data:`WIND_COLUMNS`); a failure (a wind
    the vehicle cannot fly against, no flyable cycle) is a row with a one-line ``error``.
    ``options``: unused (the vehicle planner's defaults, as plan-mission's)."""
    from mission_planner.cli import plan_and_build
    from mission_planner.mission import MissionOptions

    row: Row = dict.fromkeys(WIND_COLUMNS)
    row.update(key=spec.key, autopilot=spec.autopilot, speed_mps=spec.speed_mps,
               from_deg=spec.from_deg, turbulence_mps=spec.turbulence_mps, error="")
    start = time.perf_counter()
    try:
        site = loads_site(spec.site_yaml)
        row["site"] = site.name
        wind = (Wind(spec.speed_mps, spec.from_deg, spec.turbulence_mps)
                if spec.speed_mps > 0 else None)
        mission = plan_and_build(site.with_limits(wind=wind),
                                 options=MissionOptions(autopilot=spec.autopilot))
        row["solve_seconds"] = time.perf_counter() - start
        aware = _flown(mission, wind)
        row.update(min_rate_bps_hz=mission.solution.min_rate_bps_hz,
                   flown_min_rate_bps_hz=aware.replayed_min_rate_bps_hz,
                   cycle_ratio=aware.cycle_ratio, clearance_min_m=_clearance(aware),
                   mission_s=aware.report.duration_s)
        blind = _flown(_still_plan(spec.site_yaml, spec.autopilot), wind)
        row.update(blind_flown_min_rate_bps_hz=blind.replayed_min_rate_bps_hz,
                   blind_cycle_ratio=blind.cycle_ratio, blind_clearance_min_m=_clearance(blind),
                   blind_mission_s=blind.report.duration_s)
    except Exception as err:  # a failed trial is a result, not the end of the study
        row["error"] = " ".join(f"{type(err).__name__}: {err}".split())
    if row["solve_seconds"] is None:
        row["solve_seconds"] = time.perf_counter() - start
    return row


def missing_points(rows: Sequence[Row]) -> list[tuple[str, str]]:
    """(wind, why) of each wind whose trial failed: one trial a wind, so a hole in the figure."""
    return [("still air" if not r["speed_mps"] else
             f"wind {r['speed_mps']:g} m/s from {r['from_deg']:g}°", str(r["error"]))
            for r in rows if is_failed(r)]


@dataclass
class WindResult:
    """A finished wind study: its trial rows, the files written, and the winds (of ``points``)
    that have no result (:func:`missing_points`). ``partial`` is always empty: a wind is one
    trial, so it has a result or none (the field is
    :class:`~mission_planner.study.fig4.Fig4Result`'s)."""

    run: StudyRun
    files: list[Path]
    missing: list[tuple[str, str]]
    points: int
    partial: list[PartialPoint] = field(default_factory=list)


def wind_files(table_format: str) -> tuple[str, ...]:
    """What :func:`run_wind_study` writes into its folder: the table, the figure, the log."""
    return (f"wind_trials.{table_format}", "wind.png", *STORE_FILES)


def run_wind_study(
    site: Site,
    out_dir: str | Path,
    *,
    speeds_mps: Sequence[float] = (0.0, 2.0, 4.0, 6.0, 8.0),
    directions_deg: Sequence[float] = (0.0, 90.0, 180.0, 270.0),
    turbulence_mps: float = 0.0,
    autopilot: str = "ardupilot",
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool | None = None,
    table_format: str = "csv",
    retry_errors: bool = False,
) -> WindResult:
    """Run (or resume) a wind sweep of ``site`` into ``out_dir``: ``wind_trials.csv`` (or
    ``.parquet``) and ``wind.png`` (min rate per flown second, cycle / T and least clearance
    against wind speed, a line per direction; wind-aware solid, still-air plan dashed)."""
    from mission_planner.study.plots import plot_wind, save_png

    specs = wind_specs(site, speeds_mps, directions_deg, turbulence_mps, autopilot)
    check_table_format(table_format)
    if workers is not None and workers < 1:
        raise InputError(f"--workers: must be >= 1, got {workers}")
    if scheduler is not None:
        check_scheduler(scheduler)
    out_dir = Path(out_dir)
    run = run_trials(specs, out_dir, workers=workers, scheduler=scheduler, progress=progress,
                     retry_errors=retry_errors, trial=run_wind_trial,
                     manifest={"study": "wind", "site": site.name,
                               "spec": asdict(replace(specs[0], speed_mps=0.0, from_deg=0.0,
                                                      turbulence_mps=0.0))})
    table_name, figure_name = wind_files(table_format)[:2]
    table = write_table(run.rows, out_dir / table_name, table_format, WIND_COLUMNS)
    figure = save_png(plot_wind(run.rows, site.name, directions_deg, site.buffer_m),
                      out_dir / figure_name)
    return WindResult(run=run, files=[table, figure], missing=missing_points(run.rows),
                      points=len(specs))
