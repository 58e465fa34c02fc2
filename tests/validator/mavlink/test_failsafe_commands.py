"""Failsafe parameters on the wire: upload-mission audits the failsafe paths of --params
before it sends anything, and download-mission fetches the vehicle's parameters to audit."""

from pathlib import Path

from tests.validator.mavlink.conftest import url_of
from validator.autopilot.param_file import read_params
from validator.cli import validate_mission_main
from validator.mavlink.cli import download_mission_main, upload_mission_main
from validator.plan_format import read_plan

DATA = Path(__file__).resolve().parents[2] / "data" / "failsafe"
PLAN, SITE = DATA / "plans/river-ardupilot.plan", DATA / "sites/river.yaml"


def test_upload_refuses_parameters_whose_rtl_crosses_a_zone_before_sending(start_vehicle,
                                                                           capsys):
    vehicle = start_vehicle(read_plan(PLAN))
    args = [str(PLAN), "--connect", url_of(vehicle), "--site", str(SITE), "--params",
            str(DATA / "params/thr-rtl.param")]
    assert upload_mission_main(args) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "FS_THR_ENABLE 1 (Enabled always RTL)" in err
    assert "enters SUBSTATION" in err and "--force uploads it anyway" in err
    assert vehicle.lists().mission == ()  # nothing sent: neither mission nor parameters
    assert vehicle.params["FS_THR_ENABLE"][0] == 1.0
    good = DATA / "params/river-ardupilot-planned.param"
    assert upload_mission_main([*args[:-1], str(good)]) == 0
    assert vehicle.params["FS_THR_ENABLE"][0] == 5.0


def test_download_fetches_the_parameters_and_validate_audits_them(tmp_path, start_vehicle,
                                                                  capsys):
    vehicle = start_vehicle(read_plan(PLAN))
    assert upload_mission_main([str(PLAN), "--connect", url_of(vehicle)]) == 0
    plan_out, params_out = tmp_path / "held.plan", tmp_path / "held.param"
    assert download_mission_main(["--connect", url_of(vehicle), "-o", str(plan_out),
                                  "--params-out", str(params_out)]) == 0
    held = read_params(params_out)
    assert held["FS_THR_ENABLE"] == 1.0 and held["WPNAV_SPEED"] == vehicle.params[
        "WPNAV_SPEED"][0]
    assert len(held) == len(vehicle.params)
    capsys.readouterr()
    # the vehicle's own failsafes (ArduCopter's defaults: RC loss RTL) fail the audit
    assert validate_mission_main([str(plan_out), "--site", str(SITE), "--params",
                                  str(params_out)]) == 1
    assert "FS_THR_ENABLE 1 (Enabled always RTL)" in capsys.readouterr().out
