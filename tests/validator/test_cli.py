import json
import math

import numpy as np
import pytest
import yaml

from tests.validator.builders import make_site, service_plan, waypoint_plan
from validator.autopilot.param_file import read_params
from validator.cli import validate_mission, validate_mission_main
from validator.plan_format import write_plan
from validator.site import site_to_dict


@pytest.fixture()
def files(tmp_path):
    site = make_site()
    site_path = tmp_path / "site.yaml"
    site_path.write_text(yaml.safe_dump(site_to_dict(site)))
    good = tmp_path / "good.plan"
    q = [(0, 60), (60, 60), (60, 100), (0, 60)]
    write_plan(service_plan(site, q, [6.0, 4.0, 8.0], [0.1] * 3, ["GN1", None, "GN2"]), good)
    bad = tmp_path / "bad.plan"
    write_plan(waypoint_plan(site, [(0, -15), (75, -15), (125, -15), (200, -15)], end="none"),
               bad)
    return tmp_path, site_path, good, bad


def test_clear_plan_exits_0_and_prints_the_table(files, capsys):
    _, site, good, _ = files
    assert validate_mission_main([str(good), "--site", str(site)]) == 0
    out = capsys.readouterr().out
    assert "Result: CLEAR" in out and "NFZ1" in out


def test_violating_plan_exits_1_naming_the_leg(files, capsys):
    _, site, _, bad = files
    assert validate_mission_main([str(bad), "--site", str(site)]) == 1
    assert "leg item 4 -> item 5 (waypoint) enters NFZ1 by 5.00 m" in capsys.readouterr().out


def test_json_report_is_written(files):
    tmp, site, good, _ = files
    out = tmp / "report.json"
    status = validate_mission_main([str(good), "--site", str(site), "--replay", "--report",
                                    str(out)])
    assert status == 0
    data = json.loads(out.read_text())
    assert data["result"] == "clear" and data["exit_status"] == 0
    assert data["replay"]["profile"] == "arducopter"
    assert data["replay"]["throughput"]["per_gn"][0]["gn"] == "GN1"
    assert data["audit"]["nfz"][0]["nfz"] == "NFZ1"


