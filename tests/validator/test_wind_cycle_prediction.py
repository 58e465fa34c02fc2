"""The report's predicted cycle and rates in wind, pinned to real flights: the seventh
campaign's plans (plan-mission's at a92f119, made for their wind) replayed by today's model
against their ArduCopter 4.5.6 SITL flights in that wind
(``tests/data/arducopter-sitl-wind/flights-wind-corners.json``; the plans and their parameter
files in ``wind-corners-plans.json.gz``, as plan-mission wrote them)."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pytest

from validator.api import load_site, replay_plan
from validator.autopilot.param_file import parse_params
from validator.motion import arducopter
from validator.plan_format import loads_plan
from validator.wind import parse_wind_arg

DATA = Path(__file__).resolve().parents[1] / "data" / "arducopter-sitl-wind"
ROOT = DATA.parents[2]
SITES = {"realistic": ROOT / "samples" / "realistic.yaml",
         "orchard": DATA / "sites" / "orchard.yaml",
         "harbour": DATA / "sites" / "harbour.yaml"}


def _replayed_against_flown() -> tuple[np.ndarray, np.ndarray]:
    """Per windy flight of a plan made for its wind: the replayed cycle over the flown one, and
    the flown min rate over the replayed one (the report's)."""
    plans = json.loads(gzip.decompress((DATA / "wind-corners-plans.json.gz").read_bytes()))
    flights = json.loads((DATA / "flights-wind-corners.json").read_text())
    cycles, rates = [], []
    for f in flights:
        if f["plan"] != "aware" or f["wind_speed_mps"] <= 0:
            continue
        files = plans[f"{f['site']} {f['wind']}"]
        site = load_site(SITES[f["site"]]).with_limits(wind=parse_wind_arg(f["wind"]))
        replayed = replay_plan(loads_plan(files["plan"]), site,
                               params=parse_params(files["param"]))
        assert replayed.report.cycle is not None and replayed.report.throughput is not None
        cycles.append(replayed.report.cycle.flown_cycle_s / f["flown_cycle_s"])
        rates.append(f["flown_min_rate_bps_hz"] / replayed.report.throughput.flown_min)
    return np.array(cycles), np.array(rates)


def _without_the_corner_speed_change(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(arducopter, "corner_first_speeds_mps",
                        lambda speed, built, after, gain: speed)


def test_the_predicted_cycle_is_within_3_percent_of_the_flown_one():
    ratio, _ = _replayed_against_flown()
    assert len(ratio) >= 20
    # one miss: orchard in 8 m/s from 45° flew 4.5 % early (README, Wind: the speed change
    # at a corner)
    assert np.sum(np.abs(ratio - 1) <= 0.03) >= len(ratio) - 1, np.round(ratio, 3)
    assert abs(np.mean(ratio) - 1) <= 0.003  # unbiased


def test_the_flown_min_rate_is_at_least_0_97_of_the_reported_one():
    _, ratio = _replayed_against_flown()
    assert np.sum(ratio >= 0.97) >= len(ratio) - 1, np.round(ratio, 3)


def test_without_the_corner_speed_change_cycle_and_rates_are_predicted_worse(monkeypatch):
    _without_the_corner_speed_change(monkeypatch)
    cycle, rate = _replayed_against_flown()
    assert np.mean(cycle) - 1 < -0.005, np.round(cycle, 3)
    assert np.sum(np.abs(cycle - 1) <= 0.03) <= len(cycle) - 3, np.round(cycle, 3)
    assert np.sum(rate >= 0.97) <= len(rate) - 3, np.round(rate, 3)
