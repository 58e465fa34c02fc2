"""The lossy relay itself, and the ground station through it: against the built-in vehicle,
an upload with read-back either succeeds with the vehicle holding every list as sent, or fails
with one line; it never reports a mission the vehicle does not hold."""

from __future__ import annotations

import socket

import pytest

from tests.validator.mavlink.conftest import url_of
from validator.errors import InputError
from validator.mavlink.link import Link, LinkError, upload_to
from validator.mavlink.lossy_relay import (
    LinkFaults,
    LossyRelay,
    acked_command,
    main,
    message_id,
    split_packets,
)
from validator.mavlink.wire import MissionType, mavlink, plan_to_wire


def packet(seq: int, *, signed: bool = False) -> bytes:
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    if signed:
        mav.signing.secret_key = bytes(32)
        mav.signing.sign_outgoing = True
    mav.seq = seq
    return bytes(mav.heartbeat_encode(2, 3, 0, seq, 4).pack(mav))


# -- the packet splitter -----------------------------------------------------------------


def test_a_tcp_stream_is_cut_into_whole_packets():
    a, b, c = packet(1), packet(2, signed=True), packet(3)
    stream = bytearray(b"\x00junk" + a + b + c[:5])
    assert split_packets(stream) == [a, b]
    assert stream == bytearray(c[:5])  # the incomplete packet waits for the rest
    stream += c[5:]
    assert split_packets(stream) == [c]
    assert stream == bytearray()


def test_a_packets_message_id_is_read_in_both_versions():
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    land = bytes(mav.command_long_encode(1, 1, mavlink.MAV_CMD_DO_SET_MODE, 0, 1, 9, 0, 0, 0,
                                         0, 0).pack(mav))
    assert message_id(land) == mavlink.MAVLINK_MSG_ID_COMMAND_LONG
    assert message_id(packet(1)) == mavlink.MAVLINK_MSG_ID_HEARTBEAT
    mav1 = mavlink.MAVLink(None, srcSystem=1, srcComponent=1, use_native=False)
    mav1.WIRE_PROTOCOL_VERSION = "1.0"
    v1 = bytes(mav1.heartbeat_encode(2, 3, 0, 0, 4).pack(mav1, force_mavlink1=True))
    assert v1[0] == 0xFE and message_id(v1) == mavlink.MAVLINK_MSG_ID_HEARTBEAT
    assert message_id(b"junk") is None


def test_the_command_a_command_ack_answers_is_read_even_when_mavlink2_trims_it():
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)

    def ack(command: int) -> bytes:
        return bytes(mav.command_ack_encode(command, mavlink.MAV_RESULT_ACCEPTED).pack(mav))

    set_mode = ack(mavlink.MAV_CMD_DO_SET_MODE)
    assert set_mode[1] == 1  # 176 with ACCEPTED (0) after it: one payload byte left
    assert acked_command(set_mode) == mavlink.MAV_CMD_DO_SET_MODE
    assert acked_command(ack(mavlink.MAV_CMD_MISSION_START)) == mavlink.MAV_CMD_MISSION_START
    assert acked_command(packet(1)) is None


def test_a_mavlink1_packet_is_whole_too():
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    mav.WIRE_PROTOCOL_VERSION = "1.0"
    v1 = bytes(mavlink.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3).pack(mav, force_mavlink1=True))
    assert v1[0] == 0xFE
    assert split_packets(bytearray(v1 + v1)) == [v1, v1]


# -- the relay -----------------------------------------------------------------------------


@pytest.mark.parametrize("url", ["tcp:10.0.0.1:5760", "udpout:192.168.1.2:14550",
                                 "serial:/dev/ttyUSB0", "tcp:127.0.0.1"])
def test_only_loopback_addresses_are_relayed(url):
    with pytest.raises(InputError, match="--upstream"):
        LossyRelay(url, LinkFaults())