@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda p: p.write_text("{not json"), "not valid JSON"),
        (lambda p: p.write_text('{"fileType": "Plan"}'), "mission: missing field"),
    ],
)
def test_bad_plan_exits_2_with_one_line_and_no_output(files, capsys, mutate, message):
    tmp, site, good, _ = files
    mutate(good)
    out = tmp / "report.json"
    assert validate_mission_main([str(good), "--site", str(site), "--report", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not out.exists()


def test_bad_site_exits_2(files, capsys):
    tmp, site, good, _ = files
    site.write_text("name: x\norigin: {lat: 1, lon: 2}\n")
    assert validate_mission_main([str(good), "--site", str(site)]) == 2
    assert "uav: missing field" in capsys.readouterr().err


def test_bad_param_exits_2(files, capsys):
    _, site, good, _ = files
    assert validate_mission_main([str(good), "--site", str(site), "--param", "WPNAV_X=1"]) == 2
    assert "--param WPNAV_X: unknown parameter" in capsys.readouterr().err


def test_slower_than_20_hz_is_refused(files, capsys):
    _, site, good, _ = files
    assert validate_mission_main([str(good), "--site", str(site), "--replay", "--dt",
                                  "0.1"]) == 2
    assert "--dt" in capsys.readouterr().err


def test_a_step_finer_than_100_hz_is_refused(files, capsys):
    _, site, good, _ = files
    assert validate_mission_main([str(good), "--site", str(site), "--replay", "--dt",
                                  "1e-9"]) == 2
    assert "--dt: must be >= 0.01 s" in capsys.readouterr().err


def test_an_at_with_no_day_left_in_the_calendar_is_refused(files, capsys):
    _, site, good, _ = files
    assert validate_mission_main([str(good), "--site", str(site), "--at",
                                  "9999-12-31T23:59+00:00"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--at: '9999-12-31T23:59+00:00' is outside" in err


def test_a_param_acceleration_near_zero_is_refused(files, capsys):
    _, site, good, _ = files
    assert validate_mission_main([str(good), "--site", str(site), "--param",
                                  "WPNAV_ACCEL=1e-9"]) == 2
    assert "--param WPNAV_ACCEL: 1e-09 cm/s/s is below 10" in capsys.readouterr().err


def test_a_parameter_files_acceleration_near_zero_is_refused_naming_the_file_and_line(
        files, capsys):
    tmp, site, good, _ = files
    params = tmp / "mission.param"
    params.write_text("# what the vehicle holds\nWPNAV_SPEED 500\nWPNAV_ACCEL 1e-9\n")
    assert validate_mission_main([str(good), "--site", str(site), "--params", str(params)]) == 2
    assert capsys.readouterr().err == (f"validate-mission: {params}:3: WPNAV_ACCEL: 1e-09 cm/s/s "
                                       "is below 10, the least acceleration or jerk the replay "
                                       "flies\n")


def test_a_parameter_files_speed_of_0_is_refused_naming_the_file_and_line(files, capsys):
    tmp, site, good, _ = files
    params = tmp / "mission.param"
    params.write_text("WPNAV_SPEED 0\n")
    assert validate_mission_main([str(good), "--site", str(site), "--params", str(params)]) == 2
    assert capsys.readouterr().err == (f"validate-mission: {params}:1: WPNAV_SPEED: must be a "
                                       "number > 0, got 0.0\n")


def test_a_bad_param_flag_over_a_good_file_value_names_the_flag(files, capsys):
    tmp, site, good, _ = files
    params = tmp / "mission.param"
    params.write_text("WPNAV_ACCEL 250\n")
    assert validate_mission_main([str(good), "--site", str(site), "--params", str(params),
                                  "--param", "WPNAV_ACCEL=1e-9"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("validate-mission: --param WPNAV_ACCEL: 1e-09 cm/s/s is below 10")


def test_a_good_param_flag_over_a_bad_file_value_is_flown(files):
    tmp, site, good, _ = files
    params = tmp / "mission.param"
    params.write_text("WPNAV_ACCEL 1e-9\n")
    v = validate_mission(good, site, params={"WPNAV_ACCEL": 250.0},
                         vehicle_params=read_params(params))
    assert v.profile is not None and v.profile.params["WPNAV_ACCEL"] == 250.0


def test_param_implies_replay_and_follows_the_plan_firmware(files):
    _, site, good, _ = files
    v = validate_mission(good, site, params={"WPNAV_ACCEL": 500.0})
    assert v.replay is not None and v.profile is not None
    assert v.profile.name == "arducopter" and v.profile.params["WPNAV_ACCEL"] == 500.0


def test_replay_violation_alone_makes_exit_1(tmp_path, capsys):
    site = make_site(nfz=((100.0, 0.0, 20.0),), buffer_m=0.0)
    site_path = tmp_path / "site.yaml"
    site_path.write_text(yaml.safe_dump(site_to_dict(site)))
    a = math.asin(20.05 / 20.6)
    v = np.array([100.0, -20.6])
    pts = [v + 60.0 * np.array([-math.sin(a), math.cos(a)]), v,
           v + 60.0 * np.array([math.sin(a), math.cos(a)])]
    plan = tmp_path / "corner.plan"
    write_plan(waypoint_plan(site, pts, v=8.0, end="none"), plan)
    assert validate_mission_main([str(plan), "--site", str(site_path)]) == 0
    capsys.readouterr()
    assert validate_mission_main([str(plan), "--site", str(site_path), "--replay"]) == 1
    assert "flown track enters NFZ1" in capsys.readouterr().out


def test_the_old_json_option_still_writes_the_report_with_a_deprecation_line(tmp_path, capsys):
    site = make_site(nfz=((100.0, 0.0, 20.0),))
    site_path = tmp_path / "site.yaml"
    site_path.write_text(yaml.safe_dump(site_to_dict(site)))
    plan_path = tmp_path / "m.plan"
    write_plan(waypoint_plan(site, [(40.0, 30.0), (160.0, 30.0)]), plan_path)
    out = tmp_path / "r.json"
    status = validate_mission_main([str(plan_path), "--site", str(site_path), "--json",
                                    str(out)])
    assert json.loads(out.read_text())["exit_status"] == status
    assert capsys.readouterr().err == "warning: --json is deprecated; use --report\n"


@pytest.mark.parametrize("clearance, says", [
    ({"NFZ1": 32.77, "NFZ2": 80.1}, "  closest to a zone: NFZ1, 32.77 m"),
    ({"NFZ1": -1.5, "NFZ2": 80.1}, "  entered NFZ1 1.50 m deep"),
])
def test_the_report_says_what_a_fault_flight_did(files, clearance, says):
    """validate-mission --fault printed nothing of the flight after the fault (only its
    violations, and only in the findings): what was injected, what the autopilot flew, how it
    ended and how close it came to a zone were in the JSON report alone."""
    from validator.cli import format_report
    from validator.mavlink.faults import FaultReport

    _, site, good, _ = files
    v = validate_mission(good, site)
    v.extra["fault"] = FaultReport(
        "rc-loss", "SIM_RC_FAIL 1", "simulator truth (SIMSTATE)", 164.0, (186.6, 326.7),
        (191.3, 322.2), clearance, "landed", (480.0, 350.0), 0.04, ("SMART_RTL",),
        ("Radio Failsafe",)).as_dict()
    text = format_report(v).splitlines()
    at = text.index("Fault: rc-loss, the flight after it (from simulator truth (SIMSTATE))")
    assert text[at + 1:at + 5] == ["  rc-loss injected (SIM_RC_FAIL 1) at t = 164.0 s",
                                   "  then flew SMART_RTL", "  ended landed, 0.0 m from home",
                                   says]


def test_report_onto_the_plan_is_refused_and_the_plan_kept(files, capsys):
    _, site, good, _ = files
    before = good.read_bytes()
    assert validate_mission_main([str(good), "--site", str(site), "--report", str(good)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is an input of this command (the plan)" in err
    assert good.read_bytes() == before


def test_report_onto_the_params_file_is_refused(files, capsys):
    tmp, site, good, _ = files
    params = tmp / "v.param"
    params.write_text("WPNAV_SPEED 500\n")
    assert validate_mission_main([str(good), "--site", str(site), "--params", str(params),
                                  "--report", str(params)]) == 2
    assert "is an input of this command (the --params file)" in capsys.readouterr().err
    assert params.read_text() == "WPNAV_SPEED 500\n"


def test_report_and_html_on_one_path_are_refused(files, capsys):
    tmp, site, good, _ = files
    out = tmp / "v.json"
    assert validate_mission_main([str(good), "--site", str(site), "--report", str(out),
                                  "--html", str(out)]) == 2
    assert "named for two outputs" in capsys.readouterr().err
    assert not out.exists()


def test_report_to_a_folder_names_the_folder_not_a_temporary(files, capsys):
    tmp, site, good, _ = files
    folder = tmp / "out"
    folder.mkdir()
    assert validate_mission_main([str(good), "--site", str(site), "--report", str(folder)]) == 2
    err = capsys.readouterr().err
    assert err == f"validate-mission: {folder}: is a folder\n"


def test_empty_report_path_is_refused(files, capsys):
    _, site, good, _ = files
    assert validate_mission_main([str(good), "--site", str(site), "--report", ""]) == 2
    assert "--report: empty path" in capsys.readouterr().err
