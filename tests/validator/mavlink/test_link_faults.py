"""Fault injection on the link: a mangled stream, duplicates, impostors, stray and wrong-type
ACKs, NACKs at every step, a reboot mid-upload. Every case ends in an upload verified by its
read-back or a clear :class:`LinkError` (exit 2 from the command) within the timeout, and
leaves no thread behind."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest

from tests.validator.mavlink.conftest import FakeVehicle, FaultyWire, url_of
from validator.mavlink.cli import upload_mission_main
from validator.mavlink.link import Link, LinkError, upload_plan, upload_to, verify_lists
from validator.mavlink.wire import MissionType, mavlink, plan_to_wire
from validator.plan_format import Plan, write_plan


@pytest.fixture(autouse=True)
def no_thread_left_behind() -> Iterator[None]:
    before = set(threading.enumerate())
    yield
    deadline = time.monotonic() + 5.0  # a stopping thread may need a moment to end
    while set(threading.enumerate()) - before and time.monotonic() < deadline:
        time.sleep(0.05)
    assert set(threading.enumerate()) - before == set()


def held_as_sent(held: list, sent: tuple) -> bool:
    return [w.content() for w in held] == [w.content() for w in sent]


# -- a mangled stream ----------------------------------------------------------------------


def test_garbage_and_truncated_packets_from_the_builtin_vehicle(plan, start_vehicle):
    vehicle = start_vehicle(plan)
    wire = FaultyWire(vehicle.writer.conn, garbage=0.2, truncate=0.1, seed=11)
    vehicle.writer.conn = wire
    with Link(url_of(vehicle), timeout_s=15, retry_s=0.1) as link:
        upload_to(link, plan)  # raises unless the read-back is identical
    assert wire.mangled > 10
    sent = plan_to_wire(plan, home_item=True)
    assert held_as_sent(list(vehicle.lists().mission), sent.mission)


def test_garbage_and_truncated_packets_from_the_fake_vehicle(plan):
    wire = FaultyWire(garbage=0.2, truncate=0.1, seed=5)
    with FakeVehicle(wire=wire) as fake:
        with Link(fake.url, timeout_s=15, retry_s=0.1) as link:
            sent = plan_to_wire(plan, home_item=True)
            link.upload(sent)
            verify_lists(link, sent)
        assert wire.mangled > 10
        assert held_as_sent(fake.lists[0], sent.mission)


def test_garbage_from_the_ground_station_side_is_ignored(plan, start_vehicle):
    vehicle = start_vehicle(plan)
    with Link(url_of(vehicle), timeout_s=15, retry_s=0.1) as link:
        wire = FaultyWire(link.conn, garbage=0.3, truncate=0.15, seed=3)
        link.mav.file = wire
        sent = plan_to_wire(plan, home_item=True)
        link.upload(sent)
        link.mav.file = link.conn  # read back over a clean link: the test is the upload
        verify_lists(link, sent)
    assert wire.mangled > 5


# -- duplicates ----------------------------------------------------------------------------


def test_every_packet_from_the_builtin_vehicle_twice(plan, start_vehicle):
    vehicle = start_vehicle(plan)
    vehicle.writer.conn = FaultyWire(vehicle.writer.conn, duplicate=True)
    with Link(url_of(vehicle), timeout_s=10, retry_s=0.1) as link:
        upload_to(link, plan)
    assert held_as_sent(list(vehicle.lists().mission), plan_to_wire(plan, home_item=True).mission)


def test_every_packet_both_ways_twice_with_the_fake_vehicle(plan):
    with FakeVehicle(wire=FaultyWire(duplicate=True)) as fake:
        with Link(fake.url, timeout_s=10, retry_s=0.1) as link:
            link.mav.file = FaultyWire(link.conn, duplicate=True)
            sent = plan_to_wire(plan, home_item=True)
            link.upload(sent)
            verify_lists(link, sent)
        assert held_as_sent(fake.lists[0], sent.mission)


def test_every_packet_both_ways_twice_with_the_builtin_vehicle(plan, start_vehicle):
    vehicle = start_vehicle(plan)
    vehicle.writer.conn = FaultyWire(vehicle.writer.conn, duplicate=True)
    with Link(url_of(vehicle), timeout_s=10, retry_s=0.1) as link:
        link.mav.file = FaultyWire(link.conn, duplicate=True)
        upload_to(link, plan)
    assert held_as_sent(list(vehicle.lists().mission), plan_to_wire(plan, home_item=True).mission)


# -- reordered requests ---------------------------------------------------------------------


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_items_requested_out_of_order_are_sent_as_asked(plan, seed):
    with FakeVehicle(reorder_seed=seed) as fake:
        upload_plan(plan, fake.url, timeout_s=10, require_fence=False)
        assert held_as_sent(fake.lists[0], plan_to_wire(plan, home_item=True).mission)


# -- other system ids ----------------------------------------------------------------------


def test_heartbeat_flood_from_other_systems_with_sysid(plan):
    with FakeVehicle(sysid=7, impostors=(1, 2, 3, 200)) as fake:
        report = upload_plan(plan, fake.url, timeout_s=10, sysid=7, require_fence=False)
        assert report.vehicle.system_id == 7
        assert fake.impostor_nacks > 0  # the impostors did NACK, and were not listened to
        assert len(fake.lists[0]) == 7


def test_heartbeat_flood_from_other_systems_without_sysid(plan):
    """Without --sysid the link takes the first autopilot heard: here an impostor that floods
    heartbeats and NACKs. The failure names the other system ids and --sysid, rather than
    leaving the user to guess why a working vehicle refused."""
    with FakeVehicle(sysid=7, impostors=(2,)) as fake:
        with pytest.raises(LinkError, match=r"^mission upload: vehicle rejected it with "
                                            r"MAV_MISSION_ERROR \(talking to system id 2; also "
                                            r"heard system id 7: choose one with --sysid\)$"):
            upload_plan(plan, fake.url, timeout_s=5, require_fence=False)
        assert fake.lists[0] == []


# -- ACKs of the wrong mission type ----------------------------------------------------------


def test_stray_acks_of_other_mission_types_are_ignored(plan):
    with FakeVehicle(stray_acks=True) as fake:
        upload_plan(plan, fake.url, timeout_s=10, require_fence=False)
        sent = plan_to_wire(plan, home_item=True)
        assert [len(fake.lists[t]) for t in (0, 1, 2)] == [7, 6, 2]
        assert held_as_sent(fake.lists[1], sent.fence)


def test_a_final_ack_of_the_wrong_type_leaves_it_to_the_read_back(plan):
    # The vehicle holds the mission but ACKs it as a fence: the read-back decides.
    with FakeVehicle(ack_type=int(MissionType.FENCE)) as fake:
        upload_plan(plan, fake.url, timeout_s=10, require_fence=False)
        assert held_as_sent(fake.lists[0], plan_to_wire(plan, home_item=True).mission)


# -- NACKs at each step --------------------------------------------------------------------


@pytest.mark.parametrize("after, where", [
    # the fake vehicle is an ArduPilot: its seq is the item number (0: home)
    (0, ""), (1, " at mission item 0"), (4, " at mission item 3"), (7, " at mission item 6"),
])
@pytest.mark.parametrize("result", [mavlink.MAV_MISSION_ERROR, mavlink.MAV_MISSION_DENIED])
def test_a_nack_at_each_step_fails_naming_it(plan, tmp_path, capsys, after, where, result):
    path = tmp_path / "m.plan"
    write_plan(plan, path)
    name = mavlink.enums["MAV_MISSION_RESULT"][result].name
    with FakeVehicle(nack=result, nack_after=after) as fake:
        status = upload_mission_main([str(path), "--connect", fake.url, "--timeout", "5"])
        assert fake.lists[0] == []
    assert status == 2
    assert capsys.readouterr().err == (f"upload-mission: mission upload: vehicle rejected it "
                                       f"with {name}{where}\n")


@pytest.mark.parametrize("after", [0, 3, 7])
def test_a_restartable_nack_every_time_gives_up_clearly(plan, after):
    with FakeVehicle(nack=mavlink.MAV_MISSION_INVALID_SEQUENCE, nack_after=after) as fake:
        with pytest.raises(LinkError, match="mission upload: gave up after 5 attempts"):
            upload_plan(plan, fake.url, timeout_s=10)
        assert fake.lists[0] == []


# -- a reboot mid-upload -------------------------------------------------------------------


def stale_plan(plan: Plan) -> list:
    """An older mission the vehicle holds before the upload: the plan's first three items."""
    return list(plan_to_wire(plan, home_item=True).mission[:3])


