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
from typing import TYPE_CHECKING

import numpy as np

from mission_planner.study.config import Fig4Config
from mission_planner.study.executors import StudyRun, check_scheduler, run_trials
from mission_planner.study.stats import mean_interval, proportion_interval
from mission_planner.study.store import check_table_format, write_table
from mission_planner.study.trials import Cell, PartialPoint, Row, cell_float, is_failed
from validator.errors import InputError
from validator.fileio import write_atomic

if TYPE_CHECKING:
    from mission_planner.optimize import PlannerOptions

SWEEPS = ("radius", "count")
SUMMARY_COLUMNS = (
    "sweep", "radius_m", "num_nfzs", "scheme", "trials", "failed", "first_error", "outages",
    "outage_probability", "outage_ci_low", "outage_ci_high",
    "spectral_efficiency_bps_hz", "spectral_efficiency_ci_low", "spectral_efficiency_ci_high",
    "min_rate_bps_hz", "solve_seconds_mean",
)


def summarize(rows: Sequence[Row], config: Fig4Config) -> list[Row]:
    """One summary row per (sweep point, scheme) from the trial rows.

    ``trials`` counts the point's trials run under the scheme, ``failed`` those that failed
    (``first_error``: the first one's error, in trial order, so the same on any executor); the
    failed are left out of the estimates. Spectral efficiency
    (bps/Hz) is the mean over trials of the min rate, zero on outage; ``min_rate_bps_hz`` is
    the plain mean of the min rate (what the scheme achieves ignoring its violations).
    """
    by_key = {r["key"]: r for r in rows}
    out: list[Row] = []
    for sweep, radius, count in config.points():
        for scheme in config.schemes:
            group = _trials_of(by_key, config, radius, count, scheme)
            ok = [r for r in group if not is_failed(r)]
            outages = sum(bool(r["outage"]) for r in ok)
            se = [cell_float(r["spectral_efficiency_bps_hz"]) for r in ok]
            rate = [cell_float(r["min_rate_bps_hz"]) for r in ok]
            p_low, p_high = proportion_interval(outages, len(ok))
            se_low, se_high = mean_interval(se)
            out.append({
                "sweep": sweep, "radius_m": radius, "num_nfzs": count, "scheme": scheme,
                "trials": len(group), "failed": len(group) - len(ok),
                "first_error": next((str(r["error"]) for r in group if is_failed(r)), ""),
                "outages": outages,
                "outage_probability": outages / len(ok) if ok else math.nan,
                "outage_ci_low": p_low, "outage_ci_high": p_high,
                "spectral_efficiency_bps_hz": float(np.mean(se)) if se else math.nan,
                "spectral_efficiency_ci_low": se_low, "spectral_efficiency_ci_high": se_high,
                "min_rate_bps_hz": float(np.mean(rate)) if rate else math.nan,
                "solve_seconds_mean": float(np.mean([cell_float(r["solve_seconds"])
                                                     for r in group]))
                if group else math.nan,
            })
    return out


def _trials_of(by_key: dict[Cell, Row], config: Fig4Config, radius_m: float, count: int,
               scheme: str) -> list[Row]:
    """The rows of one point's trials under ``scheme``, in trial order."""
    keys = (config.spec(i, radius_m, count, scheme).key for i in range(config.trials))
    return [by_key[k] for k in keys if k in by_key]


def missing_points(rows: Sequence[Row], config: Fig4Config) -> list[tuple[str, str]]:
    """(point, why) of each sweep point that has no result, for every scheme or some: each of
    its trials failed (why: the first one's error). Such a point is a hole in the figure and
    the summary, however well the other points went."""
    by_key = {r["key"]: r for r in rows}
    out: list[tuple[str, str]] = []
    for sweep, radius, count in config.points():
        empty, why = [], ""
        for scheme in config.schemes:
            group = _trials_of(by_key, config, radius, count, scheme)
            if all(is_failed(r) for r in group):
                empty.append(scheme)
                why = why or (str(group[0]["error"]) if group else "not run")
        if empty:
            out.append((_point_name(sweep, radius, count, empty, config), why))
    return out


def _point_name(sweep: str, radius_m: float, count: int, schemes: Sequence[str],
                config: Fig4Config) -> str:
    """``radius sweep R=30 m``, naming ``schemes`` when they are not all of the study's."""
    point = f"{sweep} sweep " + (f"R={radius_m:g} m" if sweep == "radius" else f"M={count}")
    if len(schemes) < len(config.schemes):
        point += f" ({', '.join(schemes)})"
    return point


def partial_points(summary: Sequence[Row], config: Fig4Config) -> list[PartialPoint]:
    """Each sweep point that lost some of its trials under a scheme but not all: its estimate
    averages the sites left, which may lean to the easier ones. Its trials are counted under
    the schemes that lost some (a scheme that lost all is in :func:`missing_points`)."""
    out: list[PartialPoint] = []
    for sweep, radius, count in config.points():
        rows = [r for r in summary if r["sweep"] == sweep and r["radius_m"] == radius
                and r["num_nfzs"] == count]
        lost = [r for r in rows if 0 < int(cell_float(r["failed"])) < int(cell_float(r["trials"]))]
        if lost:
            by_scheme = tuple((str(r["scheme"]), int(cell_float(r["failed"])),
                               int(cell_float(r["trials"]))) for r in lost)
            out.append(PartialPoint(
                point=_point_name(sweep, radius, count, config.schemes, config),
                trials=sum(n for _, _, n in by_scheme), failed=sum(f for _, f, _ in by_scheme),
                error=str(lost[0]["first_error"]), by_scheme=by_scheme))
    return out


@dataclass
class Fig4Result:
    """A finished Fig. 4 study: trial rows, summary rows, the files written, the sweep points
    (of ``points``) that have no result (:func:`missing_points`) and those that lost some of
    their trials (:func:`partial_points`)."""

    run: StudyRun
    summary: list[Row]
    files: list[Path]
    missing: list[tuple[str, str]]
    points: int
    partial: list[PartialPoint] = field(default_factory=list)


def run_fig4(
    out_dir: str | Path,
    config: Fig4Config | None = None,
    *,
    options: PlannerOptions | None = None,
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
    from mission_planner.optimize import PAPER_OPTIONS
    from mission_planner.study.plots import plot_fig4, save_png
    from mission_planner.study.store import table_csv

    options = options if options is not None else PAPER_OPTIONS
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
    return Fig4Result(run=run, summary=summary, files=[table, summary_path, path_a, path_b],
                      missing=missing_points(run.rows, config), points=len(config.points()),
                      partial=partial_points(summary, config))


def _options_record(options: PlannerOptions) -> dict[str, object] | str:
    """Planner options (a dataclass) as JSON-ready data."""
    try:
        return asdict(options)
    except TypeError:
        return repr(options)
