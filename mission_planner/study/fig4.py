"""The paper's Fig. 4: outage probability and spectral efficiency against NFZ radius and count.

Two sweeps over random sites (:func:`random_site`): the NFZ radius R with M = ``num_nfzs``
zones, and the NFZ count M with radius ``radius_m``. Each point runs ``trials`` sites, each
site under both schemes (paired: both schemes see the same sites). Trial i of every point uses
the site seed :func:`trial_seed` (study seed, i), so points differ only by the swept parameter;
the point both sweeps share runs once.

Default safety buffer is 0 m, as in the paper; outage is measured against the published radius
whatever the buffer (see :mod:`mission_planner.study.trials`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mission_planner.study.executors import StudyRun, check_scheduler, run_trials
from mission_planner.study.sites import PAPER_AREA_M
from mission_planner.study.stats import mean_interval, proportion_interval
from mission_planner.study.store import check_table_format, write_table
from mission_planner.study.trials import TrialSpec, is_failed
from validator.errors import InputError
from validator.fileio import write_atomic

SCHEMES = ("proposed", "conventional")
SWEEPS = ("radius", "count")
SUMMARY_COLUMNS = (
    "sweep", "radius_m", "num_nfzs", "scheme", "trials", "failed", "outages",
    "outage_probability", "outage_ci_low", "outage_ci_high",
    "spectral_efficiency_bps_hz", "spectral_efficiency_ci_low", "spectral_efficiency_ci_high",
    "min_rate_bps_hz", "solve_seconds_mean",
)


@dataclass(frozen=True)
class Fig4Config:
    """The parameters of a Fig. 4 study (the paper's values by default)."""

    trials: int = 100
    radii_m: tuple[float, ...] = (10.0, 20.0, 30.0, 40.0, 50.0)
    counts: tuple[int, ...] = (1, 2, 3, 4, 5)
    seed: int = 0
    slots: int = 50
    num_gns: int = 4
    radius_m: float = 30.0  # the radius of every zone in the count sweep
    num_nfzs: int = 3  # the zone count in the radius sweep
    buffer_m: float = 0.0
    area_m: float = PAPER_AREA_M
    schemes: tuple[str, ...] = field(default=SCHEMES)

    def check(self) -> None:
        """Raise :class:`InputError` naming the first bad option."""
        if self.trials < 1:
            raise InputError(f"--trials: must be >= 1, got {self.trials}")
        if not self.radii_m or any(not r > 0 for r in self.radii_m):
            raise InputError(f"--radii: need radii > 0 m, got {list(self.radii_m)}")
        if not self.counts or any(m < 0 for m in self.counts):
            raise InputError(f"--counts: need counts >= 0, got {list(self.counts)}")
        if self.seed < 0:
            raise InputError(f"--seed: must be >= 0, got {self.seed}")
        if self.slots < 2:
            raise InputError(f"--slots: must be >= 2, got {self.slots}")
        if self.num_gns < 1:
            raise InputError(f"--gns: must be >= 1, got {self.num_gns}")
        if not self.radius_m > 0:
            raise InputError(f"--radius: must be > 0 m, got {self.radius_m}")
        if self.num_nfzs < 0:
            raise InputError(f"--count: must be >= 0, got {self.num_nfzs}")
        if self.buffer_m < 0:
            raise InputError(f"--buffer-m: must be >= 0, got {self.buffer_m}")
        for s in self.schemes:
            if s not in SCHEMES:
                raise InputError(f"schemes: unknown scheme {s!r} (expected {', '.join(SCHEMES)})")

    def points(self) -> list[tuple[str, float, int]]:
        """(sweep, radius_m, num_nfzs) of every point, radius sweep first."""
        return [("radius", float(r), self.num_nfzs) for r in self.radii_m] + [
            ("count", float(self.radius_m), int(m)) for m in self.counts
        ]

    def spec(self, index: int, radius_m: float, num_nfzs: int, scheme: str) -> TrialSpec:
        """Trial ``index`` of the point (``radius_m``, ``num_nfzs``) under ``scheme``."""
        return TrialSpec(seed=trial_seed(self.seed, index), scheme=scheme, num_gns=self.num_gns,
                         num_nfzs=num_nfzs, radius_m=radius_m, slots=self.slots,
                         buffer_m=self.buffer_m, area_m=self.area_m)

    def specs(self) -> list[TrialSpec]:
        """Every trial, trial index outermost so an interrupted study covers all points evenly."""
        out = [
            self.spec(i, radius, count, scheme)
            for i in range(self.trials)
            for _, radius, count in self.points()
            for scheme in self.schemes
        ]
        return list(dict.fromkeys(out))


def trial_seed(study_seed: int, index: int) -> int:
    """The site seed of trial ``index`` of a study: well mixed, reproducible, 32-bit."""
    return int(np.random.SeedSequence([study_seed, index]).generate_state(1, dtype=np.uint32)[0])


def summarize(rows: Sequence[dict[str, Any]], config: Fig4Config) -> list[dict[str, Any]]:
    """One summary row per (sweep point, scheme) from the trial rows.

    Failed trials are counted in ``failed`` and left out of the estimates. Spectral efficiency
    (bps/Hz) is the mean over trials of the min rate, zero on outage; ``min_rate_bps_hz`` is
    the plain mean of the min rate (what the scheme achieves ignoring its violations).
    """
    by_key = {r["key"]: r for r in rows}
    out = []
    for sweep, radius, count in config.points():
        for scheme in config.schemes:
            keys = (config.spec(i, radius, count, scheme).key for i in range(config.trials))
            group = [by_key[k] for k in keys if k in by_key]
            ok = [r for r in group if not is_failed(r)]
            outages = sum(bool(r["outage"]) for r in ok)
            se = [float(r["spectral_efficiency_bps_hz"]) for r in ok]
            rate = [float(r["min_rate_bps_hz"]) for r in ok]
            p_low, p_high = proportion_interval(outages, len(ok))
            se_low, se_high = mean_interval(se)
            out.append({
                "sweep": sweep, "radius_m": radius, "num_nfzs": count, "scheme": scheme,
                "trials": len(group), "failed": len(group) - len(ok), "outages": outages,
                "outage_probability": outages / len(ok) if ok else math.nan,
                "outage_ci_low": p_low, "outage_ci_high": p_high,
                "spectral_efficiency_bps_hz": float(np.mean(se)) if se else math.nan,
                "spectral_efficiency_ci_low": se_low, "spectral_efficiency_ci_high": se_high,
                "min_rate_bps_hz": float(np.mean(rate)) if rate else math.nan,
                "solve_seconds_mean": float(np.mean([r["solve_seconds"] for r in group]))
                if group else math.nan,
            })
    return out


@dataclass
class Fig4Result:
    """A finished Fig. 4 study: trial rows, summary rows and the files written."""

    run: StudyRun
    summary: list[dict[str, Any]]
    files: list[Path]


def run_fig4(
    out_dir: str | Path,
    config: Fig4Config | None = None,
    *,
    options: Any = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool | None = None,
    table_format: str = "csv",
    retry_errors: bool = False,
) -> Fig4Result:
    """Run (or resume) a Fig. 4 study into ``out_dir`` and write its table, summary and plots.

    Files: ``trials.csv`` (or ``trials.parquet``; every trial), ``fig4_summary.csv``,
    ``fig4a_spectral_efficiency.png``, ``fig4b_outage.png``; ``trials.jsonl`` and
    ``study.json`` make re-running into ``out_dir`` resume. See :func:`run_trials` for the
    executor arguments.
    """
    from mission_planner.optimize import PlannerOptions
    from mission_planner.study.plots import plot_fig4, save_png
    from mission_planner.study.store import table_csv

    options = options if options is not None else PlannerOptions()
    config = config or Fig4Config()
    config.check()
    check_table_format(table_format)
    if workers is not None and workers < 1:
        raise InputError(f"--workers: must be >= 1, got {workers}")
    if scheduler is not None:
        check_scheduler(scheduler)
    out_dir = Path(out_dir)
    run = run_trials(config.specs(), out_dir, options=options, workers=workers,
                     scheduler=scheduler, progress=progress, retry_errors=retry_errors,
                     manifest={"planner_options": _options_record(options)})
    summary = summarize(run.rows, config)
    table = write_table(run.rows, out_dir / f"trials.{table_format}", table_format)
    summary_path = out_dir / "fig4_summary.csv"
    write_atomic(summary_path, table_csv(summary, SUMMARY_COLUMNS))
    fig_a, fig_b = plot_fig4(summary, config)
    path_a = save_png(fig_a, out_dir / "fig4a_spectral_efficiency.png")
    path_b = save_png(fig_b, out_dir / "fig4b_outage.png")
    return Fig4Result(run=run, summary=summary, files=[table, summary_path, path_a, path_b])


def _options_record(options: Any) -> Any:
    """Planner options (a dataclass) as JSON-ready data."""
    try:
        return asdict(options)
    except TypeError:
        return repr(options)
