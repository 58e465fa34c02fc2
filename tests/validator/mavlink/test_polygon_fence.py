"""Polygon exclusion fences on the wire: the exporter's fence uploads to the built-in vehicle and
reads back as written, the vehicle model's fence check catches a point inside an exclusion
polygon, and a fence larger than ArduCopter's fence storage is refused before anything is sent.
The same upload against a real ArduCopter SITL is in test_ardupilot_sitl_polygons.py."""

from __future__ import annotations

import numpy as np
import pytest

from mission_planner.autopilot_params import recommended_params
from mission_planner.mission import MissionOptions, build_mission
from tests.mission_planner.solutions import airfield_solution
from tests.validator.builders import waypoint_plan
from tests.validator.mavlink.conftest import url_of
from tests.validator.test_polygon_zones import polygon_site, with_polygon_fence
from validator.audit import audit
from validator.autopilot.fence_storage import (
    ARDUPILOT_FENCE_BYTES,
    ardupilot_fence_bytes,
    fence_storage_problem,
)
from validator.errors import InputError
from validator.fence_geometry import local_fence
from validator.mavlink.link import download_plan, upload_plan
from validator.mavlink.sim.fence import breached
from validator.plan_format import FencePolygon, Plan


@pytest.fixture(scope="module")
def mission():
    m = build_mission(airfield_solution(), MissionOptions())
    assert m.safe, m.problems
    return m


def polygons_of(plan: Plan) -> list[tuple[bool, list[tuple[float, float]]]]:
    return [(p.inclusion, [(round(a, 7), round(b, 7)) for a, b in p.vertices_deg])
            for p in plan.polygons]


def test_the_exported_polygon_fences_upload_and_read_back_as_written(mission, start_vehicle):
    plan = mission.plan
    vehicle = start_vehicle(plan)
    params = {k: v for k, v in recommended_params(mission).values.items() if k.startswith("FENCE_")}
    report = upload_plan(plan, url_of(vehicle), timeout_s=5, params=params)
    vertices = sum(len(p.vertices_deg) for p in plan.polygons)  # CTR and PRISON
    assert report.counts["fence"] == vertices + 1 + 1  # and MAST, and the return point
    back = download_plan(url_of(vehicle), timeout_s=5)
    assert polygons_of(back) == polygons_of(plan)
    # written on the 1e-7 degree grid, so nothing moved on the way
    assert [p.vertices_deg for p in back.polygons] == [p.vertices_deg for p in plan.polygons]
    assert [(c.inclusion, c.radius_m) for c in back.circles] == [
        (c.inclusion, pytest.approx(c.radius_m)) for c in plan.circles]


def test_the_vehicle_model_sees_a_breach_of_an_exclusion_polygon():
    site = polygon_site()
    plan = with_polygon_fence(site, waypoint_plan(site, [(40.0, 0.0)], end="none"))
    fence = local_fence(plan, site.frame)
    assert breached(fence, np.array([120.0, 0.0]))  # inside SQ
    assert breached(fence, np.array([140.3, 0.0]))  # in the 0.5 m margin
    assert not breached(fence, np.array([140.6, 0.0]))
    assert not breached(fence, np.array([40.0, 0.0]))


def _big_fence(plan: Plan, vertices: int) -> Plan:
    """``plan`` with its fence replaced by one exclusion polygon of ``vertices`` corners and
    its return point."""
    ang = np.linspace(0.0, 2.0 * np.pi, vertices, endpoint=False)
    lat = plan.home_lat_deg + 0.003 + 0.001 * np.sin(ang)
    lon = plan.home_lon_deg + 0.001 * np.cos(ang)
    return Plan(items=plan.items, home_lat_deg=plan.home_lat_deg,
                home_lon_deg=plan.home_lon_deg, home_alt_m=plan.home_alt_m,
                polygons=[FencePolygon([(round(float(a), 7), round(float(b), 7))
                                        for a, b in zip(lat, lon, strict=True)],
                                       inclusion=False)],
                breach_return=plan.breach_return)


def test_a_fence_beyond_ardupilots_storage_is_refused_before_upload(mission, start_vehicle):
    fits, over = _big_fence(mission.plan, 68), _big_fence(mission.plan, 69)
    assert ardupilot_fence_bytes(fits) == ARDUPILOT_FENCE_BYTES
    assert fence_storage_problem(fits, ardupilot=True) is None
    problem = fence_storage_problem(over, ardupilot=True)
    assert problem is not None and "needs 568 bytes and 70 items" in problem
    assert fence_storage_problem(over, ardupilot=False) is None  # PX4 keeps far more
    assert problem in [f.message for f in audit(over, mission.solution.site).violations]
    vehicle = start_vehicle(over)
    with pytest.raises(InputError, match="^big.plan: the vehicle would not keep the plan as "
                                         "written: the geofence .* needs 568 bytes"):
        upload_plan(over, url_of(vehicle), timeout_s=5, source="big.plan")
    assert vehicle.lists().fence == () and vehicle.lists().mission == ()
