"""Fig. 4 study end to end on a small problem, with the real planner."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from mission_planner.optimize import PlannerOptions
from mission_planner.study.config import Fig4Config
from mission_planner.study.fig4 import missing_points, partial_points, run_fig4, summarize
from mission_planner.study.plots import plot_fig4
from mission_planner.study.trials import Row, TrialSpec, run_trial

FAST = PlannerOptions(max_iterations=15, dynamics="none")  # the paper's algorithm
# Large zones and few, long legs (N = 10 slots of ~5 s at up to 30 m/s): point-only constraints
# let legs cut straight through zones, which the expanded constraint must never allow.
SMALL = Fig4Config(trials=3, radii_m=(50.0,), counts=(3,), radius_m=50.0, num_nfzs=3, slots=10)


def test_small_fig4_shows_outage_for_conventional_only(tmp_path: Path) -> None:
    result = run_fig4(tmp_path, SMALL, options=FAST, workers=1, progress=False)
    assert not result.run.failed
    by_scheme = {(r["sweep"], r["scheme"]): r for r in result.summary}
    for sweep in ("radius", "count"):
        assert by_scheme[(sweep, "conventional")]["outage_probability"] > 0
        assert by_scheme[(sweep, "proposed")]["outage_probability"] == 0
        assert by_scheme[(sweep, "proposed")]["spectral_efficiency_bps_hz"] > 0
    conventional = [r for r in result.run.rows if r["scheme"] == "conventional"]
    assert all(r["nfz_clearance_min_m"] < 0 for r in conventional if r["outage"])
    assert all(r["spectral_efficiency_bps_hz"] == 0 for r in conventional if r["outage"])


def test_fig4_writes_table_summary_and_plots(tmp_path: Path) -> None:
    config = Fig4Config(trials=1, radii_m=(50.0,), counts=(3,), radius_m=50.0, slots=10)
    result = run_fig4(tmp_path, config, options=FAST, workers=1, progress=False)
    names = {p.name for p in result.files}
    assert names == {"trials.csv", "fig4_summary.csv", "fig4a_spectral_efficiency.png",
                     "fig4b_outage.png"}
    for p in result.files:
        if p.suffix == ".png":
            assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with (tmp_path / "trials.csv").open() as f:
        table = list(csv.DictReader(f))
    assert [r["key"] for r in table] == [r["key"] for r in result.run.rows]
    assert {"seed", "scheme", "min_rate_bps_hz", "nfz_clearance_min_m", "outage",
            "solve_seconds", "iterations", "error"} <= set(table[0])
    with (tmp_path / "fig4_summary.csv").open() as f:
        assert len(list(csv.DictReader(f))) == len(result.summary) == 4


def test_outage_is_judged_against_the_published_radius_not_the_buffer() -> None:
    row = run_trial(TrialSpec(seed=5, scheme="proposed", radius_m=40.0, slots=10,
                              buffer_m=5.0), FAST)
    assert row["error"] == ""
    assert row["nfz_clearance_min_m"] >= 5.0 and row["outage"] is False


def _rows(config: Fig4Config, errors: dict[tuple[int, str], str]) -> list[Row]:
    """A row for each trial of ``config``, failed with ``errors[(trial, scheme)]`` where
    given, else a plan of min rate 1 bps/Hz (no outage)."""
    rows = []
    for i in range(config.trials):
        for _, radius, count in config.points():
            for scheme in config.schemes:
                spec = config.spec(i, radius, count, scheme)
                error = errors.get((i, scheme), "")
                rate = None if error else 1.0
                rows.append({"key": spec.key, "scheme": scheme, "error": error,
                             "min_rate_bps_hz": rate, "spectral_efficiency_bps_hz": rate,
                             "outage": None if error else False, "solve_seconds": 0.1})
    return rows


THREE = Fig4Config(trials=3, radii_m=(50.0,), counts=(3,), radius_m=50.0, num_nfzs=3, slots=10)


def test_a_point_that_lost_some_trials_is_partial_with_its_first_error_in_trial_order() -> None:
    """The rows arrive in any order (processes, Dask); the first error is trial order's."""
    rows = _rows(THREE, {(2, "proposed"): "SolverError: two", (1, "proposed"): "SolverError: one"})
    summary = summarize(rows[::-1], THREE)
    proposed = [r for r in summary if r["scheme"] == "proposed"]
    assert [(r["trials"], r["failed"], r["first_error"]) for r in proposed] == [
        (3, 2, "SolverError: one")] * 2
    assert all((r["failed"], r["first_error"]) == (0, "") for r in summary
               if r["scheme"] == "conventional")
    partial = partial_points(summary, THREE)
    assert [p.point for p in partial] == ["radius sweep R=50 m", "count sweep M=3"]
    assert partial[0].warning() == ("radius sweep R=50 m: 2 of 3 trials failed under proposed; "
                                    "its result averages the trials left (first: SolverError: "
                                    "one)")
    assert missing_points(rows, THREE) == []


def test_a_scheme_that_lost_every_trial_is_missing_not_partial() -> None:
    rows = _rows(THREE, {(i, "conventional"): "SolverError: x" for i in range(3)})
    assert partial_points(summarize(rows, THREE), THREE) == []
    assert missing_points(rows, THREE)[0] == ("radius sweep R=50 m (conventional)",
                                              "SolverError: x")


def test_the_figure_marks_a_point_that_lost_trials_hollow_with_the_sites_kept() -> None:
    rows = _rows(THREE, {(1, "proposed"): "SolverError: one"})
    fig_a, _ = plot_fig4(summarize(rows, THREE), THREE)
    ax = fig_a.axes[0]
    hollow = [line for line in ax.get_lines() if line.get_markerfacecolor() == "white"]
    assert len(hollow) == 1 and list(hollow[0].get_xdata()) == [50.0]
    assert [t.get_text() for t in ax.texts] == ["2/3"]
    legend = fig_a.axes[1].get_legend()
    assert any("some trials failed" in t.get_text() for t in legend.get_texts())


def test_dask_gives_the_local_summary_and_partial_points(tmp_path: Path) -> None:
    """The failures, their counts and first errors are the same on any executor."""
    distributed = pytest.importorskip("distributed")
    # three zones of 90 m: trial 0's site cannot be drawn, trial 1's can
    config = Fig4Config(trials=2, radii_m=(90.0,), counts=(3,), radius_m=90.0, slots=10)
    local = run_fig4(tmp_path / "local", config, options=FAST, workers=2, progress=False)
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        remote = run_fig4(tmp_path / "dask", config, options=FAST,
                          scheduler=cluster.scheduler_address, progress=False)

    def kept(summary: list[Row]) -> list[Row]:
        return [{k: v for k, v in r.items() if k != "solve_seconds_mean"} for r in summary]

    assert len(local.partial) == 2 and local.partial[0].failed == 2
    assert (remote.partial, remote.missing) == (local.partial, local.missing)
    assert str(kept(remote.summary)) == str(kept(local.summary))  # nan == nan as text
