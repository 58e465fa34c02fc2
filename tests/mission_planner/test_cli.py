"""plan-mission end to end with the real optimiser on small sites (N = 12), plus its errors."""

from __future__ import annotations

import copy
import io
import json
import math
import os
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

import mission_planner.optimize
from mission_planner.cli import plan_mission_main
from mission_planner.mission import flown_legs, planned_cycle_s
from mission_planner.progress import PlanProgress
from tests.mission_planner.mavsdk_peer import mavsdk_import
from tests.mission_planner.solutions import (
    NUDGED_LEG_SLACK_M,
    circle_points,
    site_dict,
    solution_for,
    subdivided,
)
from tests.view_figure import layer, page_figure
from validator.audit import audit
from validator.autopilot.failsafe import FAILSAFE_PARAMS, recommended_failsafes
from validator.autopilot.param_file import parse_params
from validator.flight import resolve_flight
from validator.geometry import segment_point_distance
from validator.motion.speed_model import top_speed_mps
from validator.plan_format import Autopilot, Cmd, read_plan
from validator.site import load_site
from validator.waypoints_format import read_waypoints

SAMPLES = Path(__file__).resolve().parents[2] / "samples"
SMALL = site_dict(
    name="small",
    uav={"altitude": 30.0, "max_speed": 30.0, "period": 16.0, "slots": 12},
    ground_nodes=[{"name": "GN1", "x": 60.0, "y": 140.0}, {"name": "GN2", "x": 160.0, "y": 150.0}],
    no_fly_zones=[{"name": "NFZ1", "x": 110.0, "y": 150.0, "radius": 20.0}],
)
# Home sits west of an NFZ that stands between it and the GNs: the transit must bend.
BEHIND = site_dict(
    name="behind",
    uav={"altitude": 30.0, "max_speed": 20.0, "period": 20.0, "slots": 12},
    ground_nodes=[{"name": "GN1", "x": 160.0, "y": 15.0}, {"name": "GN2", "x": 165.0, "y": -20.0}],
    no_fly_zones=[{"name": "WALL", "x": 60.0, "y": 0.0, "radius": 25.0}],
)


