"""A realistic plan made for a wind, flown by the real ArduCopter firmware in that wind.

Runs an ArduCopter SITL binary (``$ARDUPILOT_SITL``, else ``/opt/sitl/arducopter``; skipped
without one, as ``test_ardupilot_sitl.py``): ``validate-mission --sitl-binary`` sets
SIM_WIND_SPD / SIM_WIND_DIR / SIM_WIND_TURB (and SIM_WIND_T 1, a flat wind) from the plan's
own wind, and the flight must keep T and stay out of every zone.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.validator.mavlink.sitl_binaries import REPO, plan_for, sitl_binary
from validator.cli import validate_mission_main

BINARY = sitl_binary("ARDUPILOT_SITL", Path("/opt/sitl/arducopter"))
pytestmark = [pytest.mark.realtime, pytest.mark.xdist_group("real-sitl"), pytest.mark.skipif(
    BINARY is None,
    reason="no ArduCopter SITL binary: build ArduCopter 4.5 SITL for this machine and set "
           "ARDUPILOT_SITL=/path/to/build/sitl/bin/arducopter (or link it at "
           "/opt/sitl/arducopter) to fly plans in SITL wind")]


def test_a_plan_made_for_the_wind_keeps_its_period_and_clearance_in_it(tmp_path) -> None:
    site = REPO / "samples" / "realistic.yaml"
    planned = tmp_path / "windy.report.json"
    plan, params = plan_for(tmp_path, site, "--wind", "5@250,1", "--report", str(planned))
    out = tmp_path / "flown.json"
    status = validate_mission_main([str(plan), "--site", str(site), "--params", str(params),
                                    "--sitl-binary", str(BINARY), "--report", str(out)])
    report = json.loads(out.read_text())
    assert status == 0
    assert report["wind"]["as_planned"] is True
    sent = report["sitl_flight"]["params_set"]
    assert (sent["SIM_WIND_SPD"], sent["SIM_WIND_DIR"], sent["SIM_WIND_TURB"]) == (5.0, 250.0,
                                                                                   1.0)
    assert report["sitl_flight"]["end"] == "landed"
    cycle = report["sitl"]["cycle"]
    predicted = json.loads(planned.read_text())["flight"]["replayed_cycle_s"]
    assert cycle["flown_cycle_s"] == pytest.approx(cycle["planned_period_s"], rel=0.05)
    assert cycle["flown_cycle_s"] == pytest.approx(predicted, rel=0.03)
    assert all(z["clearance_m"] > 0 for z in report["sitl"]["nfz"])
    assert report["sitl_flight"]["fence_breach_samples"] == 0


def test_the_front_door_flies_a_layered_wind_at_the_flight_altitude(tmp_path) -> None:
    """``api.fly_plan`` sets what validate-mission sets (the sped-up SITL's link timeout: without
    it the vehicle refused to arm, 'GCS failsafe on') and flies the site's wind at the flight
    altitude: 5 m/s from 20 m up, not the 2 m/s at the ground."""
    import yaml

    from mission_planner import api
    from validator.autopilot.param_file import read_params

    d = yaml.safe_load((REPO / "samples" / "realistic.yaml").read_text())
    d["wind"] = {"speed_mps": 2.0, "from_deg": 250.0,
                 "layers": [{"above_m": 20.0, "speed_mps": 5.0, "from_deg": 250.0,
                             "turbulence_mps": 1.0}]}
    site_path = tmp_path / "layered.yaml"
    site_path.write_text(yaml.safe_dump(d))
    plan_path, params_path = plan_for(tmp_path, site_path)
    site, plan = api.load_site(site_path), api.read_plan(plan_path)
    params = read_params(params_path)
    flown = api.fly_plan(plan, site, api.choose_vehicle(plan, binary=str(BINARY)), params=params)
    sent = flown.params_set
    assert (sent["SIM_WIND_SPD"], sent["SIM_WIND_DIR"], sent["SIM_WIND_TURB"]) == (5.0, 250.0,
                                                                                   1.0)
    assert sent["FS_GCS_TIMEOUT"] > 5.0
    assert flown.telemetry.end_reason == "landed" and flown.report.violations == []
    cycle = flown.report.cycle
    assert cycle is not None
    assert cycle.flown_cycle_s == pytest.approx(cycle.planned_period_s, rel=0.05)
