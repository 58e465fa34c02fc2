"""The planner's berth for a GPS loss: a plan from which the coast after the failsafe
(ArduCopter's EKF failsafe, PX4's Descend) could reach a zone is planned again with a buffer
wide enough (validator.position_loss measures the coast; mission_planner.pipeline plans with
it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mission_planner.mission import MissionOptions
from mission_planner.pipeline import mission_report, plan_and_build, position_loss_findings
from validator.coast_rules import PX4
from validator.position_loss import BERTH_MARGIN_M
from validator.site import load_site

REALISTIC = Path(__file__).resolve().parents[2] / "samples" / "realistic.yaml"


@pytest.fixture(scope="module")
def site():
    return load_site(REALISTIC)


@pytest.fixture(scope="module")
def narrow(site):
    return plan_and_build(site, position_loss_berth=False)


def test_the_sample_at_its_own_buffer_could_coast_into_a_zone(narrow):
    lost = position_loss_findings(narrow)
    assert lost and min(f.clearance_m for f in lost) < 0.0
    assert narrow.position_loss_berth is None


def test_the_berth_plans_again_until_every_coast_stays_clear(site, narrow):
    mission = plan_and_build(site)
    berth = mission.position_loss_berth
    assert berth is not None and berth.left == 0
    assert position_loss_findings(mission) == ()
    deepest = max(-f.clearance_m for f in position_loss_findings(narrow))
    assert berth.deepest_m == pytest.approx(deepest)
    assert berth.site_buffer_m == site.buffer_m < berth.buffer_m == mission.solution.site.buffer_m
    assert berth.buffer_m >= site.buffer_m + deepest
    assert not mission.problems
    assert mission_report(mission)["position_loss_berth"]["findings_left"] == 0


def test_the_wider_berth_costs_rate(site, narrow):
    # not free: the report is where an operator sees the price of the wider berth
    mission = plan_and_build(site)
    assert mission.solution.min_rate_bps_hz < narrow.solution.min_rate_bps_hz


def test_the_papers_kinematic_model_stays_the_papers(site):
    mission = plan_and_build(site, dynamics="none")
    assert mission.position_loss_berth is None
    assert mission.solution.site.buffer_m == site.buffer_m


def test_a_px4_plan_keeps_the_berth_of_px4s_own_coast(site):
    # PX4's coast (validator.coast_rules.PX4: off the path, then a wider wander) reaches NFZ3
    # from the sample's legs at 3 m; the plan is made again with PX4's berth
    options = MissionOptions(autopilot="px4")
    narrow = plan_and_build(site, options=options, pass_through_corners=False,
                            position_loss_berth=False)
    lost = position_loss_findings(narrow)
    assert lost and all(f.autopilot == "px4" for f in lost)
    mission = plan_and_build(site, options=options, pass_through_corners=False)
    berth = mission.position_loss_berth
    assert berth is not None and berth.left == 0 and "PX4" in berth.message
    assert site.buffer_m + berth.deepest_m <= berth.buffer_m  # the first berth, at most
    assert berth.buffer_m <= PX4.wander_m + PX4.offpath_m + BERTH_MARGIN_M  # PX4's reach
    assert position_loss_findings(mission) == () and not mission.problems


def test_home_inside_the_wider_buffer_leaves_the_findings_as_warnings(site):
    # home 5 m outside NFZ1's 3 m buffer: no plan can keep the 12 m the coast needs there
    c, r = site.nfz_xy_m[0], float(site.nfz_radius_m[0])
    home = site.with_limits(home_xy_m=c + np.array([0.0, -(r + site.buffer_m + 5.0)]))
    mission = plan_and_build(home)
    berth = mission.position_loss_berth
    assert berth is not None and berth.left > 0
    assert berth.buffer_m == berth.site_buffer_m == site.buffer_m
    assert "no wider buffer could be planned" in berth.message


def test_plan_mission_says_it_widened_the_buffer_and_buffer_m_keeps_the_given_one(tmp_path,
                                                                                  capsys):
    import json

    from mission_planner.cli import plan_mission_main

    assert plan_mission_main([str(REALISTIC), "-o", str(tmp_path / "a.plan"),
                              "--report", str(tmp_path / "a.json")]) == 0
    err = capsys.readouterr().err
    assert "plan-mission: note: buffer widened from 3 m to " in err
    report = json.loads((tmp_path / "a.json").read_text())
    assert report["position_loss_berth"]["buffer_m"] == report["buffer_m"] > 3.0

    assert plan_mission_main([str(REALISTIC), "-o", str(tmp_path / "b.plan"), "--quiet",
                              "--buffer-m", "3", "--report", str(tmp_path / "b.json")]) == 0
    assert "buffer widened" not in capsys.readouterr().err
    report = json.loads((tmp_path / "b.json").read_text())
    assert "position_loss_berth" not in report and report["buffer_m"] == 3.0

    # a note, not a warning: --quiet leaves it out, the report still says it
    assert plan_mission_main([str(REALISTIC), "-o", str(tmp_path / "c.plan"), "--quiet",
                              "--report", str(tmp_path / "c.json")]) == 0
    assert "buffer widened" not in capsys.readouterr().err
    assert "position_loss_berth" in json.loads((tmp_path / "c.json").read_text())


def test_in_wind_the_berth_takes_one_step_and_plan_mission_warns_of_the_drift(tmp_path, capsys):
    # realistic.yaml in 3 m/s from 270°: at the wander's 12.5 m one coast still reaches NFZ1,
    # and a second step asked for 27.5 m (1.50 against 1.80 bps/Hz); in wind the landing's
    # drift (125 m here) is beyond any berth, so the berth stops at its first step and
    # plan-mission warns of the drift instead
    from mission_planner.cli import plan_mission_main
    from validator.position_loss import BERTH_MARGIN_M, WANDER_M
    from validator.wind import Wind

    windy = load_site(REALISTIC).with_limits(wind=Wind(3.0, 270.0))
    mission = plan_and_build(windy)
    berth = mission.position_loss_berth
    assert berth is not None and berth.windy
    assert berth.buffer_m <= WANDER_M + BERTH_MARGIN_M + 1e-9
    assert "but for the wind's drift" in berth.message or berth.left
    drifting = [f for f in position_loss_findings(mission) if f.drift_m > 100.0]
    assert drifting  # the audit with the drift finds what the berth leaves

    assert plan_mission_main([str(REALISTIC), "-o", str(tmp_path / "w.plan"), "--quiet",
                              "--wind", "3@270"]) == 0
    err = capsys.readouterr().err
    [line] = [x for x in err.splitlines() if "drifts up to" in x]
    assert line.startswith("plan-mission: warning: a GPS loss in 3 m/s from 270°")
    assert "no buffer keeps that clear" in line


def _recorded_plans(monkeypatch) -> list[tuple[float, object, bool]]:
    """Each plan plan_and_build makes from here on: (buffer asked of it, its wind_paths,
    whether its search ends at the first fit)."""
    from mission_planner import pipeline

    made: list[tuple[float, object, bool]] = []
    real = pipeline.plan_solution

    def recording(site, *args, **kwargs):
        made.append((site.buffer_m, kwargs.get("wind_paths"), kwargs.get("first_fit", False)))
        return real(site, *args, **kwargs)

    monkeypatch.setattr(pipeline, "plan_solution", recording)
    return made


def test_in_wind_the_plan_a_berth_replaces_searches_one_family_to_its_first_fit(monkeypatch):
    # the plan at the asked buffer is a probe for the coast's findings: one family (half the
    # search) up to the first speed that fits; the berth plan, the one kept, searches every
    # family in full
    from mission_planner.pipeline import BERTH_PROBE_PATHS
    from validator.wind import Wind

    windy = load_site(REALISTIC).with_limits(wind=Wind(6.0, 270.0))
    made = _recorded_plans(monkeypatch)
    mission = plan_and_build(windy)
    berth = mission.position_loss_berth
    assert berth is not None and berth.buffer_m > berth.site_buffer_m
    assert made == [(windy.buffer_m, BERTH_PROBE_PATHS, True), (berth.buffer_m, None, False)]
    assert mission.solution.site.buffer_m == berth.buffer_m


def test_in_wind_a_probe_without_findings_is_planned_again_with_every_family(monkeypatch):
    from mission_planner import pipeline
    from mission_planner.pipeline import BERTH_PROBE_PATHS
    from validator.wind import Wind

    windy = load_site(REALISTIC).with_limits(wind=Wind(6.0, 270.0))
    made = _recorded_plans(monkeypatch)
    monkeypatch.setattr(pipeline, "position_loss_findings", lambda mission, drift=True: ())
    mission = plan_and_build(windy)
    assert mission.position_loss_berth is None
    assert made == [(windy.buffer_m, BERTH_PROBE_PATHS, True), (windy.buffer_m, None, False)]
