"""ArduCopter's sharp corners, pinned to real flights: the model's time from each corner flown
through to the next agrees with ArduCopter 4.5.6 SITL's (tests/data/arducopter-corners)
within 0.2 s at every turn from 20 to 178° at 6 and 10 m/s, and would not without the
corner lag."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from validator.api import replay_plan
from validator.motion import arducopter
from validator.plan_format import read_plan
from validator.replay.track import Track
from validator.site import load_site
from validator.track_file import read_track

DATA = Path(__file__).resolve().parents[1] / "data" / "arducopter-corners"
NEAR_M = 15.0  # a pass by a waypoint: the samples within this of it


def _passes_s(track: Track, waypoints: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """When the track comes closest to each waypoint in turn (s)."""
    out, after = [], 0
    for w in waypoints:
        d = np.hypot(*(track.xy_m[after:] - w).T)
        near = np.flatnonzero(d < NEAR_M)
        assert near.size, f"the track never passes {w}"
        run = near[: int(np.argmax(np.diff(near) > 1)) + 1] if np.any(np.diff(near) > 1) \
            else near
        k = after + int(run[np.argmin(d[run])])
        out.append(track.t_s[k])
        after = k + 1
    return np.array(out)


def _corner_legs_s(speed: int) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                        NDArray[np.float64]]:
    """Per leg between two corners flown through: its turn at the start (degrees), and the
    flown and the modelled time from one corner to the next (s)."""
    plan = read_plan(DATA / f"corners-{speed}mps.plan")
    site = load_site(DATA / "site.yaml")
    replayed = replay_plan(plan, site, profile="arducopter")
    flown = read_track(DATA / f"flown-{speed}mps.csv.gz").track(replayed.flight, site)
    legs = [leg for leg in replayed.flight.legs if leg.length_m > 1.0]
    wps = [legs[0].start_xy_m] + [leg.end_xy_m for leg in legs[:-1]]  # not the way home
    tf, tm = _passes_s(flown, wps), _passes_s(replayed.track, wps)
    turns = []
    for k in range(1, len(wps) - 1):
        u, v = wps[k] - wps[k - 1], wps[k + 1] - wps[k]
        turns.append(np.degrees(np.arccos(np.clip(u @ v / np.hypot(*u) / np.hypot(*v), -1, 1))))
    # between corners 1..8: each leg starts and ends in a corner flown through
    return np.array(turns[:-1]), np.diff(tf)[1:-1], np.diff(tm)[1:-1]


@pytest.mark.parametrize("speed", [10, 6])
def test_the_model_times_every_corner_as_the_vehicle_flew_it(speed):
    turns, flown, model = _corner_legs_s(speed)
    assert turns.min() < 30 and turns.max() > 160  # gentle to nearly back
    assert np.all(np.abs(flown - model) <= 0.2), np.round(flown - model, 2)


def test_without_the_corner_lag_the_sharp_corners_come_late(monkeypatch):
    monkeypatch.setattr(arducopter, "CORNER_LAG_S_PER_MPS_DEG", 0.0)
    turns, flown, model = _corner_legs_s(10)
    assert np.max(flown - model) > 0.6  # the 150-178° corners, at 10 m/s
