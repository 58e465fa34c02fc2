"""A mission replayed with its autopilot's model and recommended parameters, before take-off."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from mission_planner.autopilot_params import recommended_params
from mission_planner.flight_report import replay_mission
from mission_planner.mission import MissionOptions, build_mission
from tests.mission_planner.solutions import make_site, solution_for, subdivided
from validator.autopilot.failsafe import recommended_failsafes

SQUARE = [(150.0, 150.0), (250.0, 150.0), (250.0, 250.0), (150.0, 250.0)]


def _square(period_s, autopilot="ardupilot"):
    site = make_site(uav={"altitude": 30.0, "max_speed": 10.0, "period": period_s, "slots": 12})
    return build_mission(solution_for(site, subdivided(SQUARE, 3)),
                         MissionOptions(autopilot=autopilot))


@pytest.fixture(scope="module")
def slow():
    """100 m sides at 2.2 m/s: the arducopter model flies the cycle as planned."""
    return replay_mission(_square(180.0))


@pytest.fixture(scope="module")
def hurried():
    """The same square in 60 s: 8.3 m/s legs that stop at every corner take longer."""
    return replay_mission(_square(60.0))


def test_flies_the_arducopter_model_with_the_recommended_parameters(slow):
    m = _square(180.0)
    assert slow.profile.name == "arducopter"
    recommended = recommended_params(m).values
    # the replay flies with every recommended motion parameter; the fence and failsafe ones
    # (which only act when a zone is breached or a link, battery or position is lost) do not
    # move it
    not_motion = set(recommended_failsafes("ardupilot")) | {"SRTL_POINTS"}
    assert slow.params == {k: v for k, v in recommended.items()
                           if not k.startswith("FENCE_") and k not in not_motion}
    assert {k: slow.profile.params[k] for k in slow.params} == slow.params


def test_px4_missions_fly_the_px4_model():
    check = replay_mission(_square(180.0, "px4"))
    assert check.profile.name == "px4" and "NAV_ACC_RAD" in check.params


def test_a_cycle_flown_as_planned_gives_no_warning(slow):
    assert slow.cycle_ratio == pytest.approx(1.0, abs=0.02)
    assert slow.warning() is None


def test_a_cycle_more_than_ten_percent_late_is_one_warning_line(hurried):
    assert hurried.cycle_ratio > 1.1
    warning = hurried.warning()
    assert warning is not None and "\n" not in warning
    assert f"{hurried.replayed_cycle_s:.1f} s" in warning and "T = 60 s" in warning


def test_stopping_at_every_corner_costs_min_rate(slow, hurried):
    # Flown as planned, the square still gets a little less than the paper model says (it
    # scores each slot at its end point); the hurried plan's stops at corners cost more.
    assert 0.9 < slow.min_rate_ratio < 1.0
    assert hurried.min_rate_ratio < slow.min_rate_ratio


@pytest.mark.parametrize("ratio, warns", [(1.09, False), (1.11, True), (0.91, False),
                                          (0.89, True)])
def test_warning_threshold_is_ten_percent_either_way(slow, ratio, warns):
    cycle = replace(slow.report.cycle, flown_cycle_s=ratio * slow.period_s)
    check = replace(slow, report=replace(slow.report, cycle=cycle))
    assert (check.warning() is not None) == warns


def test_flight_section_holds_what_the_issue_asks_for(hurried):
    section = hurried.as_dict()
    json.dumps(section)  # plain JSON
    assert section["planned_cycle_s"] == 60.0
    assert section["replayed_cycle_s"] == pytest.approx(hurried.report.cycle.flown_cycle_s)
    assert section["planned_min_rate_bps_hz"] > section["replayed_min_rate_bps_hz"] > 0
    assert set(section["replayed_clearance_by_nfz_m"]) == {"NFZ1", "NFZ2", "NFZ3"}
    assert section["replayed_clearance_min_m"] == min(
        section["replayed_clearance_by_nfz_m"].values())
    assert section["warning"] == hurried.warning()


def test_the_flight_section_says_how_long_the_whole_mission_flies(slow):
    from mission_planner.mission import mission_summary

    section = slow.as_dict()
    assert section["replayed_mission_s"] == pytest.approx(slow.track.t_s[-1] - slow.track.t_s[0])
    # take-off, climb, accelerations and landing on top of the summary's nominal figure
    nominal = mission_summary(_square(180.0))["mission_duration_s"]
    assert nominal + 10.0 < section["replayed_mission_s"] < nominal + 120.0
