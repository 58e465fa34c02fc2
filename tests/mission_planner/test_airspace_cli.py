"""plan-mission and validate-mission among UAS zones (samples/airspace.yaml, ED-269): the
report's zone table, the time a plan is made for, and a plan checked for another time."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mission_planner.cli import plan_mission_main
from validator.cli import validate_mission_main

SAMPLE = Path(__file__).parents[2] / "samples" / "airspace.yaml"
WEDNESDAY = "2026-12-02T10:00+01:00"
SATURDAY = "2026-12-05T10:00+01:00"  # the market zone EVNT is active 07:00-18:00


@pytest.fixture(scope="module")
def weekday(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("airspace")
    assert plan_mission_main([str(SAMPLE), "-o", str(out / "m.plan"), "--report",
                              str(out / "r.json"), "--at", WEDNESDAY, "--quiet"]) == 0
    return out


def test_the_report_lists_every_zone_within_reach_taken_or_why_not(weekday: Path) -> None:
    air = json.loads((weekday / "r.json").read_text())["airspace"]
    table = {z["zone"]: (z["taken"], z["why"]) for z in air["zones"]}
    assert {k: v[0] for k, v in table.items()} == {
        "CTR1": True, "HOSP": True, "NATR": True, "HIGH": False, "EVNT": False,
        "PARK": False, "VALY": False}
    assert [table[k][1] for k in ("HIGH", "EVNT", "PARK", "VALY")] == [
        "above the ceiling", "inactive", "no restriction", "below the floor"]
    assert air["at"] == "2026-12-02T10:00:00+01:00" and air["until"] > air["at"]
    assert sorted(air["taken"]) == ["CTR1", "HOSP", "NATR"]


def test_a_plan_checked_for_a_time_another_zone_is_active_is_flagged(weekday: Path,
                                                                      capsys) -> None:
    plan = str(weekday / "m.plan")
    assert validate_mission_main([plan, "--site", str(SAMPLE), "--at", WEDNESDAY]) == 0
    capsys.readouterr()
    assert validate_mission_main([plan, "--site", str(SAMPLE), "--at", SATURDAY]) == 1
    out = capsys.readouterr().out
    assert "zone EVNT (PROHIBITED): taken" in out and "enters EVNT" in out


def test_an_authorisation_frees_its_zone(tmp_path: Path, capsys) -> None:
    assert plan_mission_main([str(SAMPLE), "-o", str(tmp_path / "m.plan"), "--at", SATURDAY,
                              "--authorised", "HOSP", "--authorised", "NATR", "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "zone HOSP (REQ_AUTHORISATION): not taken: authorised" in err
    assert "zone EVNT (PROHIBITED): taken" in err
    assert validate_mission_main([str(tmp_path / "m.plan"), "--site", str(SAMPLE), "--at",
                                  SATURDAY, "--authorised", "HOSP",
                                  "--authorised", "NATR"]) == 0


def test_an_authorisation_for_a_prohibited_zone_is_refused(tmp_path: Path, capsys) -> None:
    assert plan_mission_main([str(SAMPLE), "-o", str(tmp_path / "m.plan"), "--at", WEDNESDAY,
                              "--authorised", "CTR1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "CTR1" in err[0] and "PROHIBITED" in err[0]
    assert not (tmp_path / "m.plan").exists()
