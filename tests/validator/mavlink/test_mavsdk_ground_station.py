"""MAVSDK 4.x as the outside ground station: what it uploads, sitl-vehicle holds, and what
sitl-vehicle holds, it downloads."""

import time

import pytest
from mavsdk import ComponentType, Configuration, Mavsdk
from mavsdk.plugins.mission_raw import MissionItem, MissionRaw

from tests.validator.mavlink.conftest import url_of
from validator.mavlink.link import upload_plan
from validator.mavlink.wire import WireItem, plan_to_wire


def _as_mavsdk(w: WireItem) -> MissionItem:
    return MissionItem(w.seq, w.frame, w.command, w.current, w.autocontinue, w.param1, w.param2,
                       w.param3, w.param4, w.x, w.y, w.z, w.mission_type)


def _content(items) -> list[tuple]:
    return [WireItem(i.seq, i.frame, i.command, i.param1, i.param2, i.param3, i.param4, i.x, i.y,
                     i.z, i.mission_type, i.autocontinue).content() for i in items]


@pytest.fixture()
def ground_station(plan, start_vehicle):
    vehicle = start_vehicle(plan)
    port = vehicle.address[1]
    gcs = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    gcs.add_any_connection(f"udpout://127.0.0.1:{port}")
    system = gcs.first_autopilot(5.0)
    assert system is not None, "MAVSDK did not see sitl-vehicle's heartbeat"
    yield vehicle, MissionRaw(system)
    gcs.destroy()


def test_mavsdk_upload_is_what_the_vehicle_holds(plan, ground_station):
    vehicle, mission_raw = ground_station
    wire = plan_to_wire(plan, home_item=True)
    mission_raw.upload_mission([_as_mavsdk(w) for w in wire.mission])
    mission_raw.upload_geofence([_as_mavsdk(w) for w in wire.fence])
    deadline = time.monotonic() + 2.0  # the vehicle stores a list just after its final ACK
    while not vehicle.lists().fence and time.monotonic() < deadline:
        time.sleep(0.01)
    held = vehicle.lists()
    assert [w.content() for w in held.mission] == [w.content() for w in wire.mission]
    assert [w.content() for w in held.fence] == [w.content() for w in wire.fence]


def test_mavsdk_downloads_what_upload_mission_sent(plan, ground_station):
    vehicle, mission_raw = ground_station
    upload_plan(plan, url_of(vehicle), timeout_s=5)
    wire = plan_to_wire(plan, home_item=True)
    assert _content(mission_raw.download_mission()) == [w.content() for w in wire.mission]
    assert _content(mission_raw.download_geofence()) == [w.content() for w in wire.fence]
    assert _content(mission_raw.download_rallypoints()) == [w.content() for w in wire.rally]