def test_bad_fault_rates_are_refused():
    with pytest.raises(InputError, match="--drop: must be in"):
        LinkFaults(drop=1.0)
    with pytest.raises(InputError, match="--duplicate"):
        LinkFaults(duplicate=-0.1)


def test_the_command_refuses_bad_input_in_one_line(capsys):
    assert main(["--upstream", "tcp:8.8.8.8:5760"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "loopback" in err


def test_the_relay_stops_by_itself():
    relay = LossyRelay("udpout:127.0.0.1:9", LinkFaults(), duration_s=0.2)
    relay.thread.join(5.0)
    assert not relay.thread.is_alive()


def relay_counts(seed: int, faults: LinkFaults, n: int = 400) -> tuple[int, tuple]:
    """Send ``n`` numbered datagrams through a relay to a UDP sink; what arrived, and stats."""
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    sink.settimeout(0.3)
    gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    got: list[bytes] = []

    def drain() -> None:
        try:
            while True:
                got.append(sink.recv(1000))
        except TimeoutError:
            pass

    with LossyRelay(f"udpout:127.0.0.1:{sink.getsockname()[1]}", faults, seed=seed) as relay:
        for i in range(n):
            gcs.sendto(packet(i % 256), ("127.0.0.1", relay.port))
            if i % 50 == 49:
                drain()  # the sink's socket buffer is not what is tested
        drain()
        stats = relay.stats
    sink.close()
    gcs.close()
    return len(got), (stats[0].passed, stats[0].dropped, stats[0].duplicated,
                      stats[0].reordered)


def test_faults_are_applied_counted_and_repeat_with_the_seed():
    faults = LinkFaults(drop=0.2, duplicate=0.1, reorder=0.1, reorder_s=0.05, delay_s=0.01)
    arrived, (passed, dropped, duplicated, reordered) = relay_counts(7, faults)
    assert passed + dropped == 400
    assert 40 < dropped < 120 and duplicated > 10 and reordered > 10
    assert arrived == passed + duplicated  # every packet passed on arrived, twice if doubled
    assert relay_counts(7, faults)[1] == (passed, dropped, duplicated, reordered)
    assert relay_counts(8, faults)[1] != (passed, dropped, duplicated, reordered)


def test_a_cut_link_passes_nothing_until_restored():
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    sink.settimeout(0.3)
    gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    with LossyRelay(f"udpout:127.0.0.1:{sink.getsockname()[1]}", LinkFaults()) as relay:
        relay.cut()
        gcs.sendto(packet(1), ("127.0.0.1", relay.port))
        with pytest.raises(TimeoutError):
            sink.recv(1000)
        relay.restore()
        gcs.sendto(packet(2), ("127.0.0.1", relay.port))
        assert sink.recv(1000) == packet(2)
        assert relay.outage_drops == 1
    sink.close()
    gcs.close()


# -- uploads through it --------------------------------------------------------------------


def held_lists(vehicle) -> dict:
    lists = vehicle.lists()
    return {t: [w.content() for w in lists.of(t)] for t in MissionType}


def sent_lists(plan) -> dict:
    sent = plan_to_wire(plan, home_item=True)
    return {t: [w.content() for w in sent.of(t)] for t in MissionType}


@pytest.mark.parametrize("rate", [0.05, 0.2, 0.3])
def test_uploads_through_a_lossy_link_are_verified_or_fail_in_one_line(plan, start_vehicle,
                                                                       rate):
    outcomes: list[str] = []
    for seed in range(4):
        if len(outcomes) >= 2 and "verified" in outcomes:
            break  # two tries at least; more only while none has verified
        vehicle = start_vehicle(plan)
        with LossyRelay(url_of(vehicle), LinkFaults.lossy(rate), seed=seed,
                        duration_s=120) as relay:
            try:
                with Link(relay.url, timeout_s=10) as link:
                    upload_to(link, plan)
            except LinkError as err:
                assert "\n" not in str(err)
                outcomes.append(str(err))
            else:
                # the claim of success is checked against what the vehicle itself holds
                assert held_lists(vehicle) == sent_lists(plan)
                outcomes.append("verified")
        vehicle.stop()
    # (the built-in vehicle's MAVSDK mission server sometimes stalls a download on a lossy
    # link until it is reopened, at 30 % twice running under CI's load: a failure in one
    # line is allowed, a false success never, and one of up to four tries must verify)
    assert "verified" in outcomes, outcomes


def test_an_outage_mid_upload_shorter_than_the_timeout_is_ridden_out(plan, start_vehicle):
    vehicle = start_vehicle(plan)
    with LossyRelay(url_of(vehicle), LinkFaults.lossy(0.05), seed=3,
                    outages=[(1.0, 3.0)]) as relay:
        with Link(relay.url, timeout_s=8) as link:
            upload_to(link, plan)
        assert relay.outage_drops > 0
    assert held_lists(vehicle) == sent_lists(plan)


def test_a_link_that_stays_down_fails_the_upload_in_one_line(plan, start_vehicle):
    vehicle = start_vehicle(plan)
    before = held_lists(vehicle)
    with LossyRelay(url_of(vehicle), LinkFaults(), seed=3) as relay:
        with Link(relay.url, timeout_s=3) as link:
            relay.cut()
            with pytest.raises(LinkError, match=r"^mission upload: vehicle stopped answering"):
                upload_to(link, plan)
    assert held_lists(vehicle) == before


def test_a_tcp_vehicle_is_relayed_packet_by_packet_and_reached_again_after_it_closes():
    """ArduPilot SITL's SERIAL0: a byte stream (here sent in halves), closed by a reboot."""
    server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    server.bind(("127.0.0.1", 0))
    server.listen(2)
    server.settimeout(5.0)
    gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    gcs.bind(("127.0.0.1", 0))
    gcs.settimeout(5.0)
    with LossyRelay(f"tcp:127.0.0.1:{server.getsockname()[1]}", LinkFaults()) as relay:
        first, _ = server.accept()
        gcs.sendto(packet(1), ("127.0.0.1", relay.port))  # the relay learns where we are
        first.settimeout(5.0)
        assert first.recv(1000) == packet(1)
        a, b = packet(2), packet(3)
        first.sendall((a + b)[:7])
        first.sendall((a + b)[7:])
        assert [gcs.recv(1000), gcs.recv(1000)] == [a, b]  # one datagram per packet
        first.close()  # the vehicle reboots
        second, _ = server.accept()  # the relay connects again
        second.sendall(packet(4))
        assert gcs.recv(1000) == packet(4)
        second.close()
    server.close()
    gcs.close()


def test_a_vehicle_that_sends_first_is_relayed_from_udpin():
    """PX4's onboard link sends to a port the ground station listens on."""
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    vehicle = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    vehicle.settimeout(5.0)
    gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    gcs.settimeout(5.0)
    with LossyRelay(f"udpin:127.0.0.1:{port}", LinkFaults()) as relay:
        gcs.sendto(packet(1), ("127.0.0.1", relay.port))
        vehicle.sendto(packet(2), ("127.0.0.1", port))
        assert gcs.recv(1000) == packet(2)
        gcs.sendto(packet(3), ("127.0.0.1", relay.port))
        got = vehicle.recv(1000)
        if got == packet(1):
            # the relay read packet 1 in the same pass as the vehicle's first packet, so it
            # knew where to send it: delivered late, as a radio may; anything else is wrong
            got = vehicle.recv(1000)
        assert got == packet(3)  # answered where the vehicle sent from
    vehicle.close()
    gcs.close()


def test_the_command_relays_for_its_duration_and_says_what_it_did(capsys):
    assert main(["--upstream", "udpout:127.0.0.1:9", "--loss", "0.1", "--duration", "0.3"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("relaying udpout:127.0.0.1:") and out[0].endswith(
        "<-> udpout:127.0.0.1:9 for 0.3 s")
    assert out[1] == ("to vehicle: 0 passed, 0 dropped; to ground station: 0 passed, "
                      "0 dropped")
