
import dataclasses

import pytest

from tests.validator.mavlink.conftest import FakeVehicle, free_udp_port, url_of
from validator.autopilot.param_file import parse_params
from validator.errors import InputError
from validator.mavlink.link import (
    Link,
    LinkError,
    VehicleInfo,
    download_plan,
    upload_plan,
    upload_to,
)
from validator.mavlink.wire import MissionType, mavlink, plan_to_wire
from validator.plan_format import Autopilot, Cmd, Frame, MissionItem


def test_upload_then_read_back_is_identical(plan, start_vehicle):
    vehicle = start_vehicle(plan)
    report = upload_plan(plan, url_of(vehicle), timeout_s=5)
    assert report.counts == {"mission": 7, "fence": 6, "rally": 2}
    held = vehicle.lists()
    sent = plan_to_wire(plan, home_item=True)
    for t in MissionType:
        assert [w.content() for w in held.of(t)] == [w.content() for w in sent.of(t)]


def test_still_identical_with_20_percent_packet_loss(plan, start_vehicle):
    vehicle = start_vehicle(plan, loss=0.2, seed=7)
    with Link(url_of(vehicle), timeout_s=10, retry_s=0.1) as link:
        upload_to(link, plan)  # raises unless the read-back is identical
    assert vehicle.writer.dropped > 0 and vehicle.rx_dropped > 0
    sent = plan_to_wire(plan, home_item=True)
    assert [w.content() for w in vehicle.lists().mission] == [w.content() for w in sent.mission]


def test_download_gives_back_the_plan(plan, start_vehicle):
    vehicle = start_vehicle(plan)
    upload_plan(plan, url_of(vehicle), timeout_s=5)
    back = download_plan(url_of(vehicle), timeout_s=5)
    assert [it.command for it in back.items] == [it.command for it in plan.items]
    assert len(back.circles) == 1 and len(back.polygons) == 1 and len(back.rally) == 2
    assert back.home_lat_deg == pytest.approx(plan.home_lat_deg, abs=1e-7)


def test_parameters_are_set_and_read_back(plan, start_vehicle):
    vehicle = start_vehicle(plan)
    report = upload_plan(plan, url_of(vehicle), timeout_s=5,
                         params={"WPNAV_SPEED": 750.0, "FENCE_ACTION": 4.0})
    assert report.params == {"WPNAV_SPEED": 750.0, "FENCE_ACTION": 4.0}
    assert vehicle.params["WPNAV_SPEED"][0] == 750.0


def test_a_value_the_vehicle_refuses_is_reported(plan, start_vehicle):
    vehicle = start_vehicle(plan)
    with pytest.raises(LinkError, match="parameter WPNAV_ACCEL: set -5, vehicle holds 250"):
        with Link(url_of(vehicle), timeout_s=3, retry_s=0.1) as link:
            link.set_param("WPNAV_ACCEL", -5.0)


def test_dead_link_fails_within_the_timeout(plan):
    # the failure names the deadline it kept; the time it takes is a benchmark figure
    with pytest.raises(LinkError, match="no heartbeat within 1 s"):
        upload_plan(plan, f"udpout:127.0.0.1:{free_udp_port()}", timeout_s=1.0)


def test_wrong_system_id_is_named(plan, start_vehicle):
    vehicle = start_vehicle(plan, system_id=3)
    with pytest.raises(LinkError, match=r"no vehicle with system id 9 .*heard system id 3"):
        upload_plan(plan, url_of(vehicle), timeout_s=2.5, sysid=9)  # heartbeats come at 1 Hz
    assert upload_plan(plan, url_of(vehicle), timeout_s=5, sysid=3).vehicle.system_id == 3


def test_nack_is_reported_by_its_result_name(plan):
    with FakeVehicle(nack=mavlink.MAV_MISSION_INVALID_PARAM1) as fake:
        with pytest.raises(LinkError, match="mission upload: vehicle rejected it with "
                                            "MAV_MISSION_INVALID_PARAM1"):
            upload_plan(plan, fake.url, timeout_s=2)


def test_vehicle_going_silent_half_way_is_a_failure_within_the_timeout(plan):
    with FakeVehicle(silent_after=3) as fake:
        with pytest.raises(LinkError, match="mission upload: vehicle stopped answering after "
                                            r"mission item 2 \(3 of 7 sent\) \(no reply for "
                                            r"1.5 s\); upload incomplete"):
            upload_plan(plan, fake.url, timeout_s=1.5)
        assert fake.lists[0] == []  # the vehicle never got a complete mission


def test_read_back_difference_fails_the_upload(plan):
    with FakeVehicle(corrupt_seq=3) as fake:
        with pytest.raises(LinkError, match=r"read-back differs from the upload: mission item "
                                            r"3: param2 expected \(as ArduPilot stores what we "
                                            r"sent\) 0.0, vehicle holds 1.0"):
            upload_plan(plan, fake.url, timeout_s=2, require_fence=False)


def test_a_fake_vehicle_that_behaves_passes(plan):
    with FakeVehicle() as fake:
        assert upload_plan(plan, fake.url, timeout_s=2,
                           require_fence=False).counts["mission"] == 7


def test_a_booting_vehicle_that_has_no_room_yet_is_asked_again(plan):
    with FakeVehicle(booting=2) as fake:
        upload_plan(plan, fake.url, timeout_s=2, require_fence=False)
        assert fake.booting == 0 and len(fake.lists[0]) == 7


