"""Fig. 4 study end to end on a small problem, with the real planner."""

from __future__ import annotations

import csv
from pathlib import Path

from mission_planner.optimize import PlannerOptions
from mission_planner.study.config import Fig4Config
from mission_planner.study.fig4 import run_fig4
from mission_planner.study.trials import TrialSpec, run_trial

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
