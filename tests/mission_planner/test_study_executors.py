"""Running trials: local processes and Dask give one table; interrupted studies resume."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from mission_planner.optimize import PlannerOptions
from mission_planner.study.executors import run_trials
from mission_planner.study.store import LOG_NAME
from mission_planner.study.trials import WALL_TIME_COLUMNS, TrialSpec

# Small problems and a short iteration cap keep each solve around a second; the tables compared
# below come from the real planner all the same.
FAST = PlannerOptions(max_iterations=15, dynamics="none")  # the paper's algorithm


def _specs(seeds: range) -> list[TrialSpec]:
    return [
        TrialSpec(seed=s, scheme=scheme, num_nfzs=3, radius_m=50.0, slots=10)
        for s in seeds for scheme in ("proposed", "conventional")
    ]


def _deterministic(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k not in WALL_TIME_COLUMNS} for r in rows]


def _logged_keys(directory: Path) -> list[str]:
    lines = (directory / LOG_NAME).read_text().splitlines()
    return [json.loads(line)["key"] for line in lines]


def test_dask_cluster_gives_the_same_table_as_local_processes(tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed")
    specs = _specs(range(2))
    local = run_trials(specs, tmp_path / "local", options=FAST, workers=2, progress=False)
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        remote = run_trials(specs, tmp_path / "dask", options=FAST,
                            scheduler=cluster.scheduler_address, progress=False)
    assert [r["key"] for r in remote.rows] == [s.key for s in specs]
    assert all(not r["error"] for r in local.rows)
    assert _deterministic(remote.rows) == _deterministic(local.rows)


def test_interrupted_study_resumes_without_repeating_finished_trials(tmp_path: Path) -> None:
    specs = _specs(range(2))

    def interrupt(row: dict[str, Any]) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_trials(specs, tmp_path, options=FAST, workers=2, progress=False, on_row=interrupt)
    first = _logged_keys(tmp_path)
    assert len(first) == 1

    ran: list[str] = []
    resumed = run_trials(specs, tmp_path, options=FAST, workers=2, progress=False,
                         on_row=lambda row: ran.append(row["key"]))
    assert resumed.executed == len(specs) - 1 and resumed.skipped == 1
    assert first[0] not in ran
    assert sorted(_logged_keys(tmp_path)) == sorted(s.key for s in specs)
    assert [r["key"] for r in resumed.rows] == [s.key for s in specs]


def test_finished_study_reruns_nothing(tmp_path: Path) -> None:
    specs = _specs(range(1))[:1]
    first = run_trials(specs, tmp_path, options=FAST, workers=1, progress=False)
    again = run_trials(specs, tmp_path, options=FAST, workers=1, progress=False)
    assert (first.executed, again.executed) == (1, 0)
    assert again.rows == first.rows


def test_failed_trial_is_kept_and_the_study_goes_on(tmp_path: Path) -> None:
    bad = TrialSpec(seed=1, scheme="proposed", num_nfzs=10, radius_m=100.0, slots=10)
    good = _specs(range(1))[0]
    run = run_trials([bad, good], tmp_path, options=FAST, workers=1, progress=False)
    assert [r["key"] for r in run.rows] == [bad.key, good.key]
    assert run.failed == [run.rows[0]] and "num_nfzs" in run.rows[0]["error"]
    assert run.rows[1]["error"] == "" and run.rows[1]["min_rate_bps_hz"] > 0


def test_failed_trials_are_retried_only_when_asked(tmp_path: Path) -> None:
    bad = TrialSpec(seed=1, scheme="proposed", num_nfzs=10, radius_m=100.0, slots=10)
    run_trials([bad], tmp_path, workers=1, progress=False)
    assert run_trials([bad], tmp_path, workers=1, progress=False).executed == 0
    assert run_trials([bad], tmp_path, workers=1, progress=False, retry_errors=True).executed == 1
