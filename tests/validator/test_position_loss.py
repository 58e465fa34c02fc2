"""The position-loss (GPS loss) model: where an ArduCopter that loses its position can coast,
the legs the audit warns about, the one speed rule, and the coast measured from a track."""

from __future__ import annotations

import numpy as np
import pytest

from tests.validator.builders import make_site, waypoint_plan
from validator.flight import resolve_flight
from validator.mavlink.faults import measure_coast
from validator.position_loss import (
    BERTH_MARGIN_M,
    COAST_S,
    DETECTION_DELAY_S,
    WANDER_M,
    _leg_region,
    audit_position_loss,
    berth_buffer_m,
    coast_region,
    position_loss_speed_cap_mps,
    region_clearances,
    worst_position_loss_point,
)


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
    found = [f for f in audit_position_loss(flight, site, 10.0) if f.leg == k]
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
    found = audit_position_loss(flight, site, 5.0)
    assert found and all(f.speed_cap_mps is None for f in found)
    assert "wider berth" in found[0].message


def test_a_zone_out_of_reach_is_no_finding():
    site = make_site(nfz=((100.0, 200.0, 20.0),), buffer_m=3.0)
    assert audit_position_loss(_flight(site, [(0.0, 50.0), (200.0, 50.0)], 10.0),
                               site, 10.0) == []


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
    found = [f for f in audit_position_loss(flight, site, 5.0)
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
    found = audit_position_loss(_flight(site, [(0.0, 50.0), (180.0, 50.0)], 10.0), site, 10.0)
    deepest = max(-f.clearance_m for f in found)
    assert 3.0 + deepest > WANDER_M
    assert berth_buffer_m(3.0, found) == pytest.approx(WANDER_M + BERTH_MARGIN_M)
    assert berth_buffer_m(WANDER_M + BERTH_MARGIN_M, found) == pytest.approx(
        WANDER_M + 2 * BERTH_MARGIN_M + deepest)


def test_a_leg_moved_out_by_the_berth_leaves_the_zone_out_of_reach():
    site = make_site(nfz=((100.0, 0.0, 20.0),), gns=((0.0, 28.0), (200.0, 28.0)),
                     buffer_m=3.0)
    found = audit_position_loss(_flight(site, [(0.0, 28.0), (200.0, 28.0)], 5.0), site, 5.0)
    need = berth_buffer_m(3.0, found)
    assert need is not None
    y = 20.0 + need  # the leg as a plan with the wider buffer keeps it
    moved = _flight(site, [(0.0, y), (200.0, y)], 5.0)
    k = next(i for i, leg in enumerate(moved.legs)
             if abs(leg.end_xy_m[0] - 200.0) < 1e-3 and abs(leg.start_xy_m[0]) < 1e-3)
    before = [f for f in found if f.leg == k]
    assert before, "the leg at the narrow buffer must be a finding for this test to mean anything"
    assert [f for f in audit_position_loss(moved, site, 5.0) if f.leg == k] == []


@pytest.mark.parametrize("points", [[(0.0, 50.0), (300.0, 50.0)],
                                    [(0.0, 50.0), (250.0, 50.0), (300.0, 50.0)]])
def test_a_gps_loss_is_aimed_the_failsafe_delay_before_the_worst_coast(points):
    # the coast from the end of the leg at (300, 50) runs 26 m on toward the zone ahead; the
    # loss must come 8.2 s of flight (82 m at 10 m/s) before, over a corner if need be
    site = make_site(nfz=((360.0, 50.0, 20.0),), gns=((0.0, 50.0), (300.0, 50.0)),
                     buffer_m=3.0)
    found = worst_position_loss_point(_flight(site, points, 10.0), site, 10.0)
    assert found is not None
    xy, clearance = found
    assert clearance == pytest.approx(360.0 - 300.0 - COAST_S * 10.0 - 20.0 - WANDER_M, abs=0.5)
    assert xy == pytest.approx([300.0 - DETECTION_DELAY_S * 10.0, 50.0], abs=1.0)


def test_no_zone_no_point_to_aim_a_gps_loss_at():
    site = make_site(nfz=(), gns=((0.0, 50.0), (300.0, 50.0)), buffer_m=3.0)
    assert worst_position_loss_point(_flight(site, [(0.0, 50.0), (300.0, 50.0)], 10.0),
                                     site, 10.0) is None
