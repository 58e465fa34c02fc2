"""One type for "which autopilot": the MAV_AUTOPILOT number carries its --autopilot word, flight
model, parameter table and geofence rules, so no module maps one name to another."""

from __future__ import annotations

import pytest

from validator.autopilot.fence import ARDUPILOT_FENCE, PX4_FENCE
from validator.autopilot.tables import param_table
from validator.errors import InputError
from validator.motion.profile import PROFILES
from validator.plan_format import Autopilot, Plan
from validator.validation import default_profile_name


def _plan(firmware: int) -> Plan:
    return Plan(items=[], home_lat_deg=0.0, home_lon_deg=0.0, home_alt_m=0.0,
                firmware_type=firmware)


@pytest.mark.parametrize(("autopilot", "key", "profile", "fence", "mavlink_id"), [
    (Autopilot.ARDUPILOTMEGA, "ardupilot", "arducopter", ARDUPILOT_FENCE, 3),
    (Autopilot.PX4, "px4", "px4", PX4_FENCE, 12),
])
def test_each_autopilot_carries_its_words_and_rules(autopilot, key, profile, fence, mavlink_id):
    assert autopilot.key == key and Autopilot.named(key) is autopilot
    assert autopilot.profile_name == profile and profile in PROFILES
    assert autopilot.fence_rules is fence
    assert autopilot.param_table is param_table(key)
    assert autopilot.mavlink_id == mavlink_id and Autopilot.known(mavlink_id) is autopilot
    assert Autopilot.of(_plan(mavlink_id)) is autopilot
    assert default_profile_name(_plan(mavlink_id)) == profile


def test_a_plan_of_another_firmware_is_flown_by_ardupilot_rules_but_is_not_known():
    assert Autopilot.of(_plan(int(Autopilot.GENERIC))) is Autopilot.ARDUPILOTMEGA
    assert Autopilot.of(_plan(8)) is Autopilot.ARDUPILOTMEGA
    assert Autopilot.known(0) is None and Autopilot.known(8) is None
    assert Autopilot.GENERIC.label == "MAV_AUTOPILOT 0" and Autopilot.PX4.label == "PX4"


def test_an_unknown_autopilot_word_is_bad_input():
    with pytest.raises(InputError, match="autopilot: unknown 'inav'"):
        Autopilot.named("inav")
