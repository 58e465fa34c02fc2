"""MAVLink 2 signing: the key file, what a signed link refuses, and signed uploads, downloads
and flights against the built-in vehicle on loopback."""

from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path

import pytest
import yaml

from tests.validator.builders import make_site, waypoint_plan
from tests.validator.mavlink.conftest import url_of
from validator.cli import validate_mission_main
from validator.errors import InputError
from validator.mavlink.cli import download_mission_main, sitl_vehicle_main, upload_mission_main
from validator.mavlink.signing import (
    RefusedTraffic,
    carries_signature,
    key_file_exposure,
    read_signing_key,
    sign_and_verify,
)
from validator.mavlink.wire import mavlink
from validator.plan_format import read_plan, write_plan
from validator.site import site_to_dict

PASSPHRASE = "correct-horse-battery-staple"
KEY = hashlib.sha256(PASSPHRASE.encode("ascii")).digest()
OTHER_KEY = hashlib.sha256(b"another-passphrase").digest()


@pytest.fixture()
def key_file(tmp_path: Path) -> Path:
    path = tmp_path / "link.key"
    path.write_text(PASSPHRASE + "\n")
    path.chmod(0o600)
    return path


@pytest.fixture()
def plan_file(tmp_path: Path, plan) -> Path:
    path = tmp_path / "m.plan"
    write_plan(plan, path)
    return path


# --------------------------------------------------------------------------------------------
# the key file


def test_the_key_is_the_sha256_of_the_passphrase_as_mavproxy_makes_it(tmp_path: Path) -> None:
    path = tmp_path / "k"
    path.write_bytes(b"abc")  # SHA-256 of "abc": the FIPS 180-2 test vector
    assert read_signing_key(path).hex() == ("ba7816bf8f01cfea414140de5dae2223"
                                            "b00361a396177a9cb410ff61f20015ad")
    for text in (b"abc\n", b"abc\r\n", b"\xef\xbb\xbfabc\n\n"):
        path.write_bytes(text)
        assert read_signing_key(path) == hashlib.sha256(b"abc").digest()


@pytest.mark.parametrize("content, problem", [
    (b"", "is empty"),
    (b"\n\n", "is empty"),
    (b"one\ntwo\n", "has 2 lines"),
    (b"two words\n", "holds a space"),
    (b" leading\n", "holds a space"),
    (b"tab\there\n", "not printable ASCII"),
    ("pässword\n".encode(), "not printable ASCII"),
    (b"\xff\xfe\x00k", "not UTF-8"),
    (b"x" * 257, "over 256 characters"),
    (b"x" * 5000, "too large"),
])
def test_a_malformed_key_file_is_one_line_naming_it(tmp_path: Path, content: bytes,
                                                    problem: str) -> None:
    path = tmp_path / "bad.key"
    path.write_bytes(content)
    with pytest.raises(InputError) as err:
        read_signing_key(path)
    message = str(err.value)
    assert message.startswith(f"{path}: ") and problem in message
    assert "two" not in message and "words" not in message  # the passphrase is not shown


@pytest.mark.parametrize("mode, warned", [(0o600, False), (0o400, False), (0o640, True),
                                         (0o604, True)])
def test_a_key_file_others_may_read_is_warned_of(key_file: Path, mode: int, warned: bool) -> None:
    key_file.chmod(mode)
    warning = key_file_exposure(key_file)
    assert (warning is not None) == warned
    assert warning is None or f"mode {mode:04o}" in warning


def test_a_missing_key_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"nope\.key: cannot read signing key file"):
        read_signing_key(tmp_path / "nope.key")


