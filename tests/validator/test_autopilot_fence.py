"""Geofence parameter rules: what switches each autopilot's fence on with a safe breach action."""

import pytest

from validator.autopilot.fence import ARDUPILOT_FENCE, PX4_FENCE


def test_recommended_ardupilot_values_have_no_problem():
    assert ARDUPILOT_FENCE.problems(ARDUPILOT_FENCE.recommended) == []


@pytest.mark.parametrize("change, complaint", [
    ({"FENCE_ENABLE": 0.0}, "FENCE_ENABLE is 0, not 1"),
    ({"FENCE_TYPE": 3.0}, "FENCE_TYPE is 3: it must include 4"),
    ({"FENCE_ACTION": 1.0}, "FENCE_ACTION is 1 (RTL or Land)"),
    ({"FENCE_ACTION": 3.0}, "FENCE_ACTION is 3 (SmartRTL or RTL or Land)"),
    ({"FENCE_ACTION": 0.0}, "FENCE_ACTION is 0 (Report Only)"),
])
def test_each_ardupilot_setting_that_leaves_the_zones_unprotected_is_named(change, complaint):
    problems = ARDUPILOT_FENCE.problems({**ARDUPILOT_FENCE.recommended, **change})
    assert len(problems) == 1 and problems[0].startswith(complaint)


def test_a_parameter_file_that_does_not_mention_the_fence_leaves_it_off():
    problems = ARDUPILOT_FENCE.problems({"WPNAV_SPEED": 1000.0})
    assert [p.split(" is ")[0] for p in problems] == ["FENCE_ENABLE", "FENCE_TYPE",
                                                      "FENCE_ACTION"]


@pytest.mark.parametrize("action, safe", [(2.0, True), (5.0, True), (3.0, False), (1.0, False)])
def test_px4_breach_actions(action, safe):
    assert (PX4_FENCE.problems({"GF_ACTION": action}) == []) is safe
