"""The swing region of a PX4 pass-through corner (:mod:`validator.motion.px4_swing`): the two
legs within SWING_NEAR_M of the waypoint, widened by NAV_ACC_RAD, on either side of the turn."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mission_planner.study.sites import random_site
from tests.validator import px4_corners
from validator.flight import Flight, Leg
from validator.motion.px4_swing import (
    SWING_MARGIN_M,
    SWING_NEAR_M,
    swing_clearance_m,
    swing_findings,
    swing_polyline,
    swing_width_m,
)
from validator.plan_format import Autopilot
from validator.zones import polygon_zone

A, C, B = np.array([0.0, 0.0]), np.array([100.0, 0.0]), np.array([100.0, 100.0])  # a left turn


def _circle(centre: list[float], radius: float, acceptance_m: float = 1.5) -> float:
    return swing_clearance_m(A, C, B, acceptance_m, np.array([centre]), np.array([radius]))


def test_the_region_is_the_legs_near_the_corner() -> None:
    pts = swing_polyline(A, C, B)
    np.testing.assert_allclose(pts, [[100.0 - SWING_NEAR_M, 0.0], [100.0, 0.0],
                                     [100.0, SWING_NEAR_M]])
    short = swing_polyline([95.0, 0.0], C, B)  # a leg shorter than the stretch: all of it
    assert short[0].tolist() == [95.0, 0.0]


def test_a_zone_outside_the_turn_counts_as_one_inside_does() -> None:
    # 5 m off the corner, outside the turn (where PX4 swings) and inside it (where it cuts)
    outside = _circle([105.0 + 2.0, -5.0 - 2.0], 2.0)
    inside = _circle([95.0 - 2.0, 5.0 + 2.0], 2.0)
    assert outside == pytest.approx(np.hypot(7.0, 7.0) - 2.0 - 1.5 - SWING_MARGIN_M)
    assert inside == pytest.approx(5.0 + 2.0 - 2.0 - 1.5 - SWING_MARGIN_M)  # by the first leg
    assert _circle([105.0 + 2.0, -5.0 - 2.0], 2.0, acceptance_m=0.5) == pytest.approx(
        outside + 1.0)


def test_a_zone_beyond_the_stretch_is_not_the_corners() -> None:
    far = _circle([100.0 - SWING_NEAR_M - 10.0, -3.0], 1.0)  # by the first leg, 25 m back
    assert far > 5.0
    assert swing_clearance_m(A, C, B, 1.5, np.zeros((0, 2)), np.zeros(0)) == np.inf


def test_polygons_count_beyond_their_clearance() -> None:
    square = polygon_zone("P", [(103.0, -10.0), (110.0, -10.0), (110.0, -3.0), (103.0, -3.0)],
                          "test")
    c = swing_clearance_m(A, C, B, 1.5, np.zeros((0, 2)), np.zeros(0), (square,), 1.0)
    assert c == pytest.approx(np.hypot(3.0, 3.0) - 1.5 - SWING_MARGIN_M - 1.0)  # its corner


def _flight(pass_through: bool) -> Flight:
    legs = (
        Leg(item=1, first_item=1, kind="waypoint", start_xy_m=A, end_xy_m=C, start_alt_m=20.0,
            end_alt_m=20.0, speed_mps=5.0, hold_s=0.0 if pass_through else 1.0,
            pass_through=pass_through),
        Leg(item=2, first_item=2, kind="waypoint", start_xy_m=C, end_xy_m=B, start_alt_m=20.0,
            end_alt_m=20.0, speed_mps=5.0, hold_s=1.0, pass_through=False),
    )
    return Flight(legs=legs, home_xy_m=A, firmware_type=int(Autopilot.PX4), findings=(),
                  cycle=None, service=None)


@pytest.mark.parametrize(("gap", "severity"), [(4.5, "warning"), (1.5, "violation")])
def test_the_replay_reports_a_swing_into_a_buffer_or_a_zone(gap: float, severity: str) -> None:
    # a 5 m circle ``gap`` m from the corner outside the turn: its region comes gap - 2 close
    away = (gap + 5.0) / np.sqrt(2.0)
    site = replace(random_site(0, buffer_m=3.0), nfz_names=("Z",),
                   nfz_xy_m=np.array([[100.0 + away, -away]]), nfz_radius_m=np.array([5.0]),
                   polygon_zones=())
    found = swing_findings(_flight(True), site, 1.5, 0.01)
    assert [(f.severity, f.item) for f in found] == [(severity, 1)]
    assert swing_findings(_flight(False), site, 1.5, 0.01) == []  # it stops there
    assert swing_findings(_flight(True), site.with_buffer(0.0), 0.1, 0.01) == []


@pytest.mark.parametrize("name", px4_corners.names())
def test_every_flown_corner_stayed_in_its_swing_region(name: str) -> None:
    # the region's bound as measured: PX4's track within SWING_NEAR_M of each corner kept within
    # the swing width of the two legs (flown.json, measured within px4_corners.NEAR_M)
    f = px4_corners.load(name)
    assert px4_corners.NEAR_M >= SWING_NEAR_M
    for corner in f.flown["corners"].values():
        assert max(corner["inside_m"], corner["outside_m"]) <= swing_width_m(
            f.params["NAV_ACC_RAD"])


def test_validate_mission_lists_the_swing_of_waypoints_flown_through() -> None:
    # samples/realistic's PX4 plan as flown on SIH (realistic-sharp): its transit rounds NFZ3
    # through waypoints without a hold, 3 m + 1 cm from it, so their swing regions come within
    # the buffer; its cycle corners, far from every zone, are not listed
    from validator.validation import validate_mission

    folder = px4_corners.DATA / "realistic-sharp"
    v = validate_mission(folder / "mission.plan", folder / "site.yaml", replay_flight=True)
    assert v.replay is not None
    swings = [f for f in v.replay.findings if "may swing" in f.message]
    assert [f.item for f in swings] == [2, 3, 4, 13, 14]
    assert all(f.severity == "warning" and "NFZ3" in f.message for f in swings)


def test_the_python_replay_lists_the_same_swings() -> None:
    # validator.api.replay_plan (and plan-mission's report) scores a replay as validate-mission
    # does: the swings a PX4 replay cannot show are its findings too
    from validator.api import replay_plan
    from validator.plan_format import read_plan
    from validator.site import load_site

    folder = px4_corners.DATA / "realistic-sharp"
    report = replay_plan(read_plan(folder / "mission.plan"), load_site(folder / "site.yaml")).report
    assert [f.item for f in report.findings if "may swing" in f.message] == [2, 3, 4, 13, 14]
