"""The position-loss (GPS loss) model: where an ArduCopter that loses its position can coast,
the legs the audit warns about, the one speed rule, and the coast measured from a track."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import shapely

from tests.validator.builders import ALT_M, make_site, waypoint_plan
from validator.autopilot.rules import failsafe_land_s
from validator.flight import resolve_flight
from validator.mavlink.faults import measure_coast
from validator.position_loss import (
    BERTH_MARGIN_M,
    COAST_S,
    DEAD_RECKONING_DELAY_S,
    DETECTION_DELAY_S,
    WANDER_M,
    _leg_region,
    audit_position_loss,
    berth_buffer_m,
    coast_region,
    coasting_failsafe,
    dead_reckons,
    drift_xy_m,
    position_loss_speed_cap_mps,
    region_clearances,
    worst_position_loss_point,
)
from validator.site import load_site
from validator.wind import Wind

REPO = Path(__file__).resolve().parents[2]


def _wpnav(speed_mps):
    """Parameters whose WPNAV_SPEED (cm/s) is ``speed_mps``."""
    return {"WPNAV_SPEED": speed_mps * 100.0}


def _flight(site, points, v):
    plan = waypoint_plan(site, points, v=v)
    return resolve_flight(plan, site)


def test_the_region_reaches_the_coast_and_the_wander_ahead_of_the_leg():
    region = coast_region(np.array([0.0, 0.0]), np.array([100.0, 0.0]), 10.0)
    x0, y0, x1, y1 = region.bounds
    assert x1 == pytest.approx(100.0 + COAST_S * 10.0 + WANDER_M, abs=0.1)
    assert y1 == pytest.approx(WANDER_M, abs=0.1) and y0 == pytest.approx(-WANDER_M, abs=0.1)
    assert x0 == pytest.approx(0.0)  # nothing behind the leg: the wander is ahead of it


def test_a_corner_sweeps_between_the_two_legs_directions():
    straight = coast_region(np.array([0.0, 0.0]), np.array([100.0, 0.0]), 10.0)
    corner = coast_region(np.array([0.0, 0.0]), np.array([100.0, 0.0]), 10.0,
                          np.array([100.0, 100.0]))
    assert corner.bounds[3] >= COAST_S * 10.0 + WANDER_M - 0.1  # ahead along the next leg
    assert corner.contains(straight)


def test_a_leg_running_at_a_zone_is_capped_and_the_cap_keeps_the_buffer():
    # the leg ends 30 m short of a zone, straight at it: at 10 m/s the coast reaches it
    site = make_site(nfz=((230.0, 50.0, 20.0),), gns=((0.0, 50.0), (180.0, 50.0)),
                     buffer_m=3.0)
    flight = _flight(site, [(0.0, 50.0), (180.0, 50.0)], 10.0)
    k = next(i for i, leg in enumerate(flight.legs) if leg.end_xy_m[0] == pytest.approx(180.0))
    found = [f for f in audit_position_loss(flight, site, _wpnav(10.0)) if f.leg == k]
    assert found and found[0].zone == "NFZ1" and found[0].clearance_m < 0.0
    cap = position_loss_speed_cap_mps(flight, k, site, 10.0)
    assert cap is not None and 1.0 <= cap < 10.0 == found[0].speed_mps
    assert found[0].speed_cap_mps == cap
    assert np.all(region_clearances(site, _leg_region(flight, k, cap)) >= 0.0)
    assert np.any(region_clearances(site, _leg_region(flight, k, cap + 0.3)) < 0.0)


def test_a_leg_passing_a_zone_closer_than_the_wander_has_no_speed_that_helps():
    site = make_site(nfz=((100.0, 0.0, 20.0),), gns=((0.0, 28.0), (200.0, 28.0)),
                     buffer_m=3.0)
    flight = _flight(site, [(0.0, 28.0), (200.0, 28.0)], 5.0)
    found = audit_position_loss(flight, site, _wpnav(5.0))
    assert found and all(f.speed_cap_mps is None for f in found)
    assert "wider berth" in found[0].message


def test_a_zone_out_of_reach_is_no_finding():
    site = make_site(nfz=((100.0, 200.0, 20.0),), buffer_m=3.0)
    assert audit_position_loss(_flight(site, [(0.0, 50.0), (200.0, 50.0)], 10.0),
                               site, _wpnav(10.0)) == []


def test_the_coast_is_measured_from_the_failsafes_mode_change():
    t = np.arange(0.0, 20.0, 1.0)
    # 10 m/s east until t=8 (the failsafe), then slowing, drifting 3 m north
    x = np.where(t <= 8, 10 * t, 80 + 10 * (1 - np.exp(-(t - 8) / 2)) * 2)
    y = np.where(t <= 8, 0.0, 3.0 * (t - 8) / 11)
    coast = measure_coast(t, np.stack([x, y], axis=1), 0.5, [(8.0, "LAND")])
    assert coast is not None and coast.mode == "LAND"
    assert coast.delay_s == pytest.approx(7.5)
    assert coast.speed_mps == pytest.approx(10.0)
    assert coast.along_m == pytest.approx(x[-1] - 80.0)
    assert coast.across_m == pytest.approx(3.0)
    assert measure_coast(t, np.stack([x, y], axis=1), 0.5, []) is None


def test_the_berth_adds_the_deepest_coast_and_its_margin_to_the_buffer():
    site = make_site(nfz=((100.0, 0.0, 20.0),), gns=((0.0, 28.0), (200.0, 28.0)),
                     buffer_m=3.0)
    flight = _flight(site, [(0.0, 28.0), (200.0, 28.0)], 5.0)
    found = [f for f in audit_position_loss(flight, site, _wpnav(5.0))
             if abs(flight.legs[f.leg].end_xy_m[0] - 200.0) < 1e-3]  # the leg beside it
    deepest = max(-f.clearance_m for f in found)
    assert berth_buffer_m(3.0, found) == pytest.approx(3.0 + deepest + BERTH_MARGIN_M)
    assert berth_buffer_m(3.0, []) is None


def test_a_coast_deeper_than_the_wander_first_asks_for_the_wander_only():
    # the leg ends 20 m short of a zone, straight at it: 10 m/s coasts 26 m on, deeper
    # than any berth beside it would need; the first try is the wander's berth, and a
    # plan already that far out is asked for the whole depth
    site = make_site(nfz=((220.0, 50.0, 20.0),), gns=((0.0, 50.0), (180.0, 50.0)),
                     buffer_m=3.0)
    found = audit_position_loss(_flight(site, [(0.0, 50.0), (180.0, 50.0)], 10.0), site,
                                _wpnav(10.0))
    deepest = max(-f.clearance_m for f in found)
    assert 3.0 + deepest > WANDER_M
    assert berth_buffer_m(3.0, found) == pytest.approx(WANDER_M + BERTH_MARGIN_M)
    assert berth_buffer_m(WANDER_M + BERTH_MARGIN_M, found) == pytest.approx(
        WANDER_M + 2 * BERTH_MARGIN_M + deepest)


def test_a_leg_moved_out_by_the_berth_leaves_the_zone_out_of_reach():
    site = make_site(nfz=((100.0, 0.0, 20.0),), gns=((0.0, 28.0), (200.0, 28.0)),
                     buffer_m=3.0)
    found = audit_position_loss(_flight(site, [(0.0, 28.0), (200.0, 28.0)], 5.0), site, _wpnav(5.0))
    need = berth_buffer_m(3.0, found)
    assert need is not None
    y = 20.0 + need  # the leg as a plan with the wider buffer keeps it
    moved = _flight(site, [(0.0, y), (200.0, y)], 5.0)
    k = next(i for i, leg in enumerate(moved.legs)
             if abs(leg.end_xy_m[0] - 200.0) < 1e-3 and abs(leg.start_xy_m[0]) < 1e-3)
    before = [f for f in found if f.leg == k]
    assert before, "the leg at the narrow buffer must be a finding for this test to mean anything"
    assert [f for f in audit_position_loss(moved, site, _wpnav(5.0)) if f.leg == k] == []


@pytest.mark.parametrize("points", [[(0.0, 50.0), (300.0, 50.0)],
                                    [(0.0, 50.0), (250.0, 50.0), (300.0, 50.0)]])
def test_a_gps_loss_is_aimed_the_failsafe_delay_before_the_worst_coast(points):
    # the coast from the end of the leg at (300, 50) runs 26 m on toward the zone ahead; the
    # loss must come 8.2 s of flight (82 m at 10 m/s) before, over a corner if need be
    site = make_site(nfz=((360.0, 50.0, 20.0),), gns=((0.0, 50.0), (300.0, 50.0)),
                     buffer_m=3.0)
    found = worst_position_loss_point(_flight(site, points, 10.0), site, _wpnav(10.0))
    assert found is not None
    xy, clearance = found
    assert clearance == pytest.approx(360.0 - 300.0 - COAST_S * 10.0 - 20.0 - WANDER_M, abs=0.5)
    assert xy == pytest.approx([300.0 - DETECTION_DELAY_S * 10.0, 50.0], abs=1.0)


def test_no_zone_no_point_to_aim_a_gps_loss_at():
    site = make_site(nfz=(), gns=((0.0, 50.0), (300.0, 50.0)), buffer_m=3.0)
    assert worst_position_loss_point(_flight(site, [(0.0, 50.0), (300.0, 50.0)], 10.0),
                                     site, _wpnav(10.0)) is None


# -- in wind: the failsafe lands without a position, and the air carries the vehicle ---------

WIND_FLIGHTS = REPO / "tests" / "data" / "failsafe" / "gps-loss-wind.json"


def test_a_failsafe_landing_from_30_m_takes_the_measured_42_s():
    assert failsafe_land_s(30.0, None) == pytest.approx(41.8, abs=0.1)  # measured 41.75, 41.8


def test_a_faster_high_descent_shortens_the_landing_and_its_drift():
    default = failsafe_land_s(30.0, None)
    assert failsafe_land_s(30.0, {"LAND_SPEED_HIGH": 300.0}) == pytest.approx(
        default - 20.0 / 1.5 + 20.0 / 3.0)
    # below LAND_ALT_LOW the whole descent is at LAND_SPEED (0.5 m/s)
    assert failsafe_land_s(8.0, None) == pytest.approx(4.0 + 8.0 / 0.5 + 4.5)


def test_still_air_leaves_no_drift():
    site = make_site(nfz=((100.0, 150.0, 20.0),), gns=((0.0, 0.0), (200.0, 0.0)))
    assert drift_xy_m(site, 30.0, None) == pytest.approx([0.0, 0.0])


def test_the_drift_runs_downwind_for_the_whole_landing():
    site = make_site(nfz=((100.0, 150.0, 20.0),), gns=((0.0, 0.0), (200.0, 0.0)))
    windy = site.with_limits(wind=Wind(4.0, 180.0))  # from the south: it blows north
    assert drift_xy_m(windy, 30.0, None) == pytest.approx(
        [0.0, 4.0 * failsafe_land_s(30.0, None)], abs=1e-9)


def test_a_zone_downwind_of_a_leg_is_reached_in_wind_and_not_in_still_air():
    # the leg runs east 130 m south of a zone's edge: out of the coast's reach in still air,
    # but 4 m/s from the south carries a vehicle without a position 167 m north
    site = make_site(nfz=((100.0, 150.0, 20.0),), gns=((0.0, 0.0), (200.0, 0.0)))
    windy = site.with_limits(wind=Wind(4.0, 180.0))
    plan = _flight(site, [(0.0, 0.0), (200.0, 0.0)], 5.0)
    assert audit_position_loss(plan, site, _wpnav(5.0)) == []
    found = audit_position_loss(plan, windy, _wpnav(5.0))
    assert found and {f.zone for f in found} == {"NFZ1"}
    f = found[0]
    assert f.drift_m == pytest.approx(4.0 * failsafe_land_s(ALT_M, None), abs=0.1)
    assert f.speed_cap_mps is None  # no speed helps: the drift alone reaches it
    assert "drifting" in f.message and "LAND_SPEED_HIGH" in f.message
    # the berth's view leaves the drift out: a wider buffer cannot keep it clear
    assert audit_position_loss(plan, windy, _wpnav(5.0), drift=False) == []


def test_a_gps_loss_in_wind_is_aimed_where_the_drift_comes_closest():
    site = make_site(nfz=((100.0, 150.0, 20.0),), gns=((0.0, 0.0), (200.0, 0.0)))
    windy = site.with_limits(wind=Wind(4.0, 180.0))
    plan = _flight(site, [(0.0, 0.0), (200.0, 0.0)], 5.0)
    found = worst_position_loss_point(plan, windy, _wpnav(5.0))
    assert found is not None
    _, clearance = found
    assert clearance < 0.0  # the drift reaches the zone
    calm = worst_position_loss_point(plan, site, _wpnav(5.0))
    assert calm is not None and calm[1] > 0.0


@pytest.mark.parametrize("flight", json.loads(WIND_FLIGHTS.read_text())["flights"],
                         ids=lambda f: f"{f['wind']['speed_mps']:g}@{f['wind']['from_deg']:g}")
def test_each_gps_loss_flown_in_sitl_wind_ends_inside_the_modelled_region(flight):
    """ArduCopter 4.5.6 SITL: a GPS loss in wind, from the failsafe's point and velocity the
    landed vehicle lies within the drifting region, and outside the still-air one (the
    measured drift is far beyond the coast)."""
    site = load_site(REPO / flight["site"]).with_limits(wind=Wind(
        flight["wind"]["speed_mps"], flight["wind"]["from_deg"], flight["wind"]["turbulence_mps"]))
    p = np.array(flight["failsafe_xy_m"])
    v = np.array(flight["velocity_mps"])
    start = p - v  # the last second's flying: the leg the failsafe fired on
    speed = float(np.hypot(*v))
    end = shapely.Point(flight["end_xy_m"])
    drift = drift_xy_m(site, flight["altitude_m"], None)
    assert coast_region(start, p, speed, drift_m=drift).contains(end)
    assert not coast_region(start, p, speed).contains(end)
    assert flight["landing_s"] == pytest.approx(failsafe_land_s(flight["altitude_m"], None),
                                                abs=1.0)


DEAD_RECKONING_FLIGHTS = REPO / "tests" / "data" / "failsafe" / "gps-loss-dead-reckoning.json"
DRAG = {"EK3_DRAG_BCOEF_X": 9.5, "EK3_DRAG_BCOEF_Y": 9.5, "EK3_DRAG_MCOEF": 0.082}


@pytest.mark.parametrize("params, reckons", [
    (None, False), ({"EK3_DRAG_BCOEF_X": 0.0, "EK3_DRAG_MCOEF": 0.0}, False),
    ({"EK3_DRAG_MCOEF": 0.082}, True), ({"EK3_DRAG_BCOEF_Y": 16.3}, True)])
def test_only_drag_fusion_makes_the_ekf_dead_reckon(params, reckons):
    assert dead_reckons(params) is reckons


@pytest.mark.parametrize("flight", json.loads(DEAD_RECKONING_FLIGHTS.read_text())["flights"],
                         ids=lambda f: f"MCOEF {f['params']['EK3_DRAG_MCOEF']:g}")
def test_each_dead_reckoned_gps_loss_flown_in_sitl_ends_inside_the_any_way_region(flight):
    """ArduCopter 4.5.6 SITL with EKF3 drag fusion: the dead-reckoning failsafe landed on an
    estimate that slid upwind, outside the downwind region of a free drift and inside the one
    swept the drift's length any way; it fired later than the EKF failsafe does."""
    site = load_site(REPO / flight["site"]).with_limits(wind=Wind(
        flight["wind"]["speed_mps"], flight["wind"]["from_deg"], flight["wind"]["turbulence_mps"]))
    assert dead_reckons(flight["params"])
    p = np.array(flight["failsafe_xy_m"])
    v = np.array(flight["velocity_mps"])
    start, speed = p - v, float(np.hypot(*v))
    end = shapely.Point(flight["end_xy_m"])
    drift = drift_xy_m(site, flight["altitude_m"], flight["params"])
    assert coast_region(start, p, speed, drift_m=drift, any_direction=True).contains(end)
    assert not coast_region(start, p, speed, drift_m=drift).contains(end)
    assert flight["delay_s"] == pytest.approx(DEAD_RECKONING_DELAY_S, abs=0.3)
    assert flight["delay_s"] > DETECTION_DELAY_S + 1.5
    assert flight["landing_s"] == pytest.approx(failsafe_land_s(flight["altitude_m"], None),
                                                abs=1.0)


