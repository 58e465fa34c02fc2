"""GeoJSON export of a plan and its site."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.validator.builders import make_site, nav, plan_of, speed
from validator.flight import DO_SET_HOME
from validator.geojson_format import CIRCLE_VERTICES, dumps_geojson, plan_geojson
from validator.plan_format import Cmd, Frame, MissionItem


@pytest.fixture(scope="module")
def site():
    return make_site(nfz=((100.0, 0.0, 20.0), (0.0, 120.0, 15.0)))


@pytest.fixture(scope="module")
def plan(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(5.0),
             nav(site, Cmd.NAV_WAYPOINT, (50.0, 60.0), p1=2.0),
             nav(site, Cmd.NAV_LAND, site.home_xy_m, 0.0)]
    extra = {"trajectory_m": [[50.0, 60.0], [70.0, 60.0], [50.0, 60.0]], "scheme": "proposed"}
    return plan_of(site, items, rally=[(0.0, 0.0)], extra=extra)


def _kinds(data):
    out: dict[str, list] = {}
    for f in data["features"]:
        out.setdefault(f["properties"]["kind"], []).append(f)
    return out


def test_every_part_is_a_feature(site, plan):
    kinds = _kinds(plan_geojson(plan, site))
    assert len(kinds["flown_path"]) == 1
    assert len(kinds["service_trajectory"]) == 1
    assert len(kinds["waypoint"]) == 3
    assert len(kinds["ground_node"]) == site.num_gns
    assert len(kinds["nfz"]) == len(kinds["nfz_buffered"]) == site.num_nfzs
    assert len(kinds["fence_exclusion"]) == len(plan.circles)
    assert len(kinds["rally"]) == 1 and len(kinds["home"]) == 1


def test_coordinates_are_lon_lat(site, plan):
    kinds = _kinds(plan_geojson(plan, site))
    wp = kinds["waypoint"][1]
    assert wp["geometry"]["coordinates"] == [plan.items[2].lon_deg, plan.items[2].lat_deg]
    assert wp["properties"]["hold_s"] == 2.0


def test_circles_lie_on_their_radius(site, plan):
    nfz = _kinds(plan_geojson(plan, site))["nfz"][1]
    ring = np.array(nfz["geometry"]["coordinates"][0])
    assert len(ring) == CIRCLE_VERTICES + 1 and (ring[0] == ring[-1]).all()
    xy = site.frame.to_local(ring[:, 1], ring[:, 0])
    np.testing.assert_allclose(np.linalg.norm(xy - site.nfz_xy_m[1], axis=1), 15.0, atol=1e-6)
    assert nfz["properties"]["radius_m"] == 15.0 and nfz["properties"]["name"] == "NFZ2"


def test_text_is_valid_json_feature_collection(site, plan):
    data = json.loads(dumps_geojson(plan_geojson(plan, site)))
    assert data["type"] == "FeatureCollection"
    assert all(f["type"] == "Feature" for f in data["features"])


def _set_home_plan(site, set_home):
    """Takeoff, a waypoint at (50, 60) 20 m up, ``set_home`` (index 3: item 4), a waypoint, RTL."""
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(5.0),
             nav(site, Cmd.NAV_WAYPOINT, (50.0, 60.0), 20.0), set_home,
             nav(site, Cmd.NAV_WAYPOINT, (60.0, 80.0), 20.0),
             MissionItem(int(Cmd.NAV_RETURN_TO_LAUNCH), [0.0] * 7, int(Frame.MISSION))]
    return plan_of(site, items, fence=False)


def test_a_plan_without_do_set_home_has_only_its_own_home(site, plan):
    assert "home_set" not in _kinds(plan_geojson(plan, site))


def test_a_home_set_where_the_vehicle_is_is_a_point_there_named_by_its_item(site):
    here = MissionItem(DO_SET_HOME, [1.0, 0, 0, 0, 0, 0, 0], int(Frame.GLOBAL_RELATIVE_ALT))
    plan = _set_home_plan(site, here)
    (home,) = _kinds(plan_geojson(plan, site))["home_set"]
    lon, lat = home["geometry"]["coordinates"]
    np.testing.assert_allclose(site.frame.to_local(lat, lon), (50.0, 60.0), atol=1e-6)
    assert home["properties"]["item"] == 4  # QGroundControl's number, as in its name
    assert home["properties"]["name"] == "home set by item 4"


def test_a_home_set_moved_up_gives_its_altitude_above_sea_level_and_above_the_plans_home(site):
    here = MissionItem(DO_SET_HOME, [1.0, 0, 0, 0, 0, 0, 0], int(Frame.GLOBAL_RELATIVE_ALT))
    plan = _set_home_plan(site, here)
    props = _kinds(plan_geojson(plan, site))["home_set"][0]["properties"]
    assert props["altitude_above_plan_home_m"] == pytest.approx(20.0)
    assert props["altitude_amsl_m"] == pytest.approx(plan.home_alt_m + 20.0)


def test_a_home_set_at_coordinates_is_a_point_at_them(site):
    lat, lon = site.frame.to_geodetic(np.array([-20.0, 30.0]))
    there = MissionItem(DO_SET_HOME, [0.0, 0, 0, 0, float(lat), float(lon), 0.0],
                        int(Frame.GLOBAL_RELATIVE_ALT))
    (home,) = _kinds(plan_geojson(_set_home_plan(site, there), site))["home_set"]
    assert home["geometry"]["coordinates"] == pytest.approx([float(lon), float(lat)])
    assert home["properties"]["altitude_above_plan_home_m"] == pytest.approx(0.0)
