"""What is set on a vehicle before a flight, from validate-mission and from ``api.fly_plan``
alike: the parameter file, a sped-up SITL's link timeout, and ArduPilot SITL's wind at the
flight altitude."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from tests.validator.builders import make_site, waypoint_plan
from validator.mavlink.sitl_check import flight_params
from validator.mavlink.vehicles import VehicleChoice
from validator.plan_format import write_plan
from validator.site import site_to_dict
from validator.validation import validate_mission
from validator.wind import Wind
from validator.wind_track import buffer_share

PLAN_PARAMS = {"FS_GCS_ENABLE": 4.0, "WPNAV_SPEED": 800.0}
WIND = Wind(6.0, 270.0, 1.0)


def _sitl(name: str) -> VehicleChoice:
    return VehicleChoice("sitl-binary", binary=Path("/nowhere") / name, speedup_x=10.0)


def test_arducopter_sitl_flies_in_the_wind_with_its_link_timeout_widened():
    sent, note = flight_params(_sitl("arducopter"), PLAN_PARAMS, WIND)
    assert note is None
    assert sent["SIM_WIND_SPD"] == 6.0 and sent["SIM_WIND_DIR"] == 270.0
    assert sent["SIM_WIND_TURB"] == 1.0 and sent["SIM_WIND_T"] == 1.0
    # three of our 1 s heartbeats in the SITL's time at 10x, not its 5 s default
    assert sent["FS_GCS_TIMEOUT"] == 30.0
    assert {k: sent[k] for k in PLAN_PARAMS} == PLAN_PARAMS


def test_still_air_undoes_a_wind_left_on_arducopter_sitl():
    sent, _ = flight_params(_sitl("arducopter"), PLAN_PARAMS, None)
    assert sent["SIM_WIND_SPD"] == 0.0 and sent["SIM_WIND_TURB"] == 0.0


def test_px4_sih_says_it_has_no_wind():
    sent, note = flight_params(_sitl("px4"), PLAN_PARAMS, WIND)
    assert note is not None and "no wind" in note
    assert not any(k.startswith("SIM_WIND") for k in sent)


@pytest.mark.parametrize("choice", [VehicleChoice("builtin"),
                                    VehicleChoice("external", url="udp:127.0.0.1:14550")])
def test_other_vehicles_get_the_parameter_file_alone(choice):
    sent, note = flight_params(choice, PLAN_PARAMS, WIND)
    assert sent == PLAN_PARAMS
    assert (note is not None) == (choice.kind == "external")


def test_a_layered_wind_is_flown_and_judged_at_the_flight_altitude(tmp_path):
    site = make_site(nfz=((100.0, 60.0, 20.0),))
    d = site_to_dict(site)
    d["wind"] = {"speed_mps": 2.0, "from_deg": 270.0,
                 "layers": [{"above_m": 20.0, "speed_mps": 6.0, "from_deg": 270.0,
                             "turbulence_mps": 1.0}]}
    site_path, plan_path = tmp_path / "site.yaml", tmp_path / "mission.plan"
    site_path.write_text(yaml.safe_dump(d))
    write_plan(waypoint_plan(site, [(40.0, 0.0), (160.0, 0.0)], v=5.0), plan_path)
    v = validate_mission(plan_path, site_path)
    assert v.flight_wind == WIND  # 30 m up: the 20 m layer, not the 2 m/s at the ground
    sent, _ = flight_params(_sitl("arducopter"), {}, v.flight_wind)
    assert sent["SIM_WIND_SPD"] == 6.0
    judged = v.as_dict()["wind"]["track_deviation_m"]
    assert judged == pytest.approx(buffer_share(site.buffer_m, WIND)["track_deviation_m"])
    assert judged > buffer_share(site.buffer_m, Wind(2.0, 270.0))["track_deviation_m"]
