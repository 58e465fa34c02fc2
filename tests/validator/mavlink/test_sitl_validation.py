"""``validate-mission --sitl``: upload, fly and score on the built-in or an external vehicle."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from tests.validator.builders import make_site, waypoint_plan
from tests.validator.mavlink.conftest import url_of
from validator.cli import validate_mission_main
from validator.plan_format import write_plan
from validator.site import site_to_dict

REPO = Path(__file__).resolve().parents[3]
FAST = ["--sitl-speedup", "50"]


@pytest.fixture()
def files(tmp_path):
    site = make_site(nfz=((100.0, 0.0, 20.0),))
    site_path = tmp_path / "site.yaml"
    site_path.write_text(yaml.safe_dump(site_to_dict(site)))
    plan = waypoint_plan(site, [(40.0, 30.0), (160.0, 30.0), (160.0, -40.0)], v=8.0)
    plan_path = tmp_path / "mission.plan"
    write_plan(plan, plan_path)
    return tmp_path, site_path, plan_path, plan


def test_builtin_vehicle_flies_the_plan_clear_of_the_nfz(files):
    tmp, site, plan, _ = files
    out = tmp / "report.json"
    status = validate_mission_main([str(plan), "--site", str(site), "--replay", "--sitl",
                                    *FAST, "--json", str(out)])
    report = json.loads(out.read_text())
    assert status == 0 and report["result"] == "clear"
    flown, modelled = report["sitl"]["nfz"][0], report["replay"]["nfz"][0]
    assert flown["clearance_m"] > 0
    assert flown["clearance_m"] == pytest.approx(modelled["clearance_m"], abs=0.05)
    assert report["sitl_flight"]["end"] == "landed"
    assert report["sitl_flight"]["fence_breach_samples"] == 0


def test_a_track_through_the_nfz_is_a_violation_and_the_fence_reports_it(files, capsys):
    tmp, site_path, _, _ = files
    site = make_site(nfz=((100.0, 0.0, 20.0),))
    bad = tmp / "bad.plan"
    write_plan(waypoint_plan(site, [(40.0, 5.0), (160.0, 5.0)], v=8.0), bad)
    out = tmp / "bad.json"
    assert validate_mission_main([str(bad), "--site", str(site_path), "--sitl", *FAST,
                                  "--json", str(out)]) == 1
    report = json.loads(out.read_text())
    assert report["sitl"]["nfz"][0]["clearance_m"] < -10
    assert report["sitl_flight"]["fence_breach_samples"] > 0
    assert "Flown by a vehicle" in capsys.readouterr().out


def test_external_vehicle_gets_the_explicit_parameters(files, start_vehicle):
    tmp, site, plan_path, plan = files
    vehicle = start_vehicle(plan, speedup=50.0)
    out = tmp / "ext.json"
    status = validate_mission_main([str(plan_path), "--site", str(site), "--sitl",
                                    url_of(vehicle), "--param", "WPNAV_ACCEL=400",
                                    "--json", str(out)])
    report = json.loads(out.read_text())
    assert status == 0 and report["sitl_flight"]["builtin"] is False
    assert vehicle.params["WPNAV_ACCEL"][0] == 400.0
    assert report["sitl_flight"]["upload"].startswith("uploaded and verified")


def test_time_limit_cuts_the_flight_with_a_warning(files):
    tmp, site, plan, _ = files
    out = tmp / "cut.json"
    validate_mission_main([str(plan), "--site", str(site), "--sitl", *FAST,
                           "--sitl-time-limit", "5", "--json", str(out)])
    report = json.loads(out.read_text())
    assert report["sitl_flight"]["end"] == "time limit (5 s)"
    assert any("cut at the time limit" in f["message"] for f in report["sitl"]["findings"])


def test_dead_external_vehicle_exits_2_within_the_timeout(files, capsys):
    _, site, plan, _ = files
    status = validate_mission_main([str(plan), "--site", str(site), "--sitl",
                                    "udpout:127.0.0.1:9", "--sitl-timeout", "1"])
    assert status == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no heartbeat within 1 s" in err


@pytest.mark.skipif(shutil.which("plan-mission", path=str(Path(sys.executable).parent)) is None,
                    reason="plan-mission is not installed next to this Python")
def test_sample_plan_flown_on_the_builtin_vehicle_is_clear(tmp_path):
    site = REPO / "samples" / "paper-default.yaml"
    plan = tmp_path / "paper-default.plan"
    subprocess.run([str(Path(sys.executable).parent / "plan-mission"), str(site), "-o",
                    str(plan)], check=True, capture_output=True, timeout=600)
    out = tmp_path / "report.json"
    status = validate_mission_main([str(plan), "--site", str(site), "--sitl", *FAST,
                                    "--json", str(out)])
    report = json.loads(out.read_text())
    assert status == 0, report["violations"]
    assert all(z["clearance_m"] > 0 for z in report["sitl"]["nfz"])
    assert report["sitl_flight"]["end"] == "landed"
