"""A command the vehicle keeps refusing ends in one line that carries the vehicle's own last
words (its STATUSTEXTs), so a refused take-off or mode says why."""

from __future__ import annotations

from collections import deque

import pytest
from pymavlink.dialects.v20 import common as mavlink

from validator.mavlink.connection import LinkError
from validator.mavlink.driver import _until_accepted


class _Refusing:
    timeout_s = 0.0

    def __init__(self, said: list[str]) -> None:
        self.statustexts = deque(said, maxlen=50)
        self.asked = 0

    def command(self, command: int, *params: float) -> int:
        self.asked += 1
        return mavlink.MAV_RESULT_FAILED


class _Idle:
    def pump(self, until: float, done: object) -> bool:
        return False


def test_a_refusal_names_what_the_vehicle_said_last():
    link = _Refusing(["PreArm: Gyros inconsistent", "EKF3 IMU0 is using GPS",
                      "Arm: Need Position Estimate", "PreArm: Need Position Estimate"])
    with pytest.raises(LinkError) as err:
        _until_accepted(link, _Idle(), mavlink.MAV_CMD_NAV_TAKEOFF, patience_s=0.0)
    text = str(err.value)
    assert "MAV_RESULT_FAILED" in text and "\n" not in text
    assert "(last: EKF3 IMU0 is using GPS; Arm: Need Position Estimate; PreArm: Need " in text
    assert "Gyros" not in text  # the last three only
    assert link.asked >= 1


def test_a_silent_vehicle_adds_nothing():
    with pytest.raises(LinkError) as err:
        _until_accepted(_Refusing([]), _Idle(), mavlink.MAV_CMD_NAV_TAKEOFF, patience_s=0.0)
    assert "last:" not in str(err.value)
