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


def test_the_reports_window_covers_the_replayed_mission(weekday: Path) -> None:
    """The window the zones were decided for runs at least as long as the mission flies: it
    had named the first estimate (454 s) where plan-mission settled on a longer window taking
    the same zones (535 s) for a mission replayed in 486 s."""
    from datetime import datetime

    report = json.loads((weekday / "r.json").read_text())
    air = report["airspace"]
    window_s = (datetime.fromisoformat(air["until"]) - datetime.fromisoformat(air["at"]))
    assert window_s.total_seconds() >= report["flight"]["replayed_mission_s"]


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


def test_a_leg_beyond_the_area_zones_were_looked_for_is_a_violation(weekday: Path) -> None:
    from dataclasses import replace

    import shapely

    from validator.audit import audit
    from validator.plan_format import read_plan
    from validator.site import load_site
    from validator.uas_zones.applicability import AirspaceOptions, parse_at

    site = load_site(SAMPLE, AirspaceOptions(parse_at(WEDNESDAY), 600.0))
    plan = read_plan(weekday / "m.plan")
    assert not [f for f in audit(plan, site).findings if "looked for" in f.message]
    small = replace(site, airspace=replace(site.airspace, reach_m=shapely.box(-50, -50, 50, 50)))
    found = [f for f in audit(plan, small).violations if "looked for" in f.message]
    assert len(found) == 1


def test_the_band_takes_the_buffer_plan_mission_is_given() -> None:
    from mission_planner.airspace_time import plan_for_time
    from validator.site import load_site
    from validator.uas_zones.applicability import AirspaceOptions, parse_at

    # HIGH starts 200 m AGL: a 160 m buffer over the 40 m altitude reaches it
    high = AirspaceOptions(parse_at(WEDNESDAY), 600.0, buffer_m=160.0)
    def taken(options: AirspaceOptions) -> bool:
        return next(d.taken for d in load_site(SAMPLE, options).airspace.table
                    if d.zone.identifier == "HIGH")

    assert taken(high) and not taken(AirspaceOptions(parse_at(WEDNESDAY)))
    assert "HOSP+HIGH" in load_site(SAMPLE, high).zone_names  # they overlap: merged
    # plan_for_time hands plan-mission's --buffer-m to the band (a 5 m buffer: 45 m band)
    site, planned = plan_for_time(SAMPLE, AirspaceOptions(parse_at(WEDNESDAY)), 1,
                                  lambda s: s.buffer_m, lambda _: 0.0, buffer_m=5.0)
    assert planned == 5.0 and site.airspace.options.buffer_m == 5.0


@pytest.fixture()
def airfield(tmp_path: Path) -> Path:
    """samples/airfield.yaml and the airspace file it names, in a folder of their own."""
    for name in ("airfield.yaml", "airfield-airspace.geojson"):
        (tmp_path / name).write_bytes((SAMPLE.parent / name).read_bytes())
    return tmp_path


def test_plan_mission_refuses_to_write_over_the_site_s_airspace_file(airfield: Path,
                                                                      capsys) -> None:
    zones = airfield / "airfield-airspace.geojson"
    before = zones.read_bytes()
    assert plan_mission_main([str(airfield / "airfield.yaml"), "-o", str(airfield / "m.plan"),
                              "--geojson", str(zones)]) == 2
    assert capsys.readouterr().err == (f"plan-mission: {zones}: is an input of this command "
                                       "(the site's airspace file)\n")
    assert zones.read_bytes() == before and not (airfield / "m.plan").exists()


def test_validate_mission_refuses_to_report_over_the_site_s_airspace_file(airfield: Path,
                                                                           capsys) -> None:
    zones = airfield / "airfield-airspace.geojson"
    before = zones.read_bytes()
    assert validate_mission_main([str(airfield / "m.plan"), "--site",
                                  str(airfield / "airfield.yaml"), "--report", str(zones)]) == 2
    assert capsys.readouterr().err == (f"validate-mission: {zones}: is an input of this "
                                       "command (the site's airspace file)\n")
    assert zones.read_bytes() == before
