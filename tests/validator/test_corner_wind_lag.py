"""ArduCopter's sharp corners in wind, pinned to a real flight: from upwind at the air-speed cap
into downwind, the drag falls and the corner lags beyond its still-air lag
(:func:`validator.motion.arducopter.corner_wind_lag_s`). The realistic site's plan for 7 m/s
from 315° (turbulence 2 m/s), flown on ArduCopter 4.5.6 SITL in that wind
(tests/data/arducopter-sitl-wind/corner-wind)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from validator.api import replay_plan
from validator.autopilot.param_file import read_params
from validator.motion import arducopter
from validator.motion.arducopter import corner_wind_lag_s, drag_accel_mps2
from validator.motion.limits import SITL_QUAD_DRAG_PER_M, VehicleLimits
from validator.motion.profile import make_profile
from validator.plan_format import read_plan
from validator.site import load_site
from validator.track_file import read_track
from validator.wind import Wind

DATA = Path(__file__).resolve().parents[1] / "data" / "arducopter-sitl-wind" / "corner-wind"
# The two sharp corners from upwind into downwind: (item of the upwind leg's waypoint, item of
# the downwind leg's), the corner between them flown through
CORNERS = ((9, 11), (23, 25))
# The upwind leg into item 9 cruised at 2.90 m/s of its 3.04 commanded (the turbulence at the
# air-speed cap): 2.0 s the model does not claim, on top of the corner
SHORTFALL_S = 2.0


def _two_leg_times_s() -> tuple[np.ndarray, np.ndarray]:
    """Per corner: the flown and the modelled time (s) of the two legs either side of it."""
    plan = read_plan(DATA / "realistic-7at315.plan")
    site = load_site(DATA / "site.yaml").with_limits(wind=Wind(7.0, 315.0, 2.0))
    replayed = replay_plan(plan, site, params=read_params(DATA / "realistic-7at315.param"))
    flight = replayed.flight
    flown = read_track(DATA / "realistic-7at315.track.csv.gz").track(flight, site)
    out = []
    for corner, after in CORNERS:
        k = next(i for i, leg in enumerate(flight.legs) if leg.item == after)
        assert flight.legs[k - 1].item == corner and flight.legs[k - 1].pass_through
        span = slice(k - 2, k + 1, 2)  # reached before the upwind leg, and after the downwind
        out.append((np.diff(flown.leg_reached_s[span])[0],
                    np.diff(replayed.track.leg_reached_s[span])[0]))
    return tuple(np.array(x) for x in zip(*out, strict=True))  # type: ignore[return-value]


def test_the_model_times_both_wind_corners_as_the_vehicle_flew_them():
    flown, model = _two_leg_times_s()
    late = flown - model
    assert late[0] == pytest.approx(SHORTFALL_S, abs=0.5), late
    assert abs(late[1]) <= 0.5, late


def test_without_the_wind_lag_the_corners_come_late(monkeypatch):
    monkeypatch.setattr(arducopter, "CORNER_WIND_LAG_S_PER_MPS2", 0.0)
    flown, model = _two_leg_times_s()
    late = flown - model
    assert late[0] - SHORTFALL_S > 2.5 and late[1] > 1.2, late


def _sitl_profile(wind: Wind):
    return make_profile("arducopter", VehicleLimits(10.0, 2.5, 1.0, 0.0, wind.speed_mps,
                                                    wind.from_deg))


def test_drag_grows_with_the_square_of_the_airspeed():
    prof = _sitl_profile(Wind(6.0, 270.0))  # from the west: blows east
    drag = drag_accel_mps2(prof, [[6.0, 0.0], [0.0, 0.0], [-4.0, 0.0]])
    assert drag == pytest.approx(SITL_QUAD_DRAG_PER_M * np.array([0.0, 36.0, 100.0]))


def test_only_a_fall_in_drag_lags():
    lag = corner_wind_lag_s([160.0] * 3, [5.0, 2.0, 3.0], [1.0, 4.0, 3.0])
    assert lag == pytest.approx([4.0 * arducopter.CORNER_WIND_LAG_S_PER_MPS2, 0.0, 0.0])


def test_only_a_sharp_corner_lags_in_wind():
    lag = corner_wind_lag_s([30.0, arducopter.CORNER_LAG_FREE_DEG, 100.0], [5.0] * 3, [1.0] * 3)
    assert lag == pytest.approx([0.0, 0.0, 4.0 * arducopter.CORNER_WIND_LAG_S_PER_MPS2])
