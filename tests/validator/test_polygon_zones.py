"""Polygon no-fly zones in the validator: the audit's exact legs and fence coverage, the replayed
clearance per zone, and the GeoJSON export."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.validator.builders import ALT_M, nav, plan_of, speed, waypoint_plan
from validator.audit import audit
from validator.flight import resolve_flight
from validator.geojson_format import plan_geojson
from validator.motion.limits import site_limits
from validator.motion.profile import make_profile
from validator.plan_format import Cmd, FencePolygon, Plan
from validator.replay import replay, score_track
from validator.site import Site, parse_site
from validator.zones import fence_outline_m

BUFFER_M = 2.0
SQUARE = [(100.0, -20.0), (140.0, -20.0), (140.0, 20.0), (100.0, 20.0)]  # corner at (140, 20)


def polygon_site(buffer_m: float = BUFFER_M) -> Site:
    data = {
        "name": "poly-site",
        "origin": {"lat": 37.5585, "lon": 126.999, "alt": 40.0},
        "uav": {"altitude": ALT_M, "max_speed": 10.0, "period": 60.0, "slots": 10},
        "radio": {"p_avg_dbm": 20.0, "p_peak_dbm": 26.0206, "beta0_db": -30.0,
                  "noise_dbm": -70.0},
        "ground_nodes": [{"name": "GN1", "x": 0.0, "y": 50.0}, {"name": "GN2", "x": 200.0,
                                                                "y": 50.0}],
        "no_fly_zones": [{"name": "DISC", "x": 0.0, "y": 120.0, "radius": 15.0},
                         {"name": "SQ", "polygon": [{"x": x, "y": y} for x, y in SQUARE]}],
        "safety": {"buffer_m": buffer_m},
    }
    return parse_site(data, "poly-site")


@pytest.fixture(scope="module")
def site() -> Site:
    return polygon_site()


def with_polygon_fence(site: Site, plan: Plan, margin_m: float = 0.5) -> Plan:
    """``plan`` with an exclusion polygon round each polygon zone, ``margin_m`` out."""
    for zone in site.polygon_zones:
        lat, lon = site.frame.to_geodetic(fence_outline_m(zone, margin_m))
        plan.polygons.append(FencePolygon([(float(a), float(b)) for a, b in
                                           zip(lat, lon, strict=True)], inclusion=False))
    return plan


def corner_pass(offset_m: float) -> list[tuple[float, float]]:
    """Two points of a leg at 45° whose closest point to SQ's corner (140, 20) lies
    ``offset_m`` outside it (negative: the leg cuts the corner, its deepest point
    offset / √2 inside both edges)."""
    c = 160.0 + offset_m * math.sqrt(2.0)  # the leg's line x + y = c
    return [(110.0, c - 110.0), (175.0, c - 175.0)]


def test_a_leg_cutting_a_polygon_corner_is_a_violation_by_name(site):
    plan = with_polygon_fence(site, waypoint_plan(site, corner_pass(-math.sqrt(2.0)), end="none"))
    report = audit(plan, site)
    msgs = [f.message for f in report.violations]
    assert any(m.startswith("leg item 3 -> item 4 (waypoint) enters SQ by ") for m in msgs), msgs
    row = {z.name: z for z in report.nfz}["SQ"]
    # the deepest point of the cut, (139, 19), lies 1 m inside both edges
    assert row.clearance_m == pytest.approx(-1.0, abs=0.03)
    assert (row.from_item, row.item) == (2, 3)
    assert np.hypot(row.xy_m[0] - 139.0, row.xy_m[1] - 19.0) < 0.05
    # and the leg enters the exclusion fence round it
    assert any("enters exclusion fence polygon 0" in m for m in msgs)


def test_a_leg_passing_a_corner_at_buffer_plus_a_centimetre_passes_the_safety_gate(site):
    plan = with_polygon_fence(site, waypoint_plan(site, corner_pass(BUFFER_M + 0.01),
                                                  end="none"))
    report = audit(plan, site, require_buffer=True)
    assert report.ok, [f.message for f in report.violations]
    row = {z.name: z for z in report.nfz}["SQ"]
    assert row.clearance_m == pytest.approx(BUFFER_M + 0.01, abs=1e-6)
    # a centimetre closer than the buffer less the tolerance, the gate refuses it
    inside = with_polygon_fence(site, waypoint_plan(site, corner_pass(BUFFER_M - 0.02),
                                                    end="none"))
    strict = [f.message for f in audit(inside, site, require_buffer=True).violations]
    assert any("passes 1.98 m from SQ, inside its 2 m safety buffer" in m for m in strict), strict


def test_every_zone_has_a_row_and_a_column_by_name(site):
    plan = with_polygon_fence(site, waypoint_plan(site, corner_pass(5.0), end="none"))
    report = audit(plan, site)
    assert [z.name for z in report.nfz] == ["DISC", "SQ"]
    assert report.leg_clearance_m.shape == (len(report.flight.legs), 2)
    assert set(report.unique_legs()[0]["clearance_m"]) == {"DISC", "SQ"}


def test_a_polygon_zone_without_an_exclusion_fence_round_it_is_a_violation(site):
    plan = waypoint_plan(site, corner_pass(5.0), end="none")  # circle fences only
    msgs = [f.message for f in audit(plan, site).violations]
    assert "SQ is not inside an exclusion fence at least as large (the plan has no exclusion " \
           "polygon)" in msgs
    # a fence polygon that is the zone shrunk by 10 cm does not hold it
    small = waypoint_plan(site, corner_pass(5.0), end="none")
    zone = site.polygon_zones[0]
    lat, lon = site.frame.to_geodetic(np.asarray(zone.shape.buffer(-0.1, join_style="mitre")
                                                 .exterior.coords)[:-1])
    small.polygons.append(FencePolygon(list(zip(lat.tolist(), lon.tolist(), strict=True)),
                                       inclusion=False))
    msgs = [f.message for f in audit(small, site).violations]
    assert any(m.startswith("SQ is not inside an exclusion fence at least as large (the "
                            "closest exclusion polygon leaves") for m in msgs), msgs
    assert not [m for m in [f.message for f in audit(with_polygon_fence(
        site, waypoint_plan(site, corner_pass(5.0), end="none")), site).violations]
        if "exclusion fence" in m]


def test_a_rally_point_inside_a_polygon_zone_is_a_violation(site):
    plan = with_polygon_fence(site, waypoint_plan(site, corner_pass(5.0), end="none",
                                                  rally=[(120.0, 0.0)]))
    assert "rally point 0 lies inside SQ" in [f.message for f in audit(plan, site).violations]


def test_replay_gives_the_flown_clearance_of_each_polygon_zone(site):
    plan = with_polygon_fence(site, waypoint_plan(site, corner_pass(-math.sqrt(2.0)), end="none"))
    flight = resolve_flight(plan, site)
    rep = score_track(replay(flight, make_profile("ideal", site_limits(site))), flight, site, plan)
    rows = {p.name: p for p in rep.nfz}
    assert list(rows) == ["DISC", "SQ"]
    assert rows["SQ"].clearance_m == pytest.approx(-1.0, abs=0.03)
    assert np.hypot(rows["SQ"].xy_m[0] - 139.0, rows["SQ"].xy_m[1] - 19.0) < 0.1
    msgs = [f.message for f in rep.findings if f.severity == "violation"]
    assert any(m.startswith("flown track enters SQ by ") for m in msgs), msgs
    fence = [m for m in msgs if m.startswith("flown track enters exclusion fence polygon 0 by ")]
    # 1 m inside the zone, so the fence's 0.5 m margin deeper (its edges stand a few cm more
    # off the zone: the rounded outline's circle is just wide enough for its chords)
    assert fence and 1.5 <= float(fence[0].split(" by ")[1].split(" m")[0]) <= 1.6
    clear = with_polygon_fence(site, waypoint_plan(site, corner_pass(3.0), end="none"))
    flight = resolve_flight(clear, site)
    rep = score_track(replay(flight, make_profile("ideal", site_limits(site))), flight, site, clear)
    assert {p.name: p for p in rep.nfz}["SQ"].clearance_m == pytest.approx(3.0, abs=1e-3)
    assert not rep.fence_entries


def test_geojson_holds_polygon_zones_their_buffer_and_their_fence(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(5.0),
             nav(site, Cmd.NAV_WAYPOINT, (50.0, 60.0)), nav(site, Cmd.NAV_LAND, site.home_xy_m)]
    plan = with_polygon_fence(site, plan_of(site, items))
    feats = plan_geojson(plan, site)["features"]
    zones = [f for f in feats if f["properties"]["kind"] == "nfz"]
    assert [f["properties"]["name"] for f in zones] == ["DISC", "SQ"]
    sq = zones[1]["geometry"]["coordinates"][0]
    back = site.frame.to_local(np.array([p[1] for p in sq]), np.array([p[0] for p in sq]))
    assert np.allclose(back[:-1], SQUARE, atol=1e-6)
    assert sq[0] == sq[-1]
    buffered = [f for f in feats if f["properties"]["kind"] == "nfz_buffered"
                and f["properties"]["name"] == "SQ"]
    ring = buffered[0]["geometry"]["coordinates"][0]
    xy = site.frame.to_local(np.array([p[1] for p in ring]), np.array([p[0] for p in ring]))
    dist = [site.polygon_zones[0].shape.exterior.distance(__import__("shapely").Point(p))
            for p in xy]
    assert min(dist) == pytest.approx(BUFFER_M, abs=0.01) and max(dist) <= BUFFER_M + 1e-6
    fences = [f for f in feats if f["properties"]["kind"] == "fence_exclusion"
              and f["geometry"]["type"] == "Polygon" and "zones" in f["properties"]]
    assert [f["properties"]["zones"] for f in fences] == [["SQ"]]
