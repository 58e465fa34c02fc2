import numpy as np
import pytest

from tests.validator.builders import (
    fence_for,
    make_site,
    nav,
    plan_of,
    service_plan,
    speed,
    waypoint_plan,
)
from validator.audit import audit
from validator.plan_format import Cmd, FenceCircle, FencePolygon, MissionItem


@pytest.fixture(scope="module")
def site():
    # one NFZ of radius 20 m at (100, 0)
    return make_site()


def violations(report):
    return [f.message for f in report.violations]


def test_leg_between_clear_waypoints_that_crosses_an_nfz_is_rejected_by_name(site):
    # both waypoints lie 29 m from the centre (outside R = 20), the leg passes 15 m from it
    plan = waypoint_plan(site, [(0, -15), (75, -15), (125, -15), (200, -15)], end="none")
    report = audit(plan, site)
    assert not report.ok
    msgs = violations(report)
    # plan indices 3 -> 4; a person reads QGroundControl's numbers, index + 1
    assert any("leg item 4 -> item 5 (waypoint) enters NFZ1 by 5.00 m" in m for m in msgs)
    nfz = report.nfz[0]
    assert nfz.clearance_m == pytest.approx(-5.0, abs=1e-3)
    assert (nfz.from_item, nfz.item) == (3, 4)


def test_route_around_the_nfz_passes(site):
    plan = waypoint_plan(site, [(0, -40), (75, -40), (125, -40), (200, -40), (200, 60),
                                (0, 60)])
    report = audit(plan, site)
    assert report.ok, violations(report)
    assert report.nfz[0].clearance_m == pytest.approx(20.0, abs=1e-3)


def test_a_leg_inside_the_buffer_warns_and_fails_only_when_the_buffer_is_required(site):
    # R = 20 m, buffer 2 m: legs 21 m from the centre are outside the zone, inside its buffer
    plan = waypoint_plan(site, [(0, -21), (200, -21), (200, 60), (0, 60)])
    report = audit(plan, site)
    assert report.ok
    assert any("passes 1.00 m from NFZ1, inside its 2 m safety buffer" in f.message
               for f in report.findings if f.severity == "warning")
    strict = violations(audit(plan, site, require_buffer=True))
    assert any("passes 1.00 m from NFZ1, inside its 2 m safety buffer" in m for m in strict)
    # 22 m away keeps the buffer, up to the one tolerance (1 cm)
    clear = waypoint_plan(site, [(0, -21.995), (200, -21.995), (200, 60), (0, 60)])
    assert audit(clear, site, require_buffer=True).ok


def test_rtl_whose_straight_line_home_crosses_an_nfz_is_rejected(site):
    # fly around the NFZ to its far side, then RTL straight back through it
    plan = waypoint_plan(site, [(0, -40), (200, -40), (200, 0)], end="rtl")
    report = audit(plan, site)
    msgs = violations(report)
    assert any("(rtl) enters NFZ1" in m for m in msgs), msgs


def test_rtl_that_goes_around_via_a_nearer_rally_point_is_fine(site):
    plan = waypoint_plan(site, [(0, -40), (200, -40), (200, 0)], end="rtl",
                         rally=[(210, 10)])
    assert audit(plan, site).ok


def test_nfz_without_a_covering_exclusion_fence_is_a_violation(site):
    plan = waypoint_plan(site, [(0, -40)], fence=False)
    msgs = violations(audit(plan, site))
    assert any("NFZ1 is not inside an exclusion fence" in m for m in msgs)


def test_too_small_exclusion_fence_is_a_violation(site):
    plan = waypoint_plan(site, [(0, -40)], fence=False)
    plan.circles = fence_for(site, margin_m=-0.5)
    msgs = violations(audit(plan, site))
    assert any("misses it by 0.50 m" in m for m in msgs)


def test_leg_into_a_wider_exclusion_fence_is_a_violation(site):
    # clear of the NFZ (22 m from the centre) but inside a 25 m exclusion fence
    plan = waypoint_plan(site, [(0, -22), (200, -22)], fence=False)
    plan.circles = fence_for(site, margin_m=5.0)
    msgs = violations(audit(plan, site))
    assert any("enters exclusion fence circle 0 by 3.00 m" in m for m in msgs), msgs


