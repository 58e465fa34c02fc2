"""MAVSDK 4.x, the outside peer, imports every kind of plan we generate (no vehicle needed)."""

from __future__ import annotations

import pytest

from mission_planner.mission import MissionOptions, build_mission
from tests.mission_planner.mavsdk_peer import mavsdk_import
from tests.mission_planner.solutions import circle_tour, make_site
from validator.geodesy import to_int_e7
from validator.plan_format import Autopilot, Cmd, write_plan


@pytest.fixture(scope="module")
def site():
    return make_site()


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
@pytest.mark.parametrize("area", [None, "polygon", "circle"])
@pytest.mark.parametrize("cycles", [1, 3])
def test_mavsdk_imports_the_plan_with_every_item(tmp_path, site, autopilot, area, cycles):
    m = build_mission(circle_tour(site), MissionOptions(autopilot=autopilot, cycles=cycles,
                                                        operating_area=area))
    path = tmp_path / "mission.plan"
    write_plan(m.plan, path)
    firmware = Autopilot.ARDUPILOTMEGA if autopilot == "ardupilot" else Autopilot.PX4
    data = mavsdk_import(path, int(firmware))

    home = 1 if autopilot == "ardupilot" else 0
    assert len(data.mission_items) == len(m.plan.items) + home
    assert [it.command for it in data.mission_items[home:]] == [it.command for it in m.plan.items]
    vertices = sum(len(p.vertices_deg) for p in m.plan.polygons)
    assert len(data.geofence_items) == site.num_nfzs + (area == "circle") + vertices
    exclusions = [it for it in data.geofence_items if it.command == Cmd.NAV_FENCE_CIRCLE_EXCLUSION]
    assert len(exclusions) == site.num_nfzs
    assert [it.param1 for it in exclusions] == pytest.approx(
        list(site.nfz_radius_m + site.buffer_m / 2))
    assert len(data.rally_items) == 1
    assert data.rally_items[0].command == Cmd.NAV_RALLY_POINT

    for ours, theirs in zip(m.plan.items, data.mission_items[home:], strict=True):
        if ours.command in (Cmd.NAV_WAYPOINT, Cmd.NAV_TAKEOFF, Cmd.NAV_LAND):
            assert (theirs.x, theirs.y) == tuple(to_int_e7([ours.lat_deg, ours.lon_deg]))
        if ours.command == Cmd.DO_CHANGE_SPEED:
            assert theirs.param2 == pytest.approx(ours.params[1], rel=1e-6)
            assert theirs.param2 <= site.max_speed_mps
    jumps = [it for it in data.mission_items if it.command == Cmd.DO_JUMP]
    assert len(jumps) == (cycles > 1)


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
def test_mavsdk_imports_polygon_exclusion_fences_vertex_by_vertex(tmp_path, autopilot):
    from tests.mission_planner.solutions import airfield_solution

    m = build_mission(airfield_solution(), MissionOptions(autopilot=autopilot))
    assert len(m.plan.polygons) == 2  # the airfield's CTR and its airspace file's PRISON
    path = tmp_path / "airfield.plan"
    write_plan(m.plan, path)
    firmware = Autopilot.ARDUPILOTMEGA if autopilot == "ardupilot" else Autopilot.PX4
    data = mavsdk_import(path, int(firmware))

    vertices = [it for it in data.geofence_items
                if it.command == Cmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION]
    want = [(len(p.vertices_deg), *to_int_e7(v)) for p in m.plan.polygons
            for v in p.vertices_deg]
    assert [(int(it.param1), it.x, it.y) for it in vertices] == want
    circles = [it for it in data.geofence_items if it.command == Cmd.NAV_FENCE_CIRCLE_EXCLUSION]
    assert len(circles) == 1  # MAST
