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


class _Climbing:
    """A vehicle whose first take-off was accepted with its ACK lost: it climbs, and refuses
    every take-off asked of it after."""

    def __init__(self) -> None:
        self.armed = True
        self.t_s = 10.0
        self.rows = [(10.0, 0.0, 0.0, 0.0)]

    def pump(self, until: float, done: object) -> bool:
        self.t_s += 1.0
        self.rows.append((self.t_s, 0.0, 0.0, 1.5 * (self.t_s - 10.0)))  # 1.5 m/s up
        return False


def test_a_take_off_whose_ack_was_lost_is_not_asked_again_until_the_patience_runs_out():
    from validator.mavlink.driver import _arm_and_take_off

    link, rec = _Refusing(["Arming motors"]), _Climbing()
    assert _arm_and_take_off(link, rec, 30.0) == 10.0  # the first request's time
    assert link.asked == 2  # once more after the climb began, then no more


def test_a_vehicle_still_on_the_ground_is_asked_again(monkeypatch):
    import validator.mavlink.driver as driver

    class _Grounded(_Climbing):
        def pump(self, until: float, done: object) -> bool:
            self.t_s += 1.0
            self.rows.append((self.t_s, 0.0, 0.0, 0.0))
            return False

    link = _Refusing([])
    monkeypatch.setattr(driver, "ARM_PATIENCE_S", 0.05)
    with pytest.raises(LinkError, match="MAV_CMD_NAV_TAKEOFF"):
        driver._arm_and_take_off(link, _Grounded(), 30.0)
    assert link.asked >= 2
