"""The ``px4`` replay against real PX4 v1.15.4 SIH flights of our plans (tests/data/px4-sih).

Pins the calibration: the replay at the parameters each flight was flown with predicts its
service cycle within 3 % (the interop target), its whole mission from takeoff to disarm within
6 %, and, for plans timed with PX4's model, the min rate the nodes got within 5 %.
"""

from __future__ import annotations

import pytest

from tests.validator import px4_flights
from validator.motion.limits import site_limits
from validator.motion.profile import flown_params, make_profile
from validator.replay import TrackReport, replay, score_track

FLIGHTS = px4_flights.names()


def _scored(name: str) -> tuple[px4_flights.Px4Flight, TrackReport, TrackReport, float]:
    f = px4_flights.load(name)
    profile = make_profile("px4", site_limits(f.site), flown_params("px4", f.params))
    modelled = replay(f.flight, profile)
    return (f, score_track(modelled, f.flight, f.site, f.plan),
            score_track(f.track(), f.flight, f.site, f.plan), float(modelled.t_s[-1]))


def test_there_are_flights_to_calibrate_on():
    assert len(FLIGHTS) >= 10


@pytest.mark.parametrize("name", FLIGHTS)
def test_the_replay_predicts_the_flown_cycle(name):
    _, model, flown = _scored(name)[:3]
    assert model.cycle is not None and flown.cycle is not None
    assert model.cycle.flown_cycle_s == pytest.approx(flown.cycle.flown_cycle_s, rel=0.03)


# realistic-shifts-nolock drifted 2.9 m off its outbound transit and PX4 stopped three times to
# re-aim at the line (FlightTaskAuto's off-track state, tests/data/px4-sih/README.md): the model
# flies along the path, so it puts that mission 7 % short. Strict: a model that learns it passes.
OFF_TRACK = pytest.mark.xfail(strict=True, reason="PX4's off-track re-aiming is not modelled")


@pytest.mark.parametrize("name", [pytest.param(n, marks=OFF_TRACK)
                                  if n == "realistic-shifts-nolock" else n for n in FLIGHTS])
def test_the_replay_predicts_the_whole_mission(name):
    f, _, _, end_s = _scored(name)
    assert end_s == pytest.approx(f.mission_s, rel=0.06)


@pytest.mark.parametrize("name", [n for n in FLIGHTS if "px4timed" in n])
def test_px4_timed_plans_keep_their_period(name):
    flown = _scored(name)[2]
    assert flown.cycle is not None
    assert flown.cycle.ratio == pytest.approx(1.0, abs=0.05)


# The paper's site (T = 50 s, 1-second slots) is left out: a second's shift moves service from
# one node to the next, and its min rate is not a realistic-site target.
@pytest.mark.parametrize("name", [n for n in FLIGHTS
                                  if n.endswith("px4timed") and not n.startswith("sample")])
def test_px4_timed_plans_deliver_the_planned_rates(name):
    f, model, flown, _ = _scored(name)
    assert flown.throughput is not None and model.throughput is not None
    assert model.throughput.flown_min == pytest.approx(flown.throughput.flown_min, rel=0.05)
    assert flown.throughput.flown_min >= 0.97 * flown.throughput.planned_min
