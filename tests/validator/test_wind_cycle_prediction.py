"""The report's predicted cycle and rates in wind, pinned to real flights: the plans of two
campaigns replayed by today's model against their ArduCopter 4.5.6 SITL flights in the wind
each was made for (``tests/data/arducopter-sitl-wind``): the seventh (plan-mission's plans at
a92f119, ``flights-wind-corners.json``, plans and parameter files in
``wind-corners-plans.json.gz``), the eighth (at 13d9dac, with the speed change at a corner:
``flights-speed-change.json``, ``speed-change-plans.json.gz``), the ninth (at 7129cd1, the
berth's probe: ``flights-probe.json``, ``probe-plans.json.gz``), the eleventh (at 1b07209,
legs commanded the airspeed held through the gusts: ``flights-gusts.json``,
``gusts-plans.json.gz``), the twelfth (at 87065f4, slots laid where the model flies each
leg: ``flights-slots.json``, ``slots-plans.json.gz``), the thirteenth (at 09d47c5, a speed
change at a corner only as far as half the S-curve's constant part takes it:
``flights-reach.json``, ``reach-plans.json.gz``), the fourteenth (at 0aec2f3, the lean
limit with the SITL quad's drag per body axis: ``flights-drag.json``, ``drag-plans.json.gz``,
which also holds each site's still-air plan, ``"SITE still"``, flown in every wind: the
what-if of a plan flown in a wind it was not made for), the fifteenth (at 8560329, the
still-air path searched from the start that fits better: ``flights-starts.json``,
``starts-plans.json.gz``) and the sixteenth (at a27015f, the berth's probe ending at its
first fit: ``flights-first-fit.json``, ``first-fit-plans.json.gz``), as plan-mission wrote
them."""

from __future__ import annotations

import gzip
import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from validator.api import Replayed, load_site, replay_plan
from validator.autopilot.param_file import parse_params
from validator.motion import arducopter, arducopter_speed
from validator.plan_format import loads_plan
from validator.wind import parse_wind_arg

DATA = Path(__file__).resolve().parents[1] / "data" / "arducopter-sitl-wind"
ROOT = DATA.parents[2]
SITES = {"realistic": ROOT / "samples" / "realistic.yaml",
         "orchard": DATA / "sites" / "orchard.yaml",
         "harbour": DATA / "sites" / "harbour.yaml"}


CAMPAIGNS = {"seventh": ("flights-wind-corners.json", "wind-corners-plans.json.gz"),
             "eighth": ("flights-speed-change.json", "speed-change-plans.json.gz"),
             "ninth": ("flights-probe.json", "probe-plans.json.gz"),
             "eleventh": ("flights-gusts.json", "gusts-plans.json.gz"),
             "twelfth": ("flights-slots.json", "slots-plans.json.gz"),
             "thirteenth": ("flights-reach.json", "reach-plans.json.gz"),
             "fourteenth": ("flights-drag.json", "drag-plans.json.gz"),
             "fifteenth": ("flights-starts.json", "starts-plans.json.gz"),
             "sixteenth": ("flights-first-fit.json", "first-fit-plans.json.gz")}
# Flights whose predicted cycle missed the flown one by over 3 %: none since the vehicle leans
# to its limit with the SITL quad's drag, per body axis (docs/wind-campaigns.md, *Wind, drag
# per body axis*);
# before, the eighth's and the thirteenth's orchard in 8 m/s from 45° (3.1 and 3.2 % early:
# a leg across the wind that the model held to less than the quad leans to) and the ninth's
# realistic in 7 m/s from 315°, turbulence 2 (3.1 % late: upwind legs at the lean limit gave
# speed to the gusts that the model's lean limit did not)
CYCLE_MISSES = {"seventh": 0, "eighth": 0, "ninth": 0, "eleventh": 0, "twelfth": 0,
                "thirteenth": 0, "fourteenth": 0, "fifteenth": 0, "sixteenth": 0}


def _replays(campaign: str, kind: str) -> Iterator[tuple[dict, Replayed]]:
    """Each windy flight of ``campaign`` flying a plan of ``kind`` ("aware": made for its
    wind; "blind": the site's still-air plan, pinned as "SITE still"), with that plan's
    replay in the wind flown."""
    flights_file, plans_file = CAMPAIGNS[campaign]
    plans = json.loads(gzip.decompress((DATA / plans_file).read_bytes()))
    flights = json.loads((DATA / flights_file).read_text())
    for f in flights:
        if f["plan"] != kind or f["wind_speed_mps"] <= 0:
            continue
        files = plans[f"{f['site']} {f['wind'] if kind == 'aware' else 'still'}"]
        site = load_site(SITES[f["site"]]).with_limits(wind=parse_wind_arg(f["wind"]))
        yield f, replay_plan(loads_plan(files["plan"]), site, params=parse_params(files["param"]))