@pytest.mark.parametrize("at", [0, 3])
def test_a_reboot_mid_upload_is_recovered_and_verified(plan, at):
    fake = FakeVehicle(reboot_at=at, reboot_gap_s=1.5)
    fake.lists[0] = stale_plan(plan)
    with fake:
        upload_plan(plan, fake.url, timeout_s=10, require_fence=False)
        assert fake.reboots == 1
        assert held_as_sent(fake.lists[0], plan_to_wire(plan, home_item=True).mission)


def test_a_reboot_before_the_final_ack_never_reports_success(plan):
    # The last item reaches a vehicle that is rebooting; it comes back with the old mission,
    # ignores the repeated last item and never ACKs: only the read-back can tell.
    fake = FakeVehicle(reboot_at=6, reboot_gap_s=1.5)
    fake.lists[0] = stale_plan(plan)
    with fake:
        with pytest.raises(LinkError, match="read-back differs from the upload: mission"):
            upload_plan(plan, fake.url, timeout_s=10, require_fence=False)
        assert fake.reboots == 1
        assert held_as_sent(fake.lists[0], tuple(stale_plan(plan)))


# -- ArduPilot's NACKs on a bad link ---------------------------------------------------------


def test_a_lost_final_ack_and_ardupilots_error_to_the_repeated_item_still_verify(plan):
    # ArduPilot answers the repeated last item with MAV_MISSION_ERROR once its transfer is
    # complete: the list is read back at once, and the vehicle holds it (a vehicle that does
    # not: test_a_nack_at_each_step_fails_naming_it, the NACK after item 6)
    with FakeVehicle(ardupilot_nacks=True, lose_final_acks=3) as fake:
        report = upload_plan(plan, fake.url, timeout_s=10, require_fence=False)
        sent = plan_to_wire(plan, home_item=True)
        assert report.counts == {"mission": 7, "fence": 6, "rally": 2}
        assert [held_as_sent(fake.lists[t], sent.of(t)) for t in MissionType] == [True] * 3


def test_invalid_sequence_for_each_duplicated_item_does_not_restart_the_transfer(plan):
    with FakeVehicle(ardupilot_nacks=True) as fake:
        with Link(fake.url, timeout_s=10, retry_s=0.1) as link:
            link.mav.file = FaultyWire(link.conn, duplicate=True)  # every item arrives twice
            sent = plan_to_wire(plan, home_item=True)
            link.upload(sent)
            link.mav.file = link.conn
            verify_lists(link, sent)
        # MISSION_COUNT arrives twice per list (duplicated too), never more: no restart
        assert fake.counts_received == 2 * 3
        assert held_as_sent(fake.lists[0], sent.mission)

