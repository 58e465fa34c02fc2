"""PX4's coast after a GPS loss (validator.coast_rules.PX4), against the flights pinned in
tests/data/failsafe/gps-loss-px4.json (PX4 v1.15.4 SIH, --fault gps-loss): every true track
stays in the modelled region, the delay and the stop are within the rule's, and the audit and
the berth use PX4's figures for a PX4 plan."""

from __future__ import annotations

import dataclasses
import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from tests.validator.builders import make_site, waypoint_plan
from tests.validator.px4_coast import outside_m
from validator.autopilot.param_file import read_params
from validator.autopilot.rules import px4_descend_s
from validator.coast_rules import ARDUCOPTER, PX4, CoastRule, coast_rule
from validator.flight import Flight, resolve_flight
from validator.plan_format import read_plan
from validator.position_loss import (
    BERTH_MARGIN_M,
    audit_position_loss,
    berth_buffer_m,
    coast_region,
    coasting_failsafe,
    worst_position_loss_point,
)
from validator.site import Site, load_site

DATA = Path(__file__).resolve().parents[1] / "data" / "failsafe"
FLIGHTS = json.loads((DATA / "gps-loss-px4.json").read_text())["flights"]


@cache
def _flown(plan: str, site: str) -> tuple[Site, Flight]:
    s = load_site(DATA / site)
    return s, resolve_flight(read_plan(DATA / plan), s, plan)


def _outside_m(fl: dict, rule: CoastRule) -> float:
    """How far (m) the pinned flight's true track went outside ``rule``'s region (0: in)."""
    _, flight = _flown(fl["plan"], fl["site"])
    return outside_m(flight, fl["commanded_speed_mps"], fl["injected_xy_m"], fl["track_xy_m"],
                     rule)


def test_the_pinned_flights_cover_fast_and_slow_legs_and_the_models_aim():
    speeds = sorted(fl["log"]["speed_mps"] for fl in FLIGHTS)
    assert len(FLIGHTS) >= 4 and speeds[0] < 2.5 and speeds[-1] > 8.0, speeds
    assert any(fl["aimed"] == "the model's worst point" for fl in FLIGHTS)
    assert any(fl["commanded_speed_mps"] == 5.0 for fl in FLIGHTS)


@pytest.mark.parametrize("i", range(len(FLIGHTS)))
def test_every_true_track_after_the_loss_stays_in_the_modelled_region(i):
    assert _outside_m(FLIGHTS[i], PX4) == 0.0


def test_the_figures_are_the_flights_worst_and_no_more():
    # each figure covers its worst flight and is no more than a metre (a tenth of a second)
    # over it: measured, not padded
    logs = [fl["log"] for fl in FLIGHTS]
    offpath = max(log["offpath_m"] for log in logs)
    wander = max(log["wander_m"] for log in logs)
    coast = max(log["stop_m"] / log["speed_mps"] for log in logs if log["speed_mps"] > 2.0)
    assert offpath <= PX4.offpath_m <= offpath + 1.0
    assert wander <= PX4.wander_m <= wander + 1.0
    assert coast <= PX4.coast_s <= coast + 0.1


@pytest.mark.parametrize("i", range(len(FLIGHTS)))
def test_px4_falls_back_to_descend_within_its_delay_and_stops_within_its_coast(i):
    fl, log = FLIGHTS[i], FLIGHTS[i]["log"]
    assert fl["modes"][0] == "LAND"  # Descend reports AUTO_LAND's custom mode
    assert fl["end_state"] == "landed"
    assert log["delay_s"] <= PX4.delay_s  # EKF2_NOAID_TOUT, from the receiver's lost fix
    assert log["offpath_m"] <= PX4.offpath_m
    assert log["wander_m"] <= PX4.wander_m
    if log["speed_mps"] > 2.0:  # a stop from speed; a hover only wanders
        assert log["stop_m"] <= PX4.coast_s * log["speed_mps"]


