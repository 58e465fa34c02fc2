"""Legs commanded slower where a GPS loss's coast needs it: MissionOptions.leg_speed_caps, laid
out by mission_planner.mission.speeds, chosen by plan_and_build from the position-loss audit."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mission_planner.mission import MissionOptions, build_mission
from mission_planner.mission.options import LEG_MATCH_M, check_options
from mission_planner.mission.speeds import capped_steps, leg_caps_mps, transit_speeds
from mission_planner.mission.steps import CycleStep
from mission_planner.mission.summary import cycle_duration_s
from mission_planner.pipeline import plan_and_build, position_loss_findings
from validator.errors import InputError
from validator.site import load_site

SAMPLES = Path(__file__).resolve().parents[2] / "samples"
PATH = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 50.0]])


def test_a_cap_holds_on_the_leg_whose_two_ends_it_names():
    caps = (((100.0, 0.0), (100.0, 50.0), 6.0),)
    assert leg_caps_mps(PATH, caps).tolist() == [np.inf, 6.0]


def test_a_cap_holds_within_the_match_distance_of_both_ends():
    off = 0.9 * LEG_MATCH_M
    assert leg_caps_mps(PATH, (((off, 0.0), (100.0, off), 6.0),))[0] == 6.0
    assert leg_caps_mps(PATH, (((2 * LEG_MATCH_M, 0.0), (100.0, 0.0), 6.0),))[0] == np.inf


def test_a_leg_reached_from_elsewhere_is_not_capped():
    # same end point, other start: another leg
    assert leg_caps_mps(PATH, (((50.0, -50.0), (100.0, 0.0), 6.0),)).tolist() == [np.inf] * 2


def test_the_least_of_two_caps_on_a_leg_holds():
    caps = (((0.0, 0.0), (100.0, 0.0), 7.0), ((0.0, 0.0), (100.0, 0.0), 5.5))
    assert leg_caps_mps(PATH, caps)[0] == 5.5


def test_a_transit_leg_is_commanded_no_faster_than_its_cap():
    site = load_site(SAMPLES / "realistic.yaml")
    speeds = transit_speeds(PATH, site, "ardupilot", {}, 10.0,
                            (((100.0, 0.0), (100.0, 50.0), 6.0),))
    assert speeds.tolist() == [10.0, 6.0]


def _step(index: int, speed: float | None, leg_s: float, scurve: bool = True) -> CycleStep:
    return CycleStep(index=index, slots=(index - 1,), leg_s=leg_s, hold_s=0.0, speed_mps=speed,
                     scurve=scurve)


def test_a_capped_s_curve_leg_takes_what_its_slower_motion_adds():
    def rest_to_rest_s(length_m: float, speed_mps: float) -> float:
        return length_m / speed_mps + speed_mps / 2.0  # cruise plus a 2 m/s² ramp each way

    steps = [_step(1, 10.0, 12.0), _step(2, 10.0, 7.0)]
    out = capped_steps(steps, PATH, (((0.0, 0.0), (100.0, 0.0), 8.0),), rest_to_rest_s)
    assert out[0].speed_mps == 8.0
    assert out[0].leg_s == pytest.approx(12.0 + (100 / 8 + 4.0) - (100 / 10 + 5.0))
    assert out[1] == steps[1]


def test_a_cap_above_the_legs_speed_changes_nothing():
    steps = [_step(1, 6.0, 20.0), _step(2, 6.0, 10.0)]
    assert capped_steps(steps, PATH, (((0.0, 0.0), (100.0, 0.0), 8.0),),
                        lambda length_m, speed_mps: 0.0) == steps


def test_options_refuse_a_cap_the_vehicle_cannot_be_commanded():
    site = load_site(SAMPLES / "realistic.yaml")
    for cap in (0.0, -1.0, site.max_speed_mps + 1.0, float("nan")):
        with pytest.raises(InputError, match="leg_speed_caps"):
            check_options(site, MissionOptions(leg_speed_caps=(((0, 0), (1, 0), cap),)))


@pytest.fixture(scope="module")
def airfield():
    return plan_and_build(load_site(SAMPLES / "airfield.yaml"))


def test_a_coast_the_widest_berth_leaves_in_reach_is_kept_out_by_a_slower_leg(airfield):
    # the airfield's berth (20.1 m) still left the leg to its cycle's far end coasting 0.6 m
    # into the CTR at 10 m/s; 9.5 m/s keeps it out
    berth = airfield.position_loss_berth
    assert berth is not None and berth.slowed and berth.left == 0
    assert position_loss_findings(airfield, drift=False) == ()
    [(item, was, now)] = berth.slowed
    assert now < was
    speeds = [it for it in airfield.plan.items[:item] if it.command == 178]  # DO_CHANGE_SPEED
    assert speeds[-1].params[1] == pytest.approx(now)
    assert f"the leg to item {item + 1} slowed from {was:.1f} to {now:.1f} m/s" in berth.message


def test_without_the_cap_the_same_layout_coasts_into_a_zone(airfield):
    unslowed = build_mission(airfield.solution,
                             dataclasses.replace(airfield.options, leg_speed_caps=()))
    lost = position_loss_findings(unslowed, drift=False)
    assert lost and all(f.speed_cap_mps is not None for f in lost)


def test_the_slower_leg_costs_the_cycle_seconds_not_its_period(airfield):
    unslowed = build_mission(airfield.solution,
                             dataclasses.replace(airfield.options, leg_speed_caps=()))
    longer = cycle_duration_s(airfield) - cycle_duration_s(unslowed)
    assert 0.0 < longer < 0.01 * airfield.solution.site.period_s


def test_a_cycle_leg_is_slowed_only_within_its_share_of_the_period(monkeypatch):
    # realistic.yaml in 6 m/s from 270° asked an upwind cycle leg down from 4.5 to 2.9 m/s:
    # 45 s of a 160 s cycle; with no share of T to spend, the airfield's 1.1 s is refused too
    from mission_planner import pipeline

    monkeypatch.setattr(pipeline, "COAST_SLOWING_MAX", 0.0)
    mission = plan_and_build(load_site(SAMPLES / "airfield.yaml"))
    berth = mission.position_loss_berth
    assert berth is not None and not berth.slowed and berth.left > 0
    assert not mission.options.leg_speed_caps