def test_a_vehicle_without_room_for_the_plan_is_a_clear_failure(plan):
    with FakeVehicle(nack=mavlink.MAV_MISSION_NO_SPACE, room=5) as fake:
        with pytest.raises(LinkError, match="vehicle rejected it with MAV_MISSION_NO_SPACE: it "
                                            "has room for 5 items, the plan needs 7"):
            upload_plan(plan, fake.url, timeout_s=2)


def test_an_upload_that_leaves_the_fence_report_only_fails(plan, start_vehicle):
    vehicle = start_vehicle(plan, params={"FENCE_ACTION": 0.0})
    with pytest.raises(LinkError, match=r"geofence is not protecting it: FENCE_ACTION is 0 "
                                        r"\(Report Only\)"):
        upload_plan(plan, url_of(vehicle), timeout_s=5)
    assert vehicle.lists().fence  # the mission is there: the failure says so
    report = upload_plan(plan, url_of(vehicle), timeout_s=5, params={"FENCE_ACTION": 5.0})
    assert report.params == {"FENCE_ACTION": 5.0}


def test_an_item_a_px4_vehicle_refuses_for_its_frame_is_not_sent(plan):
    """PX4 refuses an RTL in a global frame (frames.py): the upload stops before sending,
    naming the item, by the vehicle's autopilot whatever the plan's firmware, even an item
    the mission never reaches (PX4 refuses the whole upload for it)."""
    rtl = MissionItem(int(Cmd.NAV_RETURN_TO_LAUNCH), [0.0] * 7, int(Frame.GLOBAL_RELATIVE_ALT))

    class Px4Link:
        vehicle = VehicleInfo(1, 1, int(Autopilot.PX4), 2)

        def upload(self, _sent: object) -> None:
            pytest.fail("the plan was sent")

    with pytest.raises(InputError, match=r"^m\.plan: item 7: PX4 takes NAV_RETURN_TO_LAUNCH "
                                         r"only in frame 2 \(MISSION\)"):
        upload_to(Px4Link(), dataclasses.replace(plan, items=[*plan.items, rtl]),
                  source="m.plan")


def test_a_fence_switched_off_fails_and_the_check_can_be_waived(plan, start_vehicle):
    vehicle = start_vehicle(plan, params={"FENCE_ENABLE": 0.0})
    with pytest.raises(LinkError, match="FENCE_ENABLE is 0, not 1: the uploaded fence is "
                                        "inactive"):
        upload_plan(plan, url_of(vehicle), timeout_s=5)
    upload_plan(plan, url_of(vehicle), timeout_s=5, require_fence=False)


def test_param_file_formats():
    text = ("# ArduPilot\nWPNAV_SPEED 1000\nWPNAV_ACCEL,250.5  # comment\n\n"
            "1\t1\tMPC_ACC_HOR\t3.0\t9\n")
    assert parse_params(text) == {"WPNAV_SPEED": 1000.0, "WPNAV_ACCEL": 250.5,
                                  "MPC_ACC_HOR": 3.0}


@pytest.mark.parametrize("text, message", [
    ("WPNAV_SPEED", r"f.param:1: expected 'NAME VALUE'"),
    ("WPNAV SPEED 3", r"f.param:1: expected 'NAME VALUE'"),
    ("WPNAV_SPEED fast", r"f.param:1: WPNAV_SPEED: 'fast' is not a number"),
    ("A_NAME_MUCH_TOO_LONG 1", r"f.param:1: 'A_NAME_MUCH_TOO_LONG' is not a parameter name"),
    ("X 1\nY nan", r"f.param:2: Y: value must be finite"),
])
def test_bad_param_files_name_the_line(text, message):
    with pytest.raises(InputError, match=message):
        parse_params(text, "f.param")


def test_a_plan_file_is_not_a_connection(tmp_path, plan):
    path = tmp_path / "mission.plan"
    path.write_text("{}")
    with pytest.raises(LinkError, match="is a file, not a connection"):
        upload_plan(plan, str(path), timeout_s=1)


def test_a_plan_without_fence_or_rally_clears_the_vehicles(plan, start_vehicle):
    vehicle = start_vehicle(plan)
    upload_plan(plan, url_of(vehicle), timeout_s=5)
    plan.circles, plan.polygons, plan.rally, plan.breach_return = [], [], [], None
    upload_plan(plan, url_of(vehicle), timeout_s=5)
    assert vehicle.lists().fence == () and vehicle.lists().rally == ()


def test_download_restarts_when_the_vehicle_abandons_it(plan):
    with FakeVehicle(drop_download_at=4) as fake:
        with Link(fake.url, timeout_s=8, retry_s=0.1) as link:
            sent = plan_to_wire(plan, home_item=True)
            link.upload(sent)
            held = link.download_list(MissionType.MISSION)
        assert [w.content() for w in held] == [w.content() for w in sent.mission]
        assert fake.list_requests == 2


def test_a_vehicle_that_never_sends_items_fails_within_the_timeout(plan):
    with FakeVehicle(mute_items=True) as fake:
        with pytest.raises(LinkError, match="mission download: no answer to the request for "
                                            r"mission item 0 \(1 of 7\) "
                                            "within 4 s"):
            with Link(fake.url, timeout_s=4, retry_s=0.1) as link:
                link.upload(plan_to_wire(plan, home_item=True))
                link.download_list(MissionType.MISSION)