def test_descend_reaches_the_ground_when_the_flights_did():
    grounds = [fl["log"]["ground_s"] for fl in FLIGHTS if fl["log"]["ground_s"] is not None]
    assert grounds
    assert px4_descend_s(30.0, None) == pytest.approx(np.median(grounds), abs=1.5)


def test_the_plans_parameter_files_are_plan_missions():
    for fl in FLIGHTS:
        assert read_params(DATA / fl["params"])["COM_POSCTL_NAVL"] == 1


# -- the rule in the audit, the aim and the berth -------------------------------------------


def _flight(site: Site, points: list[tuple[float, float]], v: float) -> Flight:
    return resolve_flight(waypoint_plan(site, points, v=v), site)


def test_the_px4_region_is_the_same_shape_with_its_figures_and_its_drift_off_the_path():
    region = coast_region(np.array([0.0, 0.0]), np.array([100.0, 0.0]), 10.0, rule=PX4)
    x0, y0, x1, y1 = region.bounds
    assert x1 == pytest.approx(100.0 + PX4.coast_s * 10.0 + PX4.wander_m + PX4.offpath_m,
                               abs=0.2)
    assert y1 == pytest.approx(PX4.wander_m + PX4.offpath_m, abs=0.2)
    # off the path from the start, the wander ahead of it reaching behind it too
    assert x0 == pytest.approx(min(0.0, PX4.coast_s * 10.0 - PX4.wander_m) - PX4.offpath_m,
                               abs=0.2)


def test_a_px4_plan_is_audited_with_px4s_coast():
    # a leg 15 m beside a zone: out of ArduCopter's 12 m wander, within PX4's reach
    site = make_site(nfz=((100.0, 0.0, 20.0),), gns=((0.0, 35.0), (200.0, 35.0)),
                     buffer_m=3.0)
    flight = _flight(site, [(0.0, 35.0), (200.0, 35.0)], 5.0)
    assert ARDUCOPTER.wander_m < 15.0 < PX4.wander_m + PX4.offpath_m
    k = next(i for i, leg in enumerate(flight.legs)
             if abs(leg.start_xy_m[0]) < 1e-3 and abs(leg.end_xy_m[0] - 200.0) < 1e-3)
    assert [f for f in audit_position_loss(flight, site, {"WPNAV_SPEED": 500.0})
            if f.leg == k] == []
    found = [f for f in audit_position_loss(flight, site, {"MPC_XY_CRUISE": 5.0},
                                            autopilot="px4") if f.leg == k]
    assert found and all(f.autopilot == "px4" for f in found)
    assert "Descend" in found[0].message and "wider berth" in found[0].message
    deepest = max(-f.clearance_m for f in found)
    assert berth_buffer_m(3.0, found) == pytest.approx(3.0 + deepest + BERTH_MARGIN_M)
    # a coast deeper than the wander first asks for PX4's wander and drift off the path
    deep = [dataclasses.replace(found[0], clearance_m=-40.0)]
    assert berth_buffer_m(3.0, deep) == pytest.approx(
        PX4.wander_m + PX4.offpath_m + BERTH_MARGIN_M)
    assert coasting_failsafe("px4", None) == coast_rule("px4").failsafe == "COM_POSCTL_NAVL"


def test_a_px4_gps_loss_is_aimed_its_delay_before_the_worst_coast():
    site = make_site(nfz=((360.0, 50.0, 20.0),), gns=((0.0, 50.0), (300.0, 50.0)),
                     buffer_m=3.0)
    found = worst_position_loss_point(_flight(site, [(0.0, 50.0), (300.0, 50.0)], 10.0),
                                      site, {"MPC_XY_CRUISE": 10.0}, autopilot="px4")
    assert found is not None
    xy, clearance = found
    assert clearance == pytest.approx(
        360.0 - 300.0 - PX4.coast_s * 10.0 - 20.0 - PX4.wander_m - PX4.offpath_m, abs=0.5)
    assert xy == pytest.approx([300.0 - PX4.delay_s * 10.0, 50.0], abs=1.0)
