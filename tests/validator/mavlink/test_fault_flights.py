"""Faults on the real firmware: RC loss and low battery on ArduCopter SITL (and a GPS loss on
the plan plan-mission makes now), data-link loss on PX4 SIH, injected where a straight return
would come closest to a zone (a GPS loss: where its coast would)
(``validate-mission --sitl-binary ... --fault KIND``), and a GPS loss on PX4 SIH whose coast
must stay in the modelled region. With the parameters plan-mission writes,
the vehicle must keep out of every zone and end landed or holding still; a GPS loss in wind
drifts downwind while it lands, as far as the audit warned.

Skipped without a SITL binary (``$ARDUPILOT_SITL`` / ``$PX4_SITL`` or the README's documented
paths); each flies a whole mission against the wall clock.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.validator.mavlink.sitl_binaries import sitl_binary
from validator.cli import validate_mission_main

DATA = Path(__file__).resolve().parents[2] / "data" / "failsafe"
ARDUCOPTER = sitl_binary("ARDUPILOT_SITL", Path("/opt/sitl/arducopter"))
PX4 = sitl_binary("PX4_SITL", Path("/opt/sitl/px4/build/px4_sitl_default/bin/px4"))
pytestmark = [pytest.mark.realtime, pytest.mark.xdist_group("real-sitl")]
needs_arducopter = pytest.mark.skipif(
    ARDUCOPTER is None, reason="no ArduCopter SITL binary: set ARDUPILOT_SITL (README, *Real "
                               "autopilots*) to fly the fault tests")
needs_px4 = pytest.mark.skipif(
    PX4 is None, reason="no PX4 SITL binary: set PX4_SITL (README, *Real autopilots*) to fly "
                        "the PX4 fault test")


def _fly(tmp_path: Path, binary: Path | None, site: str, plan: str, params: str, fault: str,
         *extra: str) -> tuple[int, dict]:
    out = tmp_path / "report.json"
    status = validate_mission_main([
        str(DATA / "plans" / f"{plan}.plan"), "--site", str(DATA / "sites" / f"{site}.yaml"),
        "--params", str(DATA / "params" / params), "--sitl-binary", str(binary),
        "--fault", fault, "--report", str(out), *extra])
    return status, json.loads(out.read_text())


def _assert_safe(status: int, report: dict, mode: str) -> None:
    fault = report["fault"]
    assert status == 0, report["violations"]
    assert fault["injected_s"] is not None
    assert min(fault["clearance_m"].values()) > 0, fault["clearance_m"]  # no zone entered
    assert fault["end_state"] in ("landed", "safe hold"), fault["end_state"]
    assert mode in fault["modes"], fault["modes"]


@needs_arducopter
@pytest.mark.parametrize("fault, mode", [("rc-loss", "SMART_RTL"), ("battery-low", "SMART_RTL")])
def test_arducopter_flies_the_audited_failsafe_path_home(tmp_path, fault, mode):
    status, report = _fly(tmp_path, ARDUCOPTER, "river", "river-ardupilot",
                          "river-ardupilot-planned.param", fault)
    _assert_safe(status, report, mode)
    assert report["fault"]["end_from_home_m"] < 5.0  # SmartRTL lands at home


@needs_arducopter
def test_the_before_case_is_flagged_by_the_audit_and_flies_rtl(tmp_path):
    # RC loss left at ArduCopter's default RTL: the audit fails the file, and the flight
    # that follows turns straight for home across the zone
    status, report = _fly(tmp_path, ARDUCOPTER, "river", "river-ardupilot", "thr-rtl.param",
                          "rc-loss")
    assert status == 1
    assert {f["param"] for f in report["failsafe"]["findings"]} == {"FS_THR_ENABLE"}
    assert "RTL" in report["fault"]["modes"]


@needs_px4
def test_px4_lands_in_place_on_data_link_loss(tmp_path):
    status, report = _fly(tmp_path, PX4, "river", "river-px4", "river-px4-planned.params",
                          "gcs-loss")
    _assert_safe(status, report, "LAND")


@needs_arducopter
def test_a_gps_loss_on_the_default_plan_coasts_clear_of_every_zone(tmp_path):
    # the realistic site as plan-mission plans it now: at its 3 m buffer a GPS loss coasted
    # 3.7 m into NFZ1 on this SITL; the plan keeps the berth the coast needs, and the loss is
    # aimed where the modelled coast comes closest
    from mission_planner.cli import plan_mission_main

    plan, params = tmp_path / "m.plan", tmp_path / "m.param"
    assert plan_mission_main([str(DATA / "sites" / "realistic.yaml"), "-o", str(plan),
                              "--quiet"]) == 0
    out = tmp_path / "report.json"
    status = validate_mission_main([str(plan), "--site", str(DATA / "sites" / "realistic.yaml"),
                                    "--params", str(params), "--sitl-binary", str(ARDUCOPTER),
                                    "--fault", "gps-loss", "--report", str(out), "--quiet"])
    report = json.loads(out.read_text())
    _assert_safe(status, report, "LAND")
    assert report["fault"]["coast"] is not None  # the EKF failsafe fired and the coast measured


@needs_px4
def test_a_px4_gps_loss_coasts_within_the_modelled_region_and_clear_of_every_zone(tmp_path):
    # the realistic site as plan-mission plans it for PX4 now (with PX4's GPS-loss berth: at
    # the 3 m buffer a loss aimed the same way coasted 0.39 m into NFZ3), the loss aimed where
    # the modelled coast comes closest; PX4 falls back to Descend, and the true track must
    # stay in the region validator.coast_rules.PX4 gives the legs it flew
    from mission_planner.cli import plan_mission_main
    from tests.validator.px4_coast import outside_m
    from validator.coast_rules import PX4 as PX4_COAST
    from validator.flight import resolve_flight
    from validator.plan_format import read_plan
    from validator.site import load_site

    site_path = DATA / "sites" / "realistic.yaml"
    plan, params = tmp_path / "m.plan", tmp_path / "m.param"
    assert plan_mission_main([str(site_path), "--autopilot", "px4", "-o", str(plan),
                              "--quiet"]) == 0
    out = tmp_path / "report.json"
    # x2 as test_px4_sitl.py flies: SIH is not lockstepped, and a starved one flies late
    status = validate_mission_main([str(plan), "--site", str(site_path), "--params",
                                    str(params), "--sitl-binary", str(PX4), "--sitl-speedup",
                                    "2", "--fault", "gps-loss", "--report", str(out),
                                    "--quiet"])
    report = json.loads(out.read_text())
    _assert_safe(status, report, "LAND")  # Descend reports AUTO_LAND's custom mode
    fault = report["fault"]
    assert fault["position_source"] == "simulator truth (HIL_STATE_QUATERNION)"
    # from the injection, before the parameter set's round trip: up to a second more
    assert fault["coast"] is not None and fault["coast"]["delay_s"] <= PX4_COAST.delay_s + 1.0
    site = load_site(site_path)
    flight = resolve_flight(read_plan(plan), site, str(plan))
    speed = max(leg.speed_mps or 0.0 for leg in flight.legs)
    assert outside_m(flight, speed, fault["injected_xy_m"], fault["track_xy_m"],
                     PX4_COAST) == 0.0


@needs_arducopter
def test_a_gps_loss_in_wind_drifts_downwind_as_far_as_the_audit_warns(tmp_path):
    # the realistic site planned for 4 m/s from the south and flown in it: a vehicle without
    # a position lands drifting north with the air (146 m measured once, into NFZ2); the
    # audit must have warned of that drift, and the flown drift must lie within it
    import numpy as np

    from mission_planner.cli import plan_mission_main
    from validator.autopilot.rules import failsafe_land_s
    from validator.position_loss import COAST_S, WANDER_M
    from validator.wind import Wind

    site = str(DATA / "sites" / "realistic.yaml")
    plan, params = tmp_path / "m.plan", tmp_path / "m.param"
    assert plan_mission_main([site, "-o", str(plan), "--wind", "4@180", "--quiet"]) == 0
    out = tmp_path / "report.json"
    validate_mission_main([str(plan), "--site", site, "--params", str(params),
                           "--sitl-binary", str(ARDUCOPTER), "--fault", "gps-loss",
                           "--report", str(out), "--quiet"])
    report = json.loads(out.read_text())
    fault = report["fault"]
    assert fault["end_state"] == "landed" and "LAND" in fault["modes"]
    warned = [f for f in report["failsafe"]["position_loss"] if f["drift_m"] > 0]
    assert warned, "the audit must warn of the drift in this wind"
    drift = Wind(4.0, 180.0).vector_mps * failsafe_land_s(30.0, None)
    track = np.array(fault["track_xy_m"])
    failsafe_at = track[int(round(fault["coast"]["delay_s"]))]
    moved = np.asarray(fault["end_xy_m"]) - failsafe_at
    north = float(moved[1])
    assert 0.5 * drift[1] < north <= drift[1] + COAST_S * 10.0 + WANDER_M, (north, drift)


@needs_arducopter
def test_the_front_door_flies_a_fault_as_the_command_does():
    """``api.fly_plan(..., fault=)``: the same injection at the same point, scored into
    ``Flown.fault``, with the parameters plan-mission writes: SmartRTL home, no zone entered."""
    from validator import api
    from validator.autopilot.param_file import read_params

    site = api.load_site(DATA / "sites" / "river.yaml")
    plan = api.read_plan(DATA / "plans" / "river-ardupilot.plan")
    params = read_params(DATA / "params" / "river-ardupilot-planned.param")
    flown = api.fly_plan(plan, site, api.choose_vehicle(plan, binary=str(ARDUCOPTER)),
                         params=params, fault="rc-loss")
    after = flown.fault
    assert after is not None and after.injected_s > 0
    assert "SMART_RTL" in after.modes and after.end_state == "landed", (after.modes,
                                                                        after.end_state)
    assert not after.entered_zone and after.end_from_home_m < 5.0
    assert flown.report.violations == []
