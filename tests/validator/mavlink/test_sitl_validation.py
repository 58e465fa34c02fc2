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


@pytest.fixture(autouse=True)
def no_autopilot_binary(monkeypatch):
    """These tests fly the built-in vehicle even where an ArduCopter SITL is installed."""
    monkeypatch.delenv("ARDUPILOT_SITL", raising=False)


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
                                    *FAST, "--report", str(out)])
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
                                  "--report", str(out)]) == 1
    report = json.loads(out.read_text())
    assert report["sitl"]["nfz"][0]["clearance_m"] < -10
    assert report["sitl_flight"]["fence_breach_samples"] > 0
    # the report says plainly that it flew our model, not an autopilot
    assert "Flown by the built-in model vehicle (arducopter profile): a model, not an autopilot" \
        in capsys.readouterr().out


def test_external_vehicle_gets_the_explicit_parameters(files, start_vehicle):
    tmp, site, plan_path, plan = files
    vehicle = start_vehicle(plan, speedup=50.0)
    out = tmp / "ext.json"
    status = validate_mission_main([str(plan_path), "--site", str(site), "--connect",
                                    url_of(vehicle), "--param", "WPNAV_ACCEL=400",
                                    "--report", str(out)])
    report = json.loads(out.read_text())
    assert status == 0 and report["sitl_flight"]["builtin"] is False
    assert vehicle.params["WPNAV_ACCEL"][0] == 400.0
    assert report["sitl_flight"]["upload"].startswith("uploaded and verified")


def test_time_limit_cuts_the_flight_with_a_warning(files):
    tmp, site, plan, _ = files
    out = tmp / "cut.json"
    validate_mission_main([str(plan), "--site", str(site), "--sitl", *FAST,
                           "--sitl-time-limit", "5", "--report", str(out)])
    report = json.loads(out.read_text())
    assert report["sitl_flight"]["end"] == "time limit (5 s)"
    assert any("cut at the time limit" in f["message"] for f in report["sitl"]["findings"])


def test_dead_external_vehicle_exits_2_within_the_timeout(files, capsys):
    _, site, plan, _ = files
    status = validate_mission_main([str(plan), "--site", str(site), "--connect",
                                    "udpout:127.0.0.1:9", "--timeout", "1"])
    assert status == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no heartbeat within 1 s" in err


def test_old_sitl_url_spelling_still_works_with_a_deprecation_line(files, capsys):
    _, site, plan, _ = files
    status = validate_mission_main([str(plan), "--site", str(site), "--sitl",
                                    "udpout:127.0.0.1:9", "--timeout", "1"])
    err = capsys.readouterr().err.splitlines()
    assert status == 2
    assert err[0] == "warning: --sitl URL is deprecated; use --connect URL"
    assert "no heartbeat within 1 s" in err[1]


def test_sitl_before_the_plan_path_does_not_swallow_it(files):
    tmp, site, plan, _ = files
    out = tmp / "flag.json"
    assert validate_mission_main(["--sitl", str(plan), "--site", str(site), *FAST,
                                  "--report", str(out)]) == 0
    assert json.loads(out.read_text())["sitl_flight"]["kind"] == "builtin"


@pytest.mark.skipif(shutil.which("plan-mission", path=str(Path(sys.executable).parent)) is None,
                    reason="plan-mission is not installed next to this Python")
def test_sample_plan_flown_on_the_builtin_vehicle_is_clear(tmp_path):
    site = REPO / "samples" / "paper-default.yaml"
    plan = tmp_path / "paper-default.plan"
    subprocess.run([str(Path(sys.executable).parent / "plan-mission"), str(site), "-o",
                    str(plan)], check=True, capture_output=True, timeout=600)
    out = tmp_path / "report.json"
    status = validate_mission_main([str(plan), "--site", str(site), "--sitl", *FAST,
                                    "--report", str(out)])
    report = json.loads(out.read_text())
    assert status == 0, report["violations"]
    assert all(z["clearance_m"] > 0 for z in report["sitl"]["nfz"])
    assert report["sitl_flight"]["end"] == "landed"


def test_the_parameter_file_is_set_on_the_vehicle_and_a_fence_left_off_is_flagged(files, capsys):
    tmp, site, plan, _ = files
    params = tmp / "m.param"
    params.write_text("WPNAV_ACCEL 400\nFENCE_ACTION 1\n")
    out = tmp / "p.json"
    status = validate_mission_main([str(plan), "--site", str(site), "--params", str(params),
                                    "--sitl", *FAST, "--report", str(out), "--force"])
    report = json.loads(out.read_text())
    assert status == 0  # a flag, not a violation: the flight itself was clear
    # the file leaves RC loss and the fence at RTL, straight across a zone: forced, a warning
    assert report["failsafe"]["forced"] and {f["param"] for f in report["failsafe"][
        "findings"]} >= {"FS_THR_ENABLE", "FENCE_ACTION"}
    assert report["sitl_flight"]["params_set"] == {"WPNAV_ACCEL": 400.0, "FENCE_ACTION": 1.0}
    assert report["replay"]["params"]["WPNAV_ACCEL"] == 400.0  # the replay flies the file too
    flagged = [f["message"] for f in report["param_findings"]]
    assert flagged[0].startswith("parameter file: FENCE_ENABLE is not set, not 1")
    assert any("FENCE_ACTION is 1 (RTL or Land)" in m for m in flagged)
    assert any("geofence on the vehicle: FENCE_ACTION is 1" in f["message"]
               for f in report["sitl"]["findings"])