def test_rally_point_inside_an_nfz_is_a_violation(site):
    plan = waypoint_plan(site, [(0, -40)], rally=[(100, 5)])
    assert any("rally point 0 lies inside NFZ1" in m for m in violations(audit(plan, site)))


def test_leg_outside_an_inclusion_fence_is_a_violation(site):
    plan = waypoint_plan(site, [(0, -40), (0, -300)])
    lat, lon = site.frame.to_geodetic(np.array([0.0, 0.0]))
    plan.circles.append(FenceCircle(float(lat), float(lon), 250.0, inclusion=True))
    assert any("leaves every inclusion fence" in m for m in violations(audit(plan, site)))


def test_speed_above_the_site_limit_is_a_violation(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(12.0),
             nav(site, Cmd.NAV_WAYPOINT, (0, -40))]
    report = audit(plan_of(site, items), site)
    assert any(f.item == 1 and "12 m/s exceeds the site's V = 10 m/s" in f.message
               for f in report.violations)


def test_altitude_below_home_is_a_violation_and_off_h_a_warning(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), nav(site, Cmd.NAV_WAYPOINT, (0, -40),
             alt=50.0), nav(site, Cmd.NAV_WAYPOINT, (0, -60), alt=-5.0)]
    report = audit(plan_of(site, items), site)
    assert any(f.item == 2 and "flies at -5 m" in f.message for f in report.violations)
    assert any(f.item == 1 and f.severity == "warning" and "differs from the site's H"
               in f.message for f in report.findings)


def test_fractional_hold_warns_for_ardupilot(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m),
             nav(site, Cmd.NAV_WAYPOINT, (0, -40), p1=2.6)]
    report = audit(plan_of(site, items), site)
    assert any(f.item == 1 and "truncates it to 2 s" in f.message for f in report.findings)


def test_unknown_command_is_listed(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), MissionItem(4242, [0.0] * 7, 2)]
    report = audit(plan_of(site, items), site)
    assert any(f.item == 1 and "unknown command 4242" in f.message for f in report.findings)


def test_repeated_legs_are_reported_once_with_their_count(site):
    q = [(0, 60), (60, 60), (60, 100), (0, 60)]
    plan = service_plan(site, q, [6, 4, 8], [0.1] * 3, ["GN1", None, "GN2"], cycles=3)
    report = audit(plan, site)
    assert report.ok, violations(report)
    counts = {(leg["from_item"], leg["item"]): leg["count"] for leg in report.unique_legs()}
    assert max(counts.values()) == 3


def test_closest_approach_time_follows_the_commanded_speeds(site):
    # takeoff (12 s at 2.5 m/s), 40 m at 5 m/s, then the pass south of the NFZ
    plan = waypoint_plan(site, [(0, -40), (200, -40)], v=5.0, end="none")
    nfz = audit(plan, site).nfz[0]
    assert nfz.t_s == pytest.approx(30.0 / 2.5 + 40.0 / 5.0 + 100.0 / 5.0, abs=1e-6)


@pytest.mark.parametrize("corners_m, says", [
    ([(-300, -300), (-200, -200), (-300, -200), (-200, -300)],  # a bowtie
     "fence polygon 0 (exclusion): self-intersection at x -250.0, y -250.0 m"),
    ([(-300, -300), (-300, -250), (-300, -200)],  # three vertices in a row
     "fence polygon 0 (exclusion): it has no area"),
])
def test_a_fence_polygon_the_autopilot_cannot_hold_as_drawn_is_a_violation(site, corners_m,
                                                                           says):
    """A self-intersecting or flat exclusion polygon uploads, and ArduPilot's breach test of
    it is not the shape drawn; beside fences that cover every zone it had been CLEAR."""
    plan = waypoint_plan(site, [(0, -40), (200, -40)])
    lat, lon = site.frame.to_geodetic(np.asarray(corners_m, dtype=float))
    plan.polygons.append(FencePolygon(list(zip(lat.tolist(), lon.tolist(), strict=True)),
                                      inclusion=False))
    found = [m for m in violations(audit(plan, site)) if m.startswith("fence polygon")]
    assert len(found) == 1 and says in found[0], found