def _write_site(tmp_path, data, name="site.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def _run(argv, capsys):
    code = plan_mission_main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.err


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    """One default run of the small site: (site path, plan path, report path, stderr,
    stdout)."""
    tmp = tmp_path_factory.mktemp("small")
    site = _write_site(tmp, SMALL)
    out, report = tmp / "m.plan", tmp / "m.report.json"
    proc = subprocess.run([sys.executable, "-m", "mission_planner.cli", str(site), "-o", str(out),
                           "--report", str(report), "--cycles", "2", "--dynamics", "none"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return site, out, report, proc.stderr, proc.stdout


def test_writes_a_plan_mavsdk_imports(small_run):
    site_path, out, _, _, _ = small_run
    plan = read_plan(out)
    data = mavsdk_import(out, int(Autopilot.ARDUPILOTMEGA))
    assert len(data.mission_items) == len(plan.items) + 1  # + ArduPilot's home at seq 0
    assert len(data.geofence_items) == 1 and len(data.rally_items) == 1
    assert plan.firmware_type == Autopilot.ARDUPILOTMEGA and plan.vehicle_type == 2


def test_no_progress_when_stderr_is_not_a_terminal_and_the_result_is_on_stdout(small_run):
    stderr, stdout = small_run[3], small_run[4]
    assert "iteration" not in stderr and "candidate" not in stderr
    assert "plan-mission: wrote" in stdout and "wrote" not in stderr


def test_report_is_the_solution_report_plus_the_mission_summary(small_run):
    _, out, report_path, _, _ = small_run
    report = json.loads(report_path.read_text())
    assert report["scheme"] == "proposed" and report["min_rate_bps_hz"] > 0
    mission = report["mission"]
    plan = read_plan(out)
    assert mission["items"] == len(plan.items)
    assert mission["cycles"] == 2
    assert mission["fence_radii_m"] == {"NFZ1": 21.0}
    assert mission["expanded_radius_max_m"] >= 22.0
    assert mission["cycle_duration_s"] == pytest.approx(16.0, abs=0.5)
    assert mission["transit_out_m"] > 0 and mission["problems"] == []


def test_planned_leg_times_sum_to_t_and_speeds_stay_within_v(small_run):
    site_path, out, _, _, _ = small_run
    site = load_site(site_path)
    plan = read_plan(out)
    assert planned_cycle_s(plan, site) == pytest.approx(site.period_s, abs=0.5)
    speeds = [it.params[1] for it in plan.items if it.command == Cmd.DO_CHANGE_SPEED]
    assert speeds and max(speeds) <= site.max_speed_mps


def test_geometry_reread_from_the_file_clears_every_nfz(small_run):
    site_path, out, _, _, _ = small_run
    site = load_site(site_path)
    plan = read_plan(out)
    legs = flown_legs(plan, site)
    d = segment_point_distance(legs[:, None, 0], legs[:, None, 1], site.nfz_xy_m[None])
    assert np.all(d >= site.planning_radius_m - NUDGED_LEG_SLACK_M)
    assert audit(plan, site).ok


def test_home_behind_an_nfz_gets_a_bent_transit(tmp_path, capsys):
    site_path = _write_site(tmp_path, BEHIND)
    out, report = tmp_path / "m.plan", tmp_path / "r.json"
    code, err = _run([site_path, "-o", out, "--report", report, "--dynamics", "none"], capsys)
    assert code == 0, err
    site = load_site(site_path)
    summary = json.loads(report.read_text())["mission"]
    assert summary["transit_out_waypoints"] >= 2 and summary["transit_return_waypoints"] >= 2
    plan = read_plan(out)
    first = plan.extra["cycle_items"][0]
    legs = flown_legs(plan, site)
    d = segment_point_distance(legs[:, 0], legs[:, 1], site.nfz_xy_m[0])
    assert np.min(d) >= site.planning_radius_m[0] - NUDGED_LEG_SLACK_M
    # the straight line home -> q[0] would have crossed the zone
    q0 = np.array(plan.extra["trajectory_m"][0])
    assert segment_point_distance(site.home_xy_m, q0, site.nfz_xy_m[0]) < site.nfz_radius_m[0]
    assert first > 3  # takeoff, speed, at least two transit waypoints


def test_waypoints_geojson_plot_and_px4(tmp_path, capsys):
    site_path = _write_site(tmp_path, SMALL)
    out = tmp_path / "m.waypoints"
    gj, png = tmp_path / "m.geojson", tmp_path / "m.png"
    code, err = _run([site_path, "-o", out, "--autopilot", "px4", "--operating-area", "polygon",
                      "--geojson", gj, "--plot", png, "--fence-margin-m", "0.5",
                      "--dynamics", "none"], capsys)
    assert code == 0, err
    plan = read_waypoints(out)
    assert plan.items[0].command == Cmd.NAV_TAKEOFF and plan.items[-1].command == Cmd.NAV_LAND
    assert [c.radius_m for c in plan.circles] == [20.5]
    assert len(plan.polygons) == 1 and len(plan.rally) == 1
    assert (tmp_path / "m.fence.waypoints").exists() and (tmp_path / "m.rally.waypoints").exists()
    kinds = {f["properties"]["kind"] for f in json.loads(gj.read_text())["features"]}
    assert {"flown_path", "service_trajectory", "nfz", "fence_exclusion",
            "fence_inclusion"} <= kinds
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000


@pytest.mark.parametrize("change, args, message", [
    ({"uav": {"altitude": 30}}, [], "uav.max_speed: missing field"),
    ({"colour": "red"}, [], "colour: unknown key"),
    ({}, ["--buffer-m", "-1"], "buffer_m: must be >= 0"),
    ({}, ["--cycles", "0"], "cycles: must be >= 1"),
    ({}, ["--fence-margin-m", "5"], "larger than the planned clearance"),
    ({"uav": {**SMALL["uav"], "period": 0.99}}, [], "uav.period: 0.99 s is shorter than the 1 s"),
    ({}, ["--buffer-m", "nan"], "buffer_m: must be >= 0 and <= 1e+06 m, got nan"),
    ({}, ["--at", "9999-12-31T23:59+00:00"], "--at: '9999-12-31T23:59+00:00' is outside"),
    ({}, ["--fence-margin-m", "nan"], "fence_margin_m: must be >= 0, got nan"),
    ({}, ["--operating-area", "circle", "--operating-area-margin-m", "1e9"],
     "operating_area_margin_m: must be > 0 and <= 100000 m"),
    ({"uav": {**SMALL["uav"], "max_jerk": 1e-12}}, [], "uav.max_jerk: Input should be greater"),
    ({"uav": {**SMALL["uav"], "max_accel": 1e-12}}, [], "uav.max_accel: Input should be greater"),
])
def test_bad_input_is_one_line_exit_2_and_no_file(tmp_path, capsys, change, args, message):
    site_path = _write_site(tmp_path, {**SMALL, **change})
    out = tmp_path / "m.plan"
    code, err = _run([site_path, "-o", out, "--report", tmp_path / "r.json", *args], capsys)
    assert code == 2
    assert message in err and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["site.yaml"]


def test_malformed_yaml_and_missing_folder_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed\n")
    assert _run([bad, "-o", tmp_path / "m.plan"], capsys)[0] == 2
    good = _write_site(tmp_path, SMALL)
    code, err = _run([good, "-o", tmp_path / "nowhere" / "m.plan"], capsys)
    assert code == 2 and "does not exist" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.yaml", "site.yaml"]


def test_unknown_option_is_one_line_exit_2(tmp_path, capsys):
    assert plan_mission_main([str(tmp_path / "s.yaml"), "-o", "x.plan", "--scheme", "fast"]) == 2
    assert capsys.readouterr().err.count("\n") == 1


@pytest.fixture()
def unsafe_planner(monkeypatch):
    """plan() replaced by a tour whose legs cut through NFZ1 (a conventional-scheme failure)."""
    def fake_plan(site, scheme="proposed", *, options=None, progress=None):
        # Corners 25 m from NFZ1's centre (outside R = 20), sides 17.7 m from it: inside.
        corners = circle_points((110.0, 150.0), 25.0, 4, phase_rad=np.pi / 4)
        q = corners[[0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 0, 0, 0]]
        if progress:
            progress(1, 1.0)
        return solution_for(site, q, scheme=scheme)

    monkeypatch.setattr(mission_planner.optimize, "plan", fake_plan)


def test_safety_gate_refuses_an_unsafe_mission(tmp_path, capsys, unsafe_planner):
    site_path = _write_site(tmp_path, SMALL)
    code, err = _run([site_path, "-o", tmp_path / "m.plan", "--report", tmp_path / "r.json",
                      "--scheme", "conventional"], capsys)
    assert code == 1
    assert "NFZ1" in err and "refused to write" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["site.yaml"]


def test_force_writes_the_unsafe_mission_anyway(tmp_path, capsys, unsafe_planner):
    site_path = _write_site(tmp_path, SMALL)
    out = tmp_path / "m.plan"
    code, err = _run([site_path, "-o", out, "--force"], capsys)
    assert code == 0 and "--force" in err
    assert not audit(read_plan(out), load_site(site_path)).ok


# ---------------------------------------------------------------------------- issue 7

SLOW = site_dict(name="slow", uav={"altitude": 30.0, "max_speed": 10.0, "period": 180.0,
                                   "slots": 12})
SQUARE = [(150.0, 150.0), (250.0, 150.0), (250.0, 250.0), (150.0, 250.0)]


@pytest.fixture()
def square_planner(monkeypatch):
    """plan() replaced by a square tour (3 slots per side); records the options it got."""
    seen = []

    def fake_plan(site, scheme="proposed", *, options=None, progress=None):
        seen.append(options)
        return solution_for(site, subdivided(SQUARE, 3), scheme=scheme)

    monkeypatch.setattr(mission_planner.optimize, "plan", fake_plan)
    return seen


@pytest.mark.parametrize("args, dynamics", [([], "vehicle"), (["--dynamics", "none"], "none"),
                                            (["--dynamics", "vehicle"], "vehicle")])
def test_dynamics_reaches_the_planner_vehicle_by_default(tmp_path, capsys, square_planner,
                                                         args, dynamics):
    code, err = _run([_write_site(tmp_path, SLOW), "-o", tmp_path / "m.plan", *args], capsys)
    assert code == 0, err
    assert [o.dynamics for o in square_planner] == [dynamics]


def test_a_mission_longer_than_the_endurance_is_refused(tmp_path, capsys, square_planner):
    slow = copy.deepcopy(SLOW)
    slow["uav"]["endurance"] = 120.0  # a 180 s cycle cannot fit
    code, err = _run([_write_site(tmp_path, slow), "-o", tmp_path / "m.plan"], capsys)
    assert code == 1
    assert "beyond the UAV's endurance of 120 s (uav.endurance)" in err, err
    assert "refused to write" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["site.yaml"]


def test_the_result_line_holds_the_flight_against_the_endurance(tmp_path, capsys,
                                                                square_planner):
    slow = copy.deepcopy(SLOW)
    slow["uav"]["endurance"] = 3600.0
    assert plan_mission_main([str(_write_site(tmp_path, slow)), "-o",
                              str(tmp_path / "m.plan")]) == 0
    assert " s of the 3600 s endurance, " in capsys.readouterr().out
    assert plan_mission_main([str(_write_site(tmp_path, SLOW, "plain.yaml")), "-o",
                              str(tmp_path / "p.plan")]) == 0
    assert "endurance" not in capsys.readouterr().out


@pytest.mark.parametrize("args, through", [([], True), (["--stop-at-every-waypoint"], False)])
def test_corners_are_flown_through_unless_told_to_stop(tmp_path, capsys, square_planner, args,
                                                       through):
    code, err = _run([_write_site(tmp_path, SLOW), "-o", tmp_path / "m.plan", *args], capsys)
    assert code == 0, err
    assert [o.pass_through_corners for o in square_planner] == [through]
    # the planner gets the waypoint radius the .param sets, to time the corners with
    assert "WPNAV_RADIUS" in square_planner[0].timing_params


def test_help_says_dynamics_none_reproduces_the_paper(capsys):
    assert plan_mission_main(["--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "--dynamics {vehicle,none}" in text and "reproduces the paper" in text


def test_param_file_is_written_beside_the_mission(tmp_path, capsys, square_planner):
    code, err = _run([_write_site(tmp_path, SLOW), "-o", tmp_path / "m.plan"], capsys)
    assert code == 0, err
    params = parse_params((tmp_path / "m.param").read_text())
    assert params == {"WPNAV_SPEED": 1000.0, "WPNAV_ACCEL": 250.0, "WPNAV_JERK": 1.0,
                      "WP_YAW_BEHAVIOR": 2.0, "WPNAV_RADIUS": 100.0,
                      **recommended_failsafes("ardupilot", 300.0),
                      "FENCE_TYPE": 4.0, "FENCE_ACTION": 5.0, "FENCE_ENABLE": 1.0}
    assert list(params)[-1] == "FENCE_ENABLE"  # switched on after the rest is set


def test_params_option_names_the_file_px4_gets_px4_names(tmp_path, capsys, square_planner):
    out, pfile = tmp_path / "m.plan", tmp_path / "vehicle.params"
    code, err = _run([_write_site(tmp_path, SLOW), "-o", out, "--params-out", pfile,
                      "--autopilot", "px4"], capsys)
    assert code == 0, err
    assert not (tmp_path / "m.param").exists()
    assert set(parse_params(pfile.read_text())) == {*recommended_failsafes("px4"),
                                                    "MPC_XY_CRUISE", "MPC_XY_VEL_MAX",
                                                    "MPC_ACC_HOR", "MPC_JERK_AUTO", "NAV_ACC_RAD",
                                                    "GF_ACTION"}


def test_params_file_colliding_with_the_mission_is_refused(tmp_path, capsys, square_planner):
    out = tmp_path / "m.plan"
    code, err = _run([_write_site(tmp_path, SLOW), "-o", out, "--params-out", out], capsys)
    assert code == 2 and "named for two outputs" in err and err.count("\n") == 1
    assert not out.exists()


def test_report_has_the_replayed_flight_and_no_warning_when_on_time(tmp_path, capsys,
                                                                    square_planner):
    report = tmp_path / "r.json"
    code, err = _run([_write_site(tmp_path, SLOW), "-o", tmp_path / "m.plan", "--report",
                      report], capsys)
    assert code == 0, err
    data = json.loads(report.read_text())
    flight = data["flight"]
    assert flight["profile"] == "arducopter" and flight["params"]["WPNAV_RADIUS"] == 100.0
    assert flight["replayed_cycle_s"] == pytest.approx(180.0, rel=0.02)
    assert flight["replayed_min_rate_bps_hz"] > 0 and flight["warning"] is None
    motion = {k: v for k, v in data["autopilot_params"]["values"].items()
              if not k.startswith("FENCE_") and k not in FAILSAFE_PARAMS["ardupilot"]}
    assert motion == flight["params"]
    assert data["mission"]["service_waypoints_merged"] == 8
    assert "warning" not in err


def test_a_late_cycle_is_one_warning_line_on_stderr(tmp_path, capsys, square_planner):
    hurried = {**SLOW, "uav": {**SLOW["uav"], "period": 50.0}}
    code, err = _run([_write_site(tmp_path, hurried), "-o", tmp_path / "m.plan"], capsys)
    assert code == 0, err
    warnings = [ln for ln in err.splitlines() if "warning" in ln]
    assert len(warnings) == 1
    assert warnings[0].startswith("plan-mission: warning: the arducopter replay flies the cycle")


def test_no_merge_keeps_a_waypoint_per_slot(tmp_path, capsys, square_planner):
    site = _write_site(tmp_path, SLOW)
    code, _ = _run([site, "-o", tmp_path / "a.plan"], capsys)
    code2, _ = _run([site, "-o", tmp_path / "b.plan", "--no-merge"], capsys)
    assert code == code2 == 0
    merged, per_slot = (len(read_plan(tmp_path / n).items) for n in ("a.plan", "b.plan"))
    assert per_slot == merged + 8


@pytest.fixture()
def chatty_planner(monkeypatch):
    """plan() replaced by a square tour that reports 25 iterations of progress."""

    def fake_plan(site, scheme="proposed", *, options=None, progress=None):
        for i in range(1, 26):
            if progress is not None:
                progress(i, 1.0 + i / 100)
        return solution_for(site, subdivided(SQUARE, 3), scheme=scheme)

    monkeypatch.setattr(mission_planner.optimize, "plan", fake_plan)


def test_progress_names_the_candidate_its_iterations_belong_to():
    out = io.StringIO()
    with PlanProgress(enabled=True, file=out) as progress:
        progress.candidate(1, 8, 10.0)
        progress(15, 1.5)
        progress.candidate(2, 8, 8.25)
        progress(3, 1.25)
    shown = out.getvalue()
    assert "plan-mission: candidate 1 of at most 8 (top speed 10.00 m/s), iteration 15, " \
           "objective 1.5" in shown
    assert "candidate 2 of at most 8 (top speed 8.25 m/s), iteration 3, objective 1.25" in shown
    assert shown.count("\n") <= 1  # one line, rewritten in place


def test_the_vehicle_search_reports_each_candidate():
    from mission_planner.optimize import PlannerOptions, plan

    seen: list[tuple[str, float]] = []

    class Recorder:
        def __call__(self, iteration: int, objective: float) -> None:
            seen.append(("iteration", iteration))

        def candidate(self, number: int, most: int, speed_mps: float) -> None:
            assert most == 8 and speed_mps > 0
            seen.append(("candidate", number))

    sol = plan(load_site(SAMPLES / "realistic.yaml"), options=PlannerOptions(
        max_iterations=2, search_ahead=False), progress=Recorder())
    candidates = [n for what, n in seen if what == "candidate"]
    assert sol.timing is not None
    assert candidates == list(range(1, sol.timing.speeds_tried + 1))
    assert seen[0] == ("candidate", 1) and ("iteration", 1) in seen


@pytest.mark.parametrize("flag", ["--quiet", "--no-progress"])
def test_quiet_prints_no_progress(tmp_path, capsys, chatty_planner, flag):
    code = plan_mission_main([str(_write_site(tmp_path, SLOW)), "-o", str(tmp_path / "m.plan"),
                              flag])
    out = capsys.readouterr()
    assert code == 0 and "iteration" not in out.err and "wrote" in out.out
    assert ("deprecated" in out.err) == (flag == "--no-progress")


def test_seed_is_deprecated_and_changes_nothing(tmp_path, capsys, chatty_planner):
    out = tmp_path / "m.plan"
    code, err = _run([_write_site(tmp_path, SLOW), "-o", out, "--seed", "3", "--quiet"], capsys)
    assert code == 0 and err.startswith("warning: --seed is deprecated and has no effect")


# ---------------------------------------------------------------------------- issue 11


def test_a_site_faster_than_the_vehicle_is_one_warning_naming_both_speeds(tmp_path, capsys,
                                                                          square_planner):
    fast = {**SLOW, "uav": {**SLOW["uav"], "max_speed": 30.0}}
    code, err = _run([_write_site(tmp_path, fast), "-o", tmp_path / "m.plan"], capsys)
    assert code == 0, err
    top = top_speed_mps(load_site(_write_site(tmp_path, fast)))
    warnings = [ln for ln in err.splitlines() if "top speed" in ln]
    assert len(warnings) == 1
    assert "uav.max_speed 30 m/s" in warnings[0] and f"{top:.2f} m/s" in warnings[0]
    assert f"planning at {top:.2f} m/s" in warnings[0]
    params = parse_params((tmp_path / "m.param").read_text())
    assert params["WPNAV_SPEED"] == math.ceil(top * 100.0 - 1e-9)  # what the vehicle reaches
    assert "WPNAV_SPEED" not in err  # within the documented range: no note


def test_html_writes_the_view_with_the_replay(tmp_path, capsys, chatty_planner):
    out = tmp_path / "view.html"
    code = plan_mission_main([str(_write_site(tmp_path, SLOW)), "-o", str(tmp_path / "m.plan"),
                              "--quiet", "--html", str(out)])
    assert code == 0 and str(out) in capsys.readouterr().out
    page = out.read_text(encoding="utf-8")
    assert "Plotly.newPlot" in page and "replay (arducopter): vehicle" in page


def test_html_draws_the_forecast_and_the_failsafe_paths_of_the_param_file(tmp_path, capsys,
                                                                          square_planner):
    out = tmp_path / "view.html"
    code, err = _run([_write_site(tmp_path, SLOW), "-o", tmp_path / "m.plan", "--quiet",
                      "--wind", "4@90,1", "--html", out], capsys)
    assert code == 0, err
    fig = page_figure(out.read_text(encoding="utf-8"))
    # our .param retraces the path with SmartRTL (or lands): no straight return to draw
    failsafe = layer(fig, "failsafe")
    assert [(t["meta"]["kind"], t["meta"]["ok"]) for t in failsafe] == [("retrace", True)]
    assert "FS_THR_ENABLE" in failsafe[0]["hovertext"]
    plan = read_plan(tmp_path / "m.plan")
    assert len(failsafe[0]["x"]) == len(resolve_flight(plan, load_site(
        _write_site(tmp_path, SLOW))).legs) + 1
    wind = [a["text"] for a in fig["layout"]["annotations"] if "m/s from" in a["text"]]
    assert len(wind) == 1 and "4 m/s from 90°" in wind[0] and "turbulence 1 m/s" in wind[0]
    assert "flown in" not in wind[0]  # the replay flies in the wind the plan is made for


def test_html_map_needs_html(tmp_path, capsys, chatty_planner):
    code, err = _run([_write_site(tmp_path, SLOW), "-o", tmp_path / "m.plan", "--html-map"],
                     capsys)
    assert code == 2 and "--html-map: only with --html" in err
    assert not (tmp_path / "m.plan").exists()


def test_output_onto_the_site_file_is_refused(tmp_path, capsys, square_planner):
    site = _write_site(tmp_path, SLOW)
    before = site.read_bytes()
    code, err = _run([site, "-o", site], capsys)
    assert code == 2 and err.count("\n") == 1
    assert "is an input of this command (the site file)" in err
    assert site.read_bytes() == before and not (tmp_path / "site.param").exists()


def test_report_onto_the_site_file_is_refused(tmp_path, capsys, square_planner):
    site = _write_site(tmp_path, SLOW)
    before = site.read_bytes()
    code, err = _run([site, "-o", tmp_path / "m.plan", "--report", site], capsys)
    assert code == 2 and "is an input of this command" in err
    assert site.read_bytes() == before and not (tmp_path / "m.plan").exists()


def test_output_onto_a_fifo_is_refused_and_the_fifo_kept(tmp_path, capsys, square_planner):
    fifo = tmp_path / "m.plan"
    os.mkfifo(fifo)
    code, err = _run([_write_site(tmp_path, SLOW), "-o", fifo], capsys)
    assert code == 2 and err.count("\n") == 1 and "not a regular file" in err
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and not (tmp_path / "m.param").exists()


def test_empty_output_path_is_one_line_exit_2(tmp_path, capsys, square_planner):
    code, err = _run([_write_site(tmp_path, SLOW), "-o", ""], capsys)
    assert code == 2 and err.count("\n") == 1 and "-o/--output: empty path" in err
