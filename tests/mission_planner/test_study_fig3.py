"""Fig. 3: both schemes on one site, tables and plots, with the real planner."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from mission_planner.optimize import PlannerOptions, Solution
from mission_planner.study.config import trial_seed
from mission_planner.study.fig3 import run_fig3
from mission_planner.study.sites import random_site
from validator.errors import InputError

FAST = PlannerOptions(max_iterations=15, dynamics="none")  # the paper's algorithm
Fig3Files = tuple[Path, list[Solution]]


@pytest.fixture(scope="module")
def fig3(tmp_path_factory: pytest.TempPathFactory) -> Fig3Files:
    out = tmp_path_factory.mktemp("fig3")
    site = random_site(trial_seed(0, 1), radius_m=50.0, slots=10)
    result = run_fig3(site, out, options=FAST)
    return out, result.solutions


def _read(path: Path) -> list[dict[str, str]]:
    with path.open() as f:
        return list(csv.DictReader(f))


def test_fig3_writes_both_plots_and_tables(fig3: Fig3Files) -> None:
    out, _ = fig3
    for name in ("fig3a_trajectory.png", "fig3b_slots.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [r["scheme"] for r in _read(out / "fig3_summary.csv")] == ["proposed", "conventional"]


def test_slot_table_has_every_slot_of_both_schemes(fig3: Fig3Files) -> None:
    out, solutions = fig3
    rows = _read(out / "fig3_slots.csv")
    assert len(rows) == sum(len(s.delta_s) for s in solutions)
    for sol in solutions:
        mine = [r for r in rows if r["scheme"] == sol.scheme]
        np.testing.assert_array_equal([float(r["delta_s"]) for r in mine], sol.delta_s)
        np.testing.assert_array_equal([float(r["power_w"]) for r in mine], sol.power_w)


def test_legs_marked_inside_an_nfz_are_the_ones_that_enter_it(fig3: Fig3Files) -> None:
    out, solutions = fig3
    rows = _read(out / "fig3_slots.csv")
    summary = {r["scheme"]: r for r in _read(out / "fig3_summary.csv")}
    for sol in solutions:
        marked = [r["leg_in_nfz"] == "True" for r in rows if r["scheme"] == sol.scheme]
        assert marked == list(np.any(sol.nfz_clearance_m < 0, axis=1))
        assert int(summary[sol.scheme]["legs_in_nfz"]) == sum(marked)
    assert int(summary["proposed"]["legs_in_nfz"]) == 0
    assert int(summary["conventional"]["legs_in_nfz"]) > 0  # this site shows the paper's point


def test_negative_buffer_is_refused_before_planning(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="--buffer-m"):
        run_fig3(random_site(0, slots=10), tmp_path / "out", buffer_m=-1.0)
    assert not (tmp_path / "out").exists()
