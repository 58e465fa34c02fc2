"""Flight rules: how each autopilot keeps holds, when a slot stands still, corner radius range."""

import numpy as np
import pytest

from validator.autopilot.rules import (
    acceptance_radius_m,
    programmed_holds_s,
    stored_hold_s,
)
from validator.motion.arducopter import scurve_limits
from validator.motion.limits import GRAVITY_MPS2, VehicleLimits
from validator.motion.profile import make_profile


@pytest.mark.parametrize("hold, ardupilot, px4", [(2.7, 2.0, 2.7), (3.0 - 1e-12, 3.0, 3.0 - 1e-12),
                                                  (0.4, 0.0, 0.4)])
def test_ardupilot_truncates_a_hold_to_whole_seconds_px4_keeps_it(hold, ardupilot, px4):
    assert stored_hold_s(hold, "ardupilot") == ardupilot
    assert stored_hold_s(hold, "px4") == px4


def test_programmed_holds_are_whole_for_ardupilot_only():
    planned = np.array([1.3, 2.4, 0.0, 5.9])
    ardu = programmed_holds_s(planned, "ardupilot")
    assert np.all(ardu == np.round(ardu)) and abs(ardu.sum() - planned.sum()) < 0.5
    assert np.array_equal(programmed_holds_s(planned, "px4"), planned)


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
@pytest.mark.parametrize("wanted, radius", [(0.01, 0.05), (1.3, 1.3), (5.0, 2.0), (-1.0, 0.05)])
def test_the_acceptance_radius_lies_between_the_minimum_and_the_default(autopilot, wanted,
                                                                        radius):
    assert acceptance_radius_m(wanted, autopilot) == pytest.approx(radius)


def test_arducopter_scurve_acceleration_is_capped_by_the_lean_angle():
    limits = VehicleLimits(speed_mps=12.0, accel_mps2=10.0, jerk_mps3=4.0)
    lim = scurve_limits(make_profile("arducopter", limits, {"ANGLE_MAX": 3000}))
    assert lim.accel_mps2 == pytest.approx(GRAVITY_MPS2 * np.tan(np.radians(30.0)))
    assert lim.jerk_mps3 == 4.0 and lim.default_speed_mps == pytest.approx(12.0)
    assert lim.top_speed_mps < 12.0  # the SITL quad's drag holds it near 10 m/s
    gentle = scurve_limits(make_profile("arducopter", limits, {"WPNAV_ACCEL": 200}))
    assert gentle.accel_mps2 == pytest.approx(2.0)
