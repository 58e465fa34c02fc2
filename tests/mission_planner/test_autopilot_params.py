"""Autopilot parameters a mission needs: values from the plan and site, and the file formats."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from mission_planner.autopilot_params import (
    dumps_params,
    fastest_leg_mps,
    recommended_params,
    waypoint_radius_m,
)
from mission_planner.mission import MissionOptions, build_mission
from mission_planner.study.sites import random_site
from tests.mission_planner.solutions import make_site, solution_for, subdivided
from validator.autopilot.failsafe import FAILSAFES
from validator.autopilot.fence import FENCE_RULES
from validator.autopilot.param_file import parse_params
from validator.failsafe import effective_params, smartrtl_points_needed
from validator.flight import resolve_flight
from validator.motion.speed_model import top_speed_mps

# SmartRTL or Land on RC, GCS and low-battery loss; Land on a critical battery, EKF and dead
# reckoning; FS_OPTIONS 8 + 16 (finish a landing, a pilot keeps GCS loss)
SAFE_ARDUPILOT_FAILSAFES = {"FS_THR_ENABLE": 5.0, "FS_GCS_ENABLE": 4.0, "BATT_FS_LOW_ACT": 4.0,
                            "BATT_FS_CRT_ACT": 1.0, "FS_EKF_ACTION": 1.0, "FS_DR_ENABLE": 1.0,
                            "FS_OPTIONS": 24.0,
                            # SmartRTL's path within 0.5 m of the flown one, not 1 m (issue 27)
                            "SRTL_ACCURACY": 1.0}
# Hold on RC loss, Land on link loss, low battery and navigation loss, warn on flight time
SAFE_PX4_FAILSAFES = {"NAV_RCL_ACT": 1.0, "NAV_DLL_ACT": 3.0, "COM_LOW_BAT_ACT": 2.0,
                      "COM_FLTT_LOW_ACT": 1.0, "COM_POSCTL_NAVL": 1.0}
SQUARE = [(150.0, 150.0), (250.0, 150.0), (250.0, 250.0), (150.0, 250.0)]


def _mission(autopilot="ardupilot", fence_margin_m=None, **uav):
    site = make_site(uav={"altitude": 30.0, "max_speed": 12.0, "period": 60.0, "slots": 12,
                          **uav})
    delta = [4.0] * 3 + [6.0] * 9  # side 1 at 8.33 m/s, the rest at 5.56 m/s
    return build_mission(solution_for(site, subdivided(SQUARE, 3), delta),
                         MissionOptions(autopilot=autopilot, fence_margin_m=fence_margin_m,
                                        transit_speed_mps=7.0))


def test_ardupilot_params_come_from_the_fastest_leg_and_the_site_limits():
    m = _mission(max_accel=4.0, max_jerk=3.0)
    p = recommended_params(m)
    assert fastest_leg_mps(m) == pytest.approx(100.0 / 12.0)
    assert p.values == {"WPNAV_SPEED": 834.0,  # 833.3 cm/s rounded up to a whole cm/s
                        "WPNAV_ACCEL": 400.0, "WPNAV_JERK": 3.0, "WPNAV_RADIUS": 100.0,
                        "WP_YAW_BEHAVIOR": 2.0,  # facing the course, as the wind's timing
                        **SAFE_ARDUPILOT_FAILSAFES, "SRTL_POINTS": 300.0,
                        "FENCE_TYPE": 4.0, "FENCE_ACTION": 5.0, "FENCE_ENABLE": 1.0}
    assert p.notes == ()


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
def test_the_parameters_switch_the_fence_on_with_a_safe_breach_action(autopilot):
    p = recommended_params(_mission(autopilot))
    assert FENCE_RULES[autopilot].problems(p.values) == []


def test_px4_params_use_px4_names_and_si_units():
    p = recommended_params(_mission("px4", max_accel=4.0, max_jerk=3.0))
    assert p.values == {"MPC_XY_CRUISE": 8.34, "MPC_XY_VEL_MAX": 8.34, "MPC_ACC_HOR": 4.0,
                        "MPC_JERK_AUTO": 3.0, "NAV_ACC_RAD": 1.0, **SAFE_PX4_FAILSAFES,
                        "GF_ACTION": 2.0}


def test_transit_speed_counts_as_a_planned_leg():
    m = _mission()
    fast = build_mission(m.solution, MissionOptions(transit_speed_mps=9.5))
    assert recommended_params(fast).values["WPNAV_SPEED"] == 950.0


def test_wpnav_speed_is_what_the_vehicle_reaches_within_the_documented_range():
    # A paper-model plan on a 30 m/s site: legs and transits commanded at 30 m/s, but the
    # vehicle tops out at its lean-limited speed, and that is what WPNAV_SPEED says.
    fast = build_mission(_mission(max_speed=30.0).solution, MissionOptions(transit_speed_mps=30.0))
    for autopilot in ("ardupilot", "px4"):
        # ArduPilot's SITL quad at its 30 deg lean limit, PX4 SIH's at 45 deg with its drag
        top = top_speed_mps(fast.solution.site, autopilot)
        assert 9.0 < top < 11.0
        p = recommended_params(replace(fast, options=replace(fast.options, autopilot=autopilot)))
        speeds = [v for k, v in p.values.items() if k in ("WPNAV_SPEED", "MPC_XY_VEL_MAX")]
        scale = 100.0 if autopilot == "ardupilot" else 1.0
        assert speeds == [pytest.approx(top * scale, abs=0.01 * scale)]
        assert p.notes == ()


@pytest.mark.parametrize("buffer_m, margin_m, radius_m", [
    (2.0, None, 1.0),  # the default: half the buffer is left between legs and fence
    (2.0, 1.5, 0.5),
    (6.0, 0.0, 2.0),  # never wider than ArduCopter's default
    (0.0, None, 0.05),  # never below ArduCopter's minimum
])
def test_waypoint_radius_is_the_slack_between_planned_legs_and_fence(buffer_m, margin_m,
                                                                      radius_m):
    site = make_site(safety={"buffer_m": buffer_m})
    margin = buffer_m / 2 if margin_m is None else margin_m
    assert waypoint_radius_m(site, margin) == pytest.approx(radius_m)


def test_values_outside_the_documented_range_are_written_and_noted():
    fast = build_mission(_mission(max_speed=30.0, max_accel=6.0).solution,
                         MissionOptions(transit_speed_mps=30.0))
    p = recommended_params(fast)
    assert p.values["WPNAV_ACCEL"] == 600.0
    assert [n.split(" is ")[0] for n in p.notes] == ["WPNAV_ACCEL 600 cm/s/s"]
    assert "# note: WPNAV_ACCEL 600 cm/s/s" in dumps_params(p)


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
def test_parameter_file_reads_back_as_written(autopilot):
    p = recommended_params(_mission(autopilot))
    text = dumps_params(p, "test")
    assert parse_params(text) == pytest.approx(p.values)
    assert text.startswith("# test\n")


def test_ardupilot_file_is_name_value_lines_px4_file_is_qgc_format():
    ap = dumps_params(recommended_params(_mission()))
    px = dumps_params(recommended_params(_mission("px4")))
    ap_lines = [ln for ln in ap.splitlines() if not ln.startswith("#")]
    px_lines = [ln for ln in px.splitlines() if not ln.startswith("#")]
    assert [ln.split()[0] for ln in ap_lines] == [
        "WPNAV_SPEED", "WPNAV_ACCEL", "WPNAV_JERK", "WP_YAW_BEHAVIOR", "WPNAV_RADIUS",
        *SAFE_ARDUPILOT_FAILSAFES,
        "SRTL_POINTS", "FENCE_TYPE", "FENCE_ACTION", "FENCE_ENABLE"]
    assert all(len(ln.split()) == 2 for ln in ap_lines)
    for ln in px_lines:
        sysid, compid, name, value, ptype = ln.split("\t")
        # MAV_PARAM_TYPE as PX4 declares it: the actions are INT32 enums, the rest REAL32
        enum = name == "GF_ACTION" or name in SAFE_PX4_FAILSAFES
        assert (sysid, compid, ptype) == ("1", "1", "6" if enum else "9")
        assert math.isfinite(float(value))


@pytest.mark.parametrize("buffer_m, margin_m, extra_m", [
    (2.0, 1.0, 0.0),  # the radius (1 m) fits in the buffer's slack
    (0.0, 0.0, 0.05),  # no buffer: ArduCopter's 5 cm minimum radius must come off the legs
    (0.06, 0.03, 0.02),
])
def test_legs_make_room_for_the_corners_the_buffer_cannot(buffer_m, margin_m, extra_m):
    from mission_planner.mission.options import corner_margin_m

    site = random_site(1, slots=8, buffer_m=buffer_m)
    assert corner_margin_m(site, margin_m) == pytest.approx(extra_m)


def test_a_site_without_a_buffer_still_keeps_its_cut_corners_out_of_the_zones():
    # bench_safety's random-8: with no buffer the 5 cm waypoint radius cut a corner 2.4 cm
    # into NFZ2 in the replay of a written plan
    from mission_planner.flight_report import replay_mission
    from mission_planner.pipeline import plan_and_build

    site = random_site(8, buffer_m=0.0)
    mission = plan_and_build(site, dynamics="vehicle", position_loss_berth=False)
    assert not mission.problems
    check = replay_mission(mission)
    assert min(check.clearance_by_nfz_m.values()) > 0.0


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
def test_every_failsafe_we_set_flies_only_audited_paths(autopilot):
    # Whatever the site, the written actions retrace the flown path or stay in place: never a
    # straight return (which the failsafe audit would have to prove clear).
    p = recommended_params(_mission(autopilot))
    values, _ = effective_params(autopilot, p.values)
    for f in FAILSAFES[autopilot]:
        assert "rtl" not in f.action(values[f.param]).paths, f.param


def test_smartrtl_holds_the_whole_mission_within_its_documented_range():
    m = _mission()
    need = smartrtl_points_needed(resolve_flight(m.plan, m.solution.site))
    srtl = recommended_params(m).values["SRTL_POINTS"]
    assert srtl >= min(need, 500.0)
    assert 0 < srtl <= 500.0
