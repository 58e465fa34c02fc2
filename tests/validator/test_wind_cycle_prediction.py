"""The report's predicted cycle in wind, pinned to real flights: the seventh campaign's plans
(plan-mission's, made for their wind with the wind corner lag) replayed by today's model
against their ArduCopter 4.5.6 SITL flights in that wind
(``tests/data/arducopter-sitl-wind/flights-wind-corners.json``; the plans and their parameter
files in ``wind-corners-plans.json.gz``, as plan-mission wrote them)."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np

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


def _predicted_over_flown() -> np.ndarray:
    """Per windy flight of a plan made for its wind: the replayed cycle over the flown one."""
    plans = json.loads(gzip.decompress((DATA / "wind-corners-plans.json.gz").read_bytes()))
    flights = json.loads((DATA / "flights-wind-corners.json").read_text())
    out = []
    for f in flights:
        if f["plan"] != "aware" or f["wind_speed_mps"] <= 0:
            continue
        files = plans[f"{f['site']} {f['wind']}"]
        site = load_site(SITES[f["site"]]).with_limits(wind=parse_wind_arg(f["wind"]))
        replayed = replay_plan(loads_plan(files["plan"]), site,
                               params=parse_params(files["param"]))
        assert replayed.report.cycle is not None
        out.append(replayed.report.cycle.flown_cycle_s / f["flown_cycle_s"])
    return np.array(out)


def test_the_predicted_cycle_is_within_3_percent_of_the_flown_one():
    ratio = _predicted_over_flown()
    assert len(ratio) >= 20
    # one miss: orchard in 8 m/s from 45° flew 5 % early (README, Wind: corners that shed drag)
    assert np.sum(np.abs(ratio - 1) <= 0.03) >= len(ratio) - 1, np.round(ratio, 3)
    assert abs(np.mean(ratio) - 1) <= 0.005  # unbiased


def test_without_the_wind_corner_lag_the_prediction_is_early(monkeypatch):
    monkeypatch.setattr(arducopter, "CORNER_WIND_LAG_S_PER_MPS2", 0.0)
    ratio = _predicted_over_flown()
    assert np.mean(ratio) - 1 < -0.005, np.round(ratio, 3)
    assert np.sum(np.abs(ratio - 1) <= 0.03) <= len(ratio) - 3  # 3.9-4.0 % early at 7-8 m/s
