"""The planner's front door (:mod:`mission_planner.api`): files written all or none, a refused
mission refused, typed results, the names exported by the package."""

from __future__ import annotations

import dataclasses
import json

import pytest

import mission_planner
from mission_planner import api
from tests.mission_planner.solutions import circle_tour, make_site
from tests.view_figure import layer, page_figure
from validator.autopilot.param_file import parse_params
from validator.errors import InputError


@pytest.fixture()
def mission():
    return api.build_mission(circle_tour(make_site()), api.MissionOptions())


def test_the_package_exports_the_front_door():
    assert sorted(mission_planner.__all__) == sorted(api.__all__)
    for name in mission_planner.__all__:
        assert getattr(mission_planner, name) is getattr(api, name)


def test_write_mission_writes_the_plan_its_parameter_file_and_report(mission, tmp_path):
    params = api.recommended_params(mission)
    flight = api.replay_mission(mission, params)
    written = api.write_mission(mission, tmp_path / "m.plan", autopilot_params=params,
                                flight=flight, report=tmp_path / "r.json")
    assert written.mission == tmp_path / "m.plan" and written.params == tmp_path / "m.param"
    assert set(written.files) == {tmp_path / n for n in ("m.plan", "m.param", "r.json")}
    assert all(p.is_file() for p in written.files)
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["flight"]["replayed_cycle_s"] == pytest.approx(flight.replayed_cycle_s)
    plan = api.read_plan(written.mission)
    assert len(plan.items) == len(mission.plan.items)
    assert api.audit_plan(plan, mission.solution.site).violations == []


def test_the_waypoints_format_follows_the_suffix(mission, tmp_path):
    written = api.write_mission(mission, tmp_path / "m.waypoints")
    names = {p.name for p in written.files}
    assert {"m.waypoints", "m.param"} <= names and any("fence" in n for n in names)


def test_a_refused_mission_writes_nothing_unless_forced(mission, tmp_path):
    unsafe = dataclasses.replace(mission, problems=("leg 3 inside NFZ1",))
    with pytest.raises(api.UnsafeMission) as refused:
        api.write_mission(unsafe, tmp_path / "m.plan")
    assert refused.value.problems == ("leg 3 inside NFZ1",)
    assert list(tmp_path.iterdir()) == []
    api.write_mission(unsafe, tmp_path / "m.plan", force=True)
    assert (tmp_path / "m.plan").is_file()


def test_colliding_outputs_are_bad_input_and_write_nothing(mission, tmp_path):
    with pytest.raises(InputError, match="named for two outputs"):
        api.write_mission(mission, tmp_path / "m.plan", report=tmp_path / "m.param")
    with pytest.raises(InputError, match="does not exist"):
        api.write_mission(mission, tmp_path / "missing" / "m.plan")
    assert list(tmp_path.iterdir()) == []


def test_the_view_draws_the_failsafe_paths_of_the_parameter_file_written(mission, tmp_path):
    # a file flying RTL on RC loss: the view shows the straight returns the audit checked
    params = api.recommended_params(mission)
    rtl = dataclasses.replace(params, values={**params.values, "FS_THR_ENABLE": 1.0})
    api.write_mission(mission, tmp_path / "m.plan", autopilot_params=rtl,
                      html=tmp_path / "v.html")
    failsafe = layer(page_figure((tmp_path / "v.html").read_text(encoding="utf-8")), "failsafe")
    kinds = {t["meta"]["kind"] for t in failsafe}
    assert "region" in kinds and "line" in kinds
    assert any("FS_THR_ENABLE 1" in t["hovertext"] for t in failsafe)
    assert parse_params((tmp_path / "m.param").read_text())["FS_THR_ENABLE"] == 1.0


def test_a_flight_beyond_the_endurance_is_refused_unless_forced(mission, tmp_path):
    flight = api.replay_mission(mission)
    assert flight.problems == ()
    site = dataclasses.replace(mission.solution.site, endurance_s=flight.report.duration_s / 2)
    short = api.replay_mission(dataclasses.replace(
        mission, solution=dataclasses.replace(mission.solution, site=site)))
    assert len(short.problems) == 1 and "uav.endurance" in short.problems[0]
    with pytest.raises(api.UnsafeMission) as refused:
        api.write_mission(mission, tmp_path / "m.plan", flight=short)
    assert refused.value.problems == short.problems
    assert list(tmp_path.iterdir()) == []
    api.write_mission(mission, tmp_path / "m.plan", flight=short, force=True)
    assert (tmp_path / "m.plan").is_file()
