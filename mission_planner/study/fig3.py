"""The paper's Fig. 3: both schemes planned on one site, drawn and tabulated.

Files written by :func:`run_fig3`: ``fig3a_trajectory.png`` (map), ``fig3b_slots.png``
(δ[n], p[n]), ``fig3_slots.csv`` (one row per scheme and slot) and ``fig3_summary.csv`` (one row
per scheme). Clearances and outage are against the NFZs as published; the planner keeps legs out
of the zones plus the site's safety buffer (paper: 0 m; pass ``buffer_m`` to override).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mission_planner.optimize.solution import Solution
from mission_planner.study.store import table_csv
from mission_planner.study.trials import Row
from validator.errors import InputError
from validator.fileio import write_atomic
from validator.site import Site

if TYPE_CHECKING:
    from mission_planner.optimize import PlannerOptions

SCHEMES = ("proposed", "conventional")
MAP_PNG, SLOTS_PNG = "fig3a_trajectory.png", "fig3b_slots.png"
SLOTS_CSV, SUMMARY_CSV = "fig3_slots.csv", "fig3_summary.csv"
FILES = (MAP_PNG, SLOTS_PNG, SLOTS_CSV, SUMMARY_CSV)  # what run_fig3 writes into its folder
SLOT_COLUMNS = (
    "scheme", "slot", "x_m", "y_m", "delta_s", "power_w", "gn", "leg_length_m",
    "leg_clearance_min_m", "leg_in_nfz", "nfz_entered",
)
SUMMARY_COLUMNS = (
    "scheme", "min_rate_bps_hz", "nfz_clearance_min_m", "outage", "legs_in_nfz", "iterations",
    "solve_seconds",
)


def slot_rows(sol: Solution) -> list[Row]:
    """One row per slot n = 1..N: q[n] (m), δ[n] (s), p[n] (W), the GN served, and the leg
    q[n-1]→q[n]: length (m), smallest clearance from any NFZ (m) and the zones it enters."""
    site = sol.site
    clearance = sol.nfz_clearance_m
    legs = sol.leg_length_m
    rows: list[Row] = []
    for n in range(len(sol.delta_s)):
        entered = [site.nfz_names[m] for m in np.flatnonzero(clearance[n] < 0.0)] \
            if site.num_nfzs else []
        k = int(sol.schedule[n])
        rows.append({
            "scheme": sol.scheme,
            "slot": n + 1,
            "x_m": float(sol.trajectory_m[n + 1, 0]),
            "y_m": float(sol.trajectory_m[n + 1, 1]),
            "delta_s": float(sol.delta_s[n]),
            "power_w": float(sol.power_w[n]),
            "gn": site.gn_names[k] if k >= 0 else "",
            "leg_length_m": float(legs[n]),
            "leg_clearance_min_m": float(np.min(clearance[n])) if site.num_nfzs else None,
            "leg_in_nfz": bool(entered),
            "nfz_entered": ";".join(entered),
        })
    return rows


def summary_row(sol: Solution) -> Row:
    """Min rate (bps/Hz), smallest leg clearance (m), outage and effort of one solution."""
    clearance = sol.nfz_clearance_min_m
    legs_in = int(np.sum(np.any(sol.nfz_clearance_m < 0.0, axis=1))) if sol.site.num_nfzs else 0
    return {
        "scheme": sol.scheme,
        "min_rate_bps_hz": sol.min_rate_bps_hz,
        "nfz_clearance_min_m": clearance if np.isfinite(clearance) else None,
        "outage": bool(clearance < 0.0),
        "legs_in_nfz": legs_in,
        "iterations": sol.iterations,
        "solve_seconds": sol.solve_seconds,
    }


@dataclass
class Fig3Result:
    """Both schemes' solutions and the files written."""

    solutions: list[Solution]
    files: list[Path]


def plan_both(site: Site, options: PlannerOptions | None = None, schemes: Sequence[str] = SCHEMES
              ) -> list[Solution]:
    """Plan ``site`` with each scheme (proposed first); ``options`` None: the paper's model
    (:data:`~mission_planner.optimize.PAPER_OPTIONS`)."""
    from mission_planner.optimize import PAPER_OPTIONS, plan

    options = options if options is not None else PAPER_OPTIONS
    return [plan(site, scheme=s, options=options) for s in schemes]


def run_fig3(
    site: Site,
    out_dir: str | Path,
    *,
    options: PlannerOptions | None = None,
    buffer_m: float | None = None,
) -> Fig3Result:
    """Plan ``site`` with both schemes and write Fig. 3's plots and tables into ``out_dir``.

    ``buffer_m`` replaces the site's safety buffer (m) when given; 0 reproduces the paper.
    """
    from mission_planner.study.plots import plot_fig3_map, plot_fig3_slots, save_png

    if buffer_m is not None:
        if buffer_m < 0:
            raise InputError(f"--buffer-m: must be >= 0, got {buffer_m}")
        site = site.with_buffer(buffer_m)
    solutions = plan_both(site, options)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    slots = [r for sol in solutions for r in slot_rows(sol)]
    files = [
        save_png(plot_fig3_map(solutions), out_dir / MAP_PNG),
        save_png(plot_fig3_slots(solutions), out_dir / SLOTS_PNG),
    ]
    for name, rows, columns in (
        (SLOTS_CSV, slots, SLOT_COLUMNS),
        (SUMMARY_CSV, [summary_row(s) for s in solutions], SUMMARY_COLUMNS),
    ):
        write_atomic(out_dir / name, table_csv(rows, columns))
        files.append(out_dir / name)
    return Fig3Result(solutions=solutions, files=files)