def _replayed_against_flown(campaign: str) -> tuple[np.ndarray, np.ndarray]:
    """Per windy flight of a plan made for its wind: the replayed cycle over the flown one, and
    the flown min rate over the replayed one (the report's)."""
    cycles, rates = [], []
    for f, replayed in _replays(campaign, "aware"):
        assert replayed.report.cycle is not None and replayed.report.throughput is not None
        cycles.append(replayed.report.cycle.flown_cycle_s / f["flown_cycle_s"])
        rates.append(f["flown_min_rate_bps_hz"] / replayed.report.throughput.flown_min)
    return np.array(cycles), np.array(rates)


@pytest.mark.parametrize("campaign", list(CAMPAIGNS))
def test_the_predicted_cycle_is_within_3_percent_of_the_flown_one(campaign):
    ratio, _ = _replayed_against_flown(campaign)
    assert len(ratio) >= 20
    assert np.sum(np.abs(ratio - 1) <= 0.03) >= len(ratio) - CYCLE_MISSES[campaign], \
        np.round(ratio, 3)
    # unbiased: every campaign's mean is 0.997-0.998 (the model times a cycle 0.2-0.3 % short,
    # a tenth of the target); 0.9969 for the fifteenth, the first past 0.003
    assert abs(np.mean(ratio) - 1) <= 0.004, np.round(ratio, 3)


# Flights whose worst node got less than 0.97 of the report's rate: the eighth's and the
# eleventh's orchard in 8 m/s from 0° (0.969 and 0.968; both flown 1.2-1.3 % early). Before
# the drag per body axis there were 7 (0.955-0.969) of the 126, the orchard flights in 8 m/s
# from 0° and 45° and harbour in 8 m/s from 45°, all flown early
RATE_MISSES = {"seventh": 0, "eighth": 1, "ninth": 0, "eleventh": 1, "twelfth": 0,
               "thirteenth": 0, "fourteenth": 0, "fifteenth": 0, "sixteenth": 0}


@pytest.mark.parametrize("campaign", list(CAMPAIGNS))
def test_the_flown_min_rate_is_at_least_0_97_of_the_reported_one(campaign):
    _, ratio = _replayed_against_flown(campaign)
    assert np.sum(ratio >= 0.97) >= len(ratio) - RATE_MISSES[campaign], np.round(ratio, 3)
    assert np.min(ratio) >= 0.965, np.round(ratio, 3)


def test_without_the_corner_speed_change_cycle_and_rates_are_predicted_worse(monkeypatch):
    monkeypatch.setattr(arducopter, "corner_first_speeds_mps",
                        lambda speed, built, after, gain: speed)
    cycle, rate = _replayed_against_flown("seventh")
    assert np.mean(cycle) - 1 < -0.005, np.round(cycle, 3)
    assert np.max(np.abs(cycle - 1)) > 0.03, np.round(cycle, 3)
    assert np.sum(np.abs(cycle - 1) <= 0.02) <= len(cycle) - 3, np.round(cycle, 3)
    assert np.sum(rate >= 0.97) <= len(rate) - 2, np.round(rate, 3)


def test_with_drag_the_same_every_way_cycles_are_predicted_late(monkeypatch):
    # the lean limit held through the gusts, but the quad's drag as if it were round: legs
    # across the wind at the lean limit come out slower than SITL flies them
    monkeypatch.setattr(arducopter_speed, "SITL_QUAD_LINEAR_DRAG_SHARE", 1.0)
    cycle, _ = _replayed_against_flown("seventh")
    assert np.mean(cycle) - 1 > 0.01, np.round(cycle, 3)
    assert np.sum(np.abs(cycle - 1) <= 0.03) <= len(cycle) - 3, np.round(cycle, 3)


# Still-air plans flown in wind predicted more than 3 % off: orchard in 8 m/s from 45° (1.047,
# its home at 584 m AMSL; every orchard flight came out 1-5 % late)
WHAT_IF_MISSES = 1


def _what_if_against_flown() -> np.ndarray:
    """Per flight of the fourteenth campaign's still-air plans in wind: the cycle the replay
    predicts in the wind flown over the flown one."""
    ratio = []
    for f, replayed in _replays("fourteenth", "blind"):
        assert replayed.report.cycle is not None
        ratio.append(replayed.report.cycle.flown_cycle_s / f["flown_cycle_s"])
    return np.array(ratio)


def test_a_still_air_plan_flown_in_wind_is_predicted_within_3_percent():
    # commanded 10 m/s on every leg, the plan is overdriven on every leg into or across the
    # wind: the vehicle leans to its limit there, and the replay times it as SITL's quad flies
    ratio = _what_if_against_flown()
    assert len(ratio) >= 20
    assert np.sum(np.abs(ratio - 1) <= 0.03) >= len(ratio) - WHAT_IF_MISSES, np.round(ratio, 3)


def test_with_drag_the_same_every_way_the_what_if_comes_out_late(monkeypatch):
    monkeypatch.setattr(arducopter_speed, "SITL_QUAD_LINEAR_DRAG_SHARE", 1.0)
    ratio = _what_if_against_flown()
    assert np.max(ratio) > 1.08, np.round(ratio, 3)
    assert np.sum(np.abs(ratio - 1) <= 0.03) <= len(ratio) - 5, np.round(ratio, 3)
