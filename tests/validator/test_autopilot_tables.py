"""Each autopilot's one parameter table, and everything that reads its parameters from it."""

import math

import pytest

from validator.autopilot import ardupilot, px4
from validator.autopilot.tables import PARAM_TABLES, param_table, range_notes
from validator.errors import InputError
from validator.mavlink.sim.config import VehicleConfig
from validator.mavlink.sim.params import ParamTable
from validator.motion.limits import VehicleLimits
from validator.motion.profile import PARAM_SPECS, make_profile


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
def test_every_default_lies_in_its_documented_range(autopilot):
    outside = [n for n, s in param_table(autopilot).items() if not s.in_range(s.default)]
    assert outside == []


@pytest.mark.parametrize("profile, table", [("arducopter", ardupilot.PARAMS),
                                            ("px4", px4.PARAMS)])
def test_a_profile_flies_with_its_autopilots_own_parameter_specs(profile, table):
    shared = [n for n in PARAM_SPECS[profile] if n in table]
    assert len(shared) >= 16
    assert all(PARAM_SPECS[profile][n] is table[n] for n in shared)
    # what is not the autopilot's is our model's, in SI units
    assert all(PARAM_SPECS[profile][n].to_si == 1.0 for n in PARAM_SPECS[profile]
               if n not in table)


def test_a_value_outside_the_documented_range_gets_a_note_naming_unit_and_range():
    notes = range_notes("ardupilot", {"WPNAV_SPEED": 2500.0, "WPNAV_ACCEL": 250.0})
    assert notes == ("WPNAV_SPEED 2500 cm/s is outside the documented range 20-2000: "
                     "check that the vehicle accepts it",)
    assert range_notes("px4", {"NAV_ACC_RAD": 0.05, "MPC_JERK_AUTO": 80.0}) == ()


def test_an_unknown_autopilot_is_an_input_error():
    with pytest.raises(InputError, match="unknown 'inav'"):
        param_table("inav")


def test_profiles_take_their_speed_accel_and_jerk_from_the_vehicle_limits():
    limits = VehicleLimits(speed_mps=7.5, accel_mps2=3.25, jerk_mps3=2.0, alt_amsl_m=600.0)
    ardu = make_profile("arducopter", limits).params
    assert (ardu["WPNAV_SPEED"], ardu["WPNAV_ACCEL"], ardu["WPNAV_JERK"]) == (750.0, 325.0, 2.0)
    assert ardu["ALT_AMSL"] == 600.0 and ardu["VEHICLE_SPEED_MAX"] == 7.5
    assert ardu["WPNAV_RADIUS"] == ardupilot.PARAMS["WPNAV_RADIUS"].default
    p = make_profile("px4", limits).params
    assert (p["MPC_XY_CRUISE"], p["MPC_ACC_HOR"], p["MPC_JERK_AUTO"]) == (7.5, 3.25, 2.0)


def test_zero_is_accepted_only_where_it_is_a_setting():
    limits = VehicleLimits(10.0, 2.5, 1.0)
    assert make_profile("arducopter", limits, {"WPNAV_ACCEL_C": 0}).params["WPNAV_ACCEL_C"] == 0
    with pytest.raises(InputError, match="WPNAV_ACCEL: must be a number > 0"):
        make_profile("arducopter", limits, {"WPNAV_ACCEL": 0})


def test_the_simulated_vehicle_serves_each_parameter_as_the_table_types_it():
    table = ParamTable(VehicleConfig(home=(47.0, 8.0, 500.0)), VehicleLimits(10.4, 2.5, 1.0))
    served = {n: int(t) for n, (_, t) in table.values.items() if n in ardupilot.PARAMS}
    assert served == {n: ardupilot.PARAMS[n].mav_type for n in served}
    assert {"ANGLE_MAX", "RTL_ALT", "FENCE_ACTION", "WPNAV_SPEED"} <= set(served)
    # ArduCopter's own defaults, but a report-only fence so that every breach shows
    assert table.value("WPNAV_SPEED") == 1000.0 and table.value("FENCE_ACTION") == 0.0


def test_the_tables_cover_both_autopilots_and_every_range_is_ordered():
    assert set(PARAM_TABLES) == {"ardupilot", "px4"}
    for table in PARAM_TABLES.values():
        assert all(s.minimum <= s.maximum and not math.isnan(s.default) for s in table.values())