@pytest.mark.parametrize("command", ["upload", "download", "validate", "vehicle"])
def test_every_command_refuses_a_malformed_key_file_before_connecting(
        tmp_path: Path, plan_file: Path, command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.key"
    bad.write_text("two lines\nof text\n")
    link = ["--connect", "udpout:127.0.0.1:9", "--signing-key", str(bad), "--timeout", "30"]
    site = tmp_path / "site.yaml"
    site.write_text(yaml.safe_dump(site_to_dict(make_site(nfz=((100.0, 0.0, 20.0),)))))
    start = time.monotonic()
    status = {
        "upload": lambda: upload_mission_main([str(plan_file), *link]),
        "download": lambda: download_mission_main([*link, "-o", str(tmp_path / "out.plan")]),
        "validate": lambda: validate_mission_main([str(plan_file), "--site", str(site),
                                                   "--connect", "udpout:127.0.0.1:9",
                                                   "--timeout", "30",
                                                   "--signing-key", str(bad)]),
        "vehicle": lambda: sitl_vehicle_main(["--connect", "0", "--home", "1,2,3",
                                              "--signing-key", str(bad)]),
    }[command]()
    assert time.monotonic() - start < 30  # refused at once, not after a link timeout
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1
    assert f"{bad}: signing key file has 2 lines" in err
    assert not (tmp_path / "out.plan").exists()


# --------------------------------------------------------------------------------------------
# what a signed parser refuses, and how it is explained


class _Wire:
    def __init__(self) -> None:
        self.packets: list[bytes] = []

    def write(self, buf: bytes) -> None:
        self.packets.append(bytes(buf))


def _heartbeat(key: bytes | None, sysid: int = 1) -> bytes:
    wire = _Wire()
    mav = mavlink.MAVLink(wire, srcSystem=sysid, srcComponent=1)
    if key is not None:
        sign_and_verify(mav, key)
    mav.heartbeat_send(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 0)
    return wire.packets[0]


def _receiver() -> tuple[object, RefusedTraffic]:
    rx = mavlink.MAVLink(None)
    rx.robust_parsing = True
    sign_and_verify(rx, KEY)
    return rx, RefusedTraffic(KEY)


def test_a_signed_parser_takes_only_packets_signed_with_its_key_and_each_once() -> None:
    rx, refused = _receiver()
    good = _heartbeat(KEY)
    for packet, sysid in ((good, 1), (_heartbeat(None, 2), 2), (_heartbeat(OTHER_KEY, 3), 3),
                          (good, 1)):  # the last: the first one replayed
        msg = rx.parse_char(packet)  # type: ignore[attr-defined]
        refused.note(msg)
        if packet is good and not refused:
            assert msg.get_type() == "HEARTBEAT" and carries_signature(msg)
        else:
            assert msg.get_type() == "BAD_DATA", sysid
    assert (refused.unsigned, refused.other_key, refused.replayed) == ({2: 1}, {3: 1}, {1: 1})
    text = refused.explanation()
    assert text.startswith("refused 1 unsigned packet from system 2: the vehicle does not sign")
    assert "refused 1 packet from system 3 signed with another key" in text
    assert "refused 1 packet from system 1 with old signing timestamps" in text


def test_without_a_key_pymavlink_takes_signed_packets_unchecked() -> None:
    """Why the vehicle needs its own key to refuse anything: a parser with no key accepts a
    packet signed with any key (and the link can only say that the vehicle signs)."""
    rx = mavlink.MAVLink(None)
    msg = rx.parse_char(_heartbeat(OTHER_KEY))
    assert msg.get_type() == "HEARTBEAT" and carries_signature(msg)


# --------------------------------------------------------------------------------------------
# the commands against the built-in vehicle


def test_signed_upload_to_a_signing_vehicle_is_verified(plan, plan_file, key_file, start_vehicle,
                                                        tmp_path, capsys):
    vehicle = start_vehicle(plan, signing_key=KEY)
    url = url_of(vehicle)
    assert upload_mission_main([str(plan_file), "--connect", url, "--signing-key",
                                str(key_file)]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith("uploaded and verified 7 mission, 6 fence")
    assert captured.err == ""  # a private key file: no warning
    assert len(vehicle.lists().mission) == 7
    signing = vehicle.conn.mav.signing
    assert signing.goodsig_count > 0 and signing.badsig_count == signing.reject_count == 0
    out = tmp_path / "held.plan"
    key_file.chmod(0o644)  # readable by everyone: warned, not refused
    assert download_mission_main(["--connect", url, "--signing-key", str(key_file), "-o",
                                  str(out)]) == 0
    assert [it.command for it in read_plan(out).items] == [it.command for it in plan.items]
    assert capsys.readouterr().err == (f"warning: signing key file {key_file} is readable by "
                                       f"other users (mode 0644): chmod 600 {key_file}\n")


def test_a_wrong_key_fails_cleanly_within_the_timeout(plan, plan_file, tmp_path, start_vehicle,
                                                      capsys):
    vehicle = start_vehicle(plan, signing_key=KEY)
    wrong = tmp_path / "wrong.key"
    wrong.write_text("another-passphrase\n")
    wrong.chmod(0o600)
    start = time.monotonic()
    status = upload_mission_main([str(plan_file), "--connect", url_of(vehicle), "--timeout", "2",
                                  "--signing-key", str(wrong)])
    elapsed = time.monotonic() - start
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1
    assert "no signed heartbeat within 2 s" in err
    assert "from system 1 signed with another key (check --signing-key)" in err
    assert elapsed < 2 + 3  # the timeout, and no more than start-up besides
    assert vehicle.lists().mission == ()
    assert vehicle.conn.mav.signing.goodsig_count == 0  # nothing of ours was taken


def test_a_vehicle_that_does_not_sign_is_refused(plan, plan_file, key_file, start_vehicle,
                                                 tmp_path, capsys):
    vehicle = start_vehicle(plan)
    out = tmp_path / "held.plan"
    status = download_mission_main(["--connect", url_of(vehicle), "--timeout", "2",
                                    "--signing-key", str(key_file), "-o", str(out)])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and not out.exists()
    assert "unsigned packets from system 1: the vehicle does not sign" in err
    assert upload_mission_main([str(plan_file), "--connect", url_of(vehicle), "--timeout", "2",
                                "--signing-key", str(key_file)]) == 2
    assert vehicle.lists().mission == ()


def test_a_signing_vehicle_ignores_an_unsigned_ground_station(plan, plan_file, start_vehicle,
                                                              capsys):
    vehicle = start_vehicle(plan, signing_key=KEY)
    status = upload_mission_main([str(plan_file), "--connect", url_of(vehicle), "--timeout",
                                  "2"])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1
    assert err.endswith("; the vehicle signs its packets and may refuse unsigned ones: connect "
                        "with --signing-key FILE\n")
    assert vehicle.lists().mission == ()
    assert vehicle.conn.mav.signing.reject_count > 0


def test_validate_mission_flies_over_a_signed_link(tmp_path, key_file, start_vehicle):
    site = make_site(nfz=((100.0, 0.0, 20.0),))
    site_path = tmp_path / "site.yaml"
    site_path.write_text(yaml.safe_dump(site_to_dict(site)))
    plan = waypoint_plan(site, [(40.0, 30.0), (160.0, 30.0), (160.0, -40.0)], v=8.0)
    plan_path = tmp_path / "mission.plan"
    write_plan(plan, plan_path)
    vehicle = start_vehicle(plan, speedup=50.0, signing_key=KEY)
    out = tmp_path / "report.json"
    status = validate_mission_main([str(plan_path), "--site", str(site_path), "--connect",
                                    url_of(vehicle), "--signing-key", str(key_file),
                                    "--report", str(out)])
    report = json.loads(out.read_text())
    assert status == 0 and report["sitl_flight"]["end"] == "landed"
    assert vehicle.conn.mav.signing.goodsig_count > 0 and vehicle.conn.mav.signing.reject_count == 0


def test_validate_mission_takes_a_signing_key_only_with_a_url(tmp_path, key_file, plan_file,
                                                              capsys):
    site = tmp_path / "site.yaml"
    site.write_text(yaml.safe_dump(site_to_dict(make_site(nfz=((100.0, 0.0, 20.0),)))))
    assert validate_mission_main([str(plan_file), "--site", str(site), "--sitl",
                                  "--signing-key", str(key_file)]) == 2
    assert capsys.readouterr().err == ("validate-mission: --signing-key: only with --connect "
                                       "(the vehicles --sitl starts itself run on loopback, "
                                       "unsigned)\n")
