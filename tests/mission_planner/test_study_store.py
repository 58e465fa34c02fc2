"""The study directory: trial log, manifest and table files."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import pytest

from mission_planner.study.store import (
    LOG_NAME,
    MANIFEST_NAME,
    TrialLog,
    check_manifest,
    check_table_format,
    read_log,
    table_csv,
    write_table,
)
from validator.errors import InputError


def _row(key: str, **extra: object) -> dict[str, object]:
    return {"key": key, "seed": 1, "min_rate_bps_hz": 0.1, **extra}


def test_log_reads_back_what_was_appended(tmp_path: Path) -> None:
    with TrialLog(tmp_path) as log:
        log.append(_row("a"))
        log.append(_row("b", error="boom"))
    assert read_log(tmp_path) == {"a": _row("a"), "b": _row("b", error="boom")}


def test_log_writes_nothing_before_the_first_row(tmp_path: Path) -> None:
    with TrialLog(tmp_path / "study", {"x": 1}):
        pass
    assert not (tmp_path / "study").exists()


def test_torn_last_line_is_ignored_and_the_next_row_starts_clean(tmp_path: Path) -> None:
    with TrialLog(tmp_path) as log:
        log.append(_row("a"))
    with (tmp_path / LOG_NAME).open("a") as f:
        f.write('{"key": "b", "seed"')  # killed mid-write
    assert set(read_log(tmp_path)) == {"a"}
    with TrialLog(tmp_path) as log:
        log.append(_row("c"))
    assert set(read_log(tmp_path)) == {"a", "c"}


def test_manifest_is_written_with_the_first_row(tmp_path: Path) -> None:
    with TrialLog(tmp_path, {"planner_options": {"max_iterations": 5}}) as log:
        log.append(_row("a"))
    recorded = json.loads((tmp_path / MANIFEST_NAME).read_text())
    assert recorded == {"planner_options": {"max_iterations": 5}}


def test_resuming_with_other_settings_is_refused(tmp_path: Path) -> None:
    with TrialLog(tmp_path, {"planner_options": {"max_iterations": 5}}) as log:
        log.append(_row("a"))
    check_manifest(tmp_path, {"planner_options": {"max_iterations": 5}})
    with pytest.raises(InputError, match="planner_options"):
        check_manifest(tmp_path, {"planner_options": {"max_iterations": 6}})


def test_csv_keeps_floats_exact_and_none_empty() -> None:
    value = 0.1 + 0.2
    text = table_csv([{"key": "a", "x": value, "y": None, "z": float("inf")}],
                     ("key", "x", "y", "z"))
    (row,) = list(csv.DictReader(io.StringIO(text)))
    assert float(row["x"]) == value
    assert row["y"] == ""
    assert float(row["z"]) == float("inf")


def test_unknown_table_format_is_refused() -> None:
    with pytest.raises(InputError, match="--format"):
        check_table_format("xlsx")


def test_parquet_without_pyarrow_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(__import__("sys").modules, "pyarrow", None)
    with pytest.raises(InputError, match="pyarrow"):
        check_table_format("parquet")


def test_parquet_table_reads_back(tmp_path: Path) -> None:
    pq = pytest.importorskip("pyarrow.parquet")
    rows = [_row("a", error=""), _row("b", error="boom")]
    path = write_table(rows, tmp_path / "t.parquet", "parquet", ("key", "seed", "error"))
    assert pq.read_table(path).to_pylist() == [
        {"key": "a", "seed": 1, "error": ""}, {"key": "b", "seed": 1, "error": "boom"}
    ]
