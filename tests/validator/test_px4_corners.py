"""The ``px4`` replay against PX4 v1.15.4 SIH flights through pass-through corners
(tests/data/px4-corners): what holds (cycle and leg times) and what the model lacks (the swing
outside a corner), from the recorded flights' summaries.

The replay is flown here from each flight's own plan and parameters; only the flown side is
stored (``flown.json``, :func:`tests.validator.px4_corners.flown_summary`).
"""

from __future__ import annotations

import pytest

from mission_planner.optimize.corners import PX4_MAX_TURN_DEG
from tests.validator import px4_corners
from validator.motion.limits import site_limits
from validator.motion.profile import flown_params, make_profile
from validator.motion.px4_swing import swing_width_m
from validator.replay import replay

ALL_FLIGHTS = px4_corners.names()
# the turns the px4 model is timed for (the planner flies no sharper one through)
FLIGHTS = [n for n in ALL_FLIGHTS if all(c["turn_deg"] <= PX4_MAX_TURN_DEG
                                         for c in px4_corners.load(n).flown["corners"].values())]
SHARP = [n for n in ALL_FLIGHTS if n not in FLIGHTS]
WITH_CORNERS = [n for n in ALL_FLIGHTS if px4_corners.load(n).flown["corners"]]


def _modelled(name: str) -> tuple[px4_corners.CornerFlight, dict, dict]:
    f = px4_corners.load(name)
    profile = make_profile("px4", site_limits(f.site), flown_params("px4", f.params))
    model = px4_corners.flown_summary(f.flight, f.site, f.plan, replay(f.flight, profile))
    return f, model, f.flown


def _corners(name: str) -> list[tuple[float, dict, dict]]:
    """(NAV_ACC_RAD, modelled, flown) per corner of a flight."""
    f, model, flown = _modelled(name)
    assert model["corners"].keys() == flown["corners"].keys()
    return [(f.params["NAV_ACC_RAD"], model["corners"][k], flown["corners"][k])
            for k in flown["corners"]]


def test_there_are_corners_to_calibrate_on():
    assert len(WITH_CORNERS) >= 3
    assert sum(len(px4_corners.load(n).flown["corners"]) for n in FLIGHTS) >= 5


@pytest.mark.parametrize("name", FLIGHTS)
def test_the_replay_predicts_the_cycle_flown_through_corners(name):
    _, model, flown = _modelled(name)
    assert model["cycle_s"] == pytest.approx(flown["cycle_s"], rel=0.03)


@pytest.mark.parametrize("name", FLIGHTS)
def test_the_replay_times_the_way_through_each_corner(name):
    # from the start of the leg into the corner to the next waypoint: SIH took 0.4-1.9 s (1-4 %)
    # longer than the model (it turned a 55° corner at 1.6 m/s where the model's corner speed is
    # 1.9), and up to 1.3 s more on a leg leaving a stop (one leg 5.4 % long)
    for _, model, flown in _corners(name):
        assert model["in_s"] + model["out_s"] == pytest.approx(flown["in_s"] + flown["out_s"],
                                                               rel=0.05)


def test_sharper_turns_fly_slower_than_the_replay_times_them():
    # why the planner flies no turn sharper than PX4_MAX_TURN_DEG through: samples/realistic
    # flown through 77-137° turns took 1.054 T on SIH where the replay said 1.000 T
    assert SHARP
    for name in SHARP:
        _, model, flown = _modelled(name)
        assert flown["cycle_s"] > 1.03 * model["cycle_s"]


@pytest.mark.parametrize("name", ALL_FLIGHTS)
def test_px4_passes_its_corners_within_the_acceptance_radius(name):
    # PX4 passed within NAV_ACC_RAD of every waypoint, and strayed from the two legs by at
    # most NAV_ACC_RAD on either side of every corner but one: a 16° turn of rs1-planned,
    # 1.56 m outside (NAV_ACC_RAD 1.5; 1.54 m on an earlier flight), hence the swing region's
    # margin (validator.motion.px4_swing.SWING_MARGIN_M)
    for radius_m, _, flown in _corners(name):
        assert flown["closest_m"] < radius_m
        assert max(flown["inside_m"], flown["outside_m"]) < swing_width_m(radius_m)


SWING = pytest.mark.xfail(strict=True, reason=(
    "PX4 overshoots a pass-through corner to the outside (0.6-1.3 m at 12-60° turns on SIH) and "
    "comes back onto the next leg; the px4 replay rounds the corner inside NAV_ACC_RAD instead"))


@SWING
@pytest.mark.parametrize("name", WITH_CORNERS)
def test_the_replay_swings_outside_a_corner_as_px4_does(name):
    for _, model, flown in _corners(name):
        assert model["outside_m"] == pytest.approx(flown["outside_m"], abs=0.3)