def test_a_zone_upwind_of_a_leg_is_reached_only_by_a_dead_reckoning_vehicle():
    # the leg runs east 130 m north of a zone's edge, the wind blowing north (from the south):
    # a free drift carries the vehicle away from it, a dead-reckoned estimate may slide to it
    site = make_site(nfz=((100.0, -150.0, 20.0),), gns=((0.0, 0.0), (200.0, 0.0)))
    windy = site.with_limits(wind=Wind(4.0, 180.0))
    plan = _flight(site, [(0.0, 0.0), (200.0, 0.0)], 5.0)
    assert audit_position_loss(plan, windy, _wpnav(5.0)) == []
    found = audit_position_loss(plan, windy, {**_wpnav(5.0), **DRAG})
    assert found and {f.zone for f in found} == {"NFZ1"}
    assert all(f.dead_reckoning for f in found)
    assert "dead-reckoning failsafe" in found[0].message and "any way" in found[0].message
    assert found[0].as_dict()["dead_reckoning"] is True
    # still air: no drift to slide, the same coast as without drag fusion
    assert audit_position_loss(plan, site, {**_wpnav(5.0), **DRAG}) == []


def test_a_dead_reckoning_gps_loss_is_aimed_at_the_upwind_zone():
    site = make_site(nfz=((100.0, -150.0, 20.0),), gns=((0.0, 0.0), (200.0, 0.0)))
    windy = site.with_limits(wind=Wind(4.0, 180.0))
    plan = _flight(site, [(0.0, 0.0), (200.0, 0.0)], 5.0)
    free = worst_position_loss_point(plan, windy, _wpnav(5.0))
    reckoned = worst_position_loss_point(plan, windy, {**_wpnav(5.0), **DRAG})
    assert free is not None and reckoned is not None
    assert free[1] > 0.0 > reckoned[1]


def test_the_failsafe_after_a_gps_loss_is_ekf3s_unless_it_dead_reckons():
    assert coasting_failsafe("ardupilot", None) == "FS_EKF_ACTION"
    assert coasting_failsafe("ardupilot", DRAG) == "FS_DR_ENABLE"
    assert coasting_failsafe("px4", DRAG) == "COM_POSCTL_NAVL"
