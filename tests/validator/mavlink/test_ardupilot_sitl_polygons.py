"""Polygon exclusion fences on the real ArduCopter firmware: the exporter's fence for the
airfield sample uploads with the fence switched on and reads back exactly as written, and
ArduCopter's fence storage holds exactly what validator.autopilot.fence_storage says it does.

Runs an ArduCopter SITL binary built for this machine (``$ARDUPILOT_SITL``, else
``/opt/sitl/arducopter``); skipped without one.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mission_planner.autopilot_params import recommended_params
from mission_planner.mission import MissionOptions, build_mission
from tests.mission_planner.solutions import airfield_solution
from tests.validator.mavlink.sitl_binaries import sitl_binary
from tests.validator.mavlink.test_polygon_fence import _big_fence
from validator.autopilot.fence_storage import ARDUPILOT_FENCE_BYTES, ardupilot_fence_bytes
from validator.mavlink.link import Link, LinkError, download_from, upload_to
from validator.mavlink.sitl_process import ardupilot_sitl, find_defaults
from validator.mavlink.storage import first_stored_difference
from validator.mavlink.wire import MissionType, plan_to_wire

BINARY = sitl_binary("ARDUPILOT_SITL", Path("/opt/sitl/arducopter"))
pytestmark = [pytest.mark.realtime, pytest.mark.xdist_group("real-sitl"), pytest.mark.skipif(
    BINARY is None,
    reason="no ArduCopter SITL binary: set ARDUPILOT_SITL=/path/to/arducopter (or link it at "
           "/opt/sitl/arducopter) to run the real-autopilot tests")]


@pytest.fixture(scope="module")
def mission():
    m = build_mission(airfield_solution(), MissionOptions())
    assert m.safe, m.problems
    return m


@pytest.fixture(scope="module")
def sitl_url(mission):
    plan = mission.plan
    assert BINARY is not None
    with ardupilot_sitl(BINARY, (plan.home_lat_deg, plan.home_lon_deg, plan.home_alt_m),
                        speedup=10.0, defaults=find_defaults(BINARY)) as url:
        yield url


def test_polygon_fences_upload_switched_on_and_read_back_as_written(mission, sitl_url):
    plan = mission.plan
    params = {k: v for k, v in recommended_params(mission).values.items()
              if k.startswith("FENCE_")}
    with Link(sitl_url, timeout_s=20) as link:
        report = upload_to(link, plan, params)  # verifies every item as ArduCopter stores it
        vertices = sum(len(p.vertices_deg) for p in plan.polygons)
        assert report.counts["fence"] == vertices + len(plan.circles) + 1  # + return point
        assert link.read_param("FENCE_TYPE").value == 4.0  # polygons and circles
        back = download_from(link)
    assert [(p.inclusion, p.vertices_deg) for p in back.polygons] == [
        (p.inclusion, p.vertices_deg) for p in plan.polygons]
    assert [(c.inclusion, c.radius_m) for c in back.circles] == [
        (c.inclusion, pytest.approx(c.radius_m, rel=1e-6)) for c in plan.circles]


def test_ardupilots_fence_storage_holds_560_bytes_and_no_more(mission, sitl_url):
    fits, over = _big_fence(mission.plan, 68), _big_fence(mission.plan, 69)
    assert ardupilot_fence_bytes(fits) == ARDUPILOT_FENCE_BYTES
    with Link(sitl_url, timeout_s=20) as link:
        sent = plan_to_wire(fits, home_item=True)
        link.upload_list(sent.fence, MissionType.FENCE)
        held = link.download_list(MissionType.FENCE)
        assert len(held) == 69
        assert first_stored_difference(sent.fence, held, MissionType.FENCE,
                                       link.vehicle.autopilot, skip_seq0=False) is None
        # forced past our own refusal, the vehicle refuses the 69-vertex fence (568 bytes)
        # itself, at its last item, when it writes the whole fence to storage
        with pytest.raises(LinkError, match="rejected it with MAV_MISSION_ERROR at fence item 69"):
            link.upload_list(plan_to_wire(over, home_item=True).fence, MissionType.FENCE)
