"""The real ArduCopter firmware in the loop: upload, read-back, fence and flights.

These tests run an ArduCopter SITL binary built for this machine: ``$ARDUPILOT_SITL``, else
``/opt/sitl/arducopter`` (see the README's *Real autopilots*). Without one they are skipped,
saying how to enable them. Plans are made by ``plan-mission`` as a user makes them.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
import yaml

from tests.validator.mavlink.sitl_binaries import REPO, crossing_site, plan_for, sitl_binary
from validator.autopilot.param_file import read_params
from validator.cli import validate_mission_main
from validator.mavlink.cli import download_mission_main, upload_mission_main
from validator.mavlink.link import Link
from validator.mavlink.signing import SIGNING_EPOCH_UNIX_S, key_from_passphrase
from validator.mavlink.sitl_process import ardupilot_sitl, find_defaults
from validator.plan_format import read_plan

DOCUMENTED_PATH = Path("/opt/sitl/arducopter")

BINARY = sitl_binary("ARDUPILOT_SITL", DOCUMENTED_PATH)
pytestmark = [pytest.mark.realtime, pytest.mark.xdist_group("real-sitl"), pytest.mark.skipif(
    BINARY is None,
    reason="no ArduCopter SITL binary: build ArduCopter 4.5 SITL for this machine and set "
           "ARDUPILOT_SITL=/path/to/build/sitl/bin/arducopter (or link it at "
           "/opt/sitl/arducopter) to run the real-autopilot tests")]


@pytest.fixture(scope="module")
def sample(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    tmp = tmp_path_factory.mktemp("sample")
    site = REPO / "samples" / "paper-default.yaml"
    plan, params = plan_for(tmp, site)
    return site, plan, params


@pytest.fixture()
def sitl_url(sample: tuple[Path, Path, Path]):
    _, plan_path, _ = sample
    plan = read_plan(plan_path)
    assert BINARY is not None
    with ardupilot_sitl(BINARY, (plan.home_lat_deg, plan.home_lon_deg, plan.home_alt_m),
                        speedup=10.0, defaults=find_defaults(BINARY)) as url:
        yield url


def test_upload_verifies_against_ardupilots_storage_and_the_fence_is_on(sample, sitl_url,
                                                                       tmp_path, capsys):
    _, plan, params = sample
    assert upload_mission_main([str(plan), "--connect", sitl_url, "--params", str(params),
                                "--timeout", "20"]) == 0
    assert capsys.readouterr().out.startswith("uploaded and verified")
    with Link(sitl_url, timeout_s=10) as link:
        assert link.read_param("FENCE_ENABLE").value == 1.0
        assert link.read_param("FENCE_ACTION").value == 5.0
        assert link.read_param("WPNAV_SPEED").value == read_params(params)["WPNAV_SPEED"]
    back = tmp_path / "back.plan"
    assert download_mission_main(["--connect", sitl_url, "-o", str(back)]) == 0
    sent, held = read_plan(plan), read_plan(back)
    assert [it.command for it in held.items] == [it.command for it in sent.items]
    assert len(held.circles) == len(sent.circles) and len(held.rally) == len(sent.rally)
    holds = [it.params[0] for it in sent.items if it.command == 16]
    assert [it.params[0] for it in held.items if it.command == 16] == holds


def test_an_upload_without_the_parameter_file_leaves_the_fence_off_and_fails(sample, sitl_url,
                                                                            capsys):
    _, plan, _ = sample
    assert upload_mission_main([str(plan), "--connect", sitl_url, "--timeout", "20"]) == 2
    assert "FENCE_ENABLE is 0, not 1" in capsys.readouterr().err


def test_the_sample_plan_flies_to_the_end_clear_of_every_nfz(sample, tmp_path, capsys):
    site, plan, params = sample
    out = tmp_path / "flown.json"
    status = validate_mission_main([str(plan), "--site", str(site), "--params", str(params),
                                    "--sitl-binary", str(BINARY), "--report", str(out)])
    text = capsys.readouterr().out
    report = json.loads(out.read_text())
    assert status == 0, text
    assert report["sitl_flight"]["kind"] == "sitl-binary"
    assert report["sitl_flight"]["vehicle"].startswith("ArduPilot")
    assert report["sitl_flight"]["end"] == "landed"
    assert report["sitl_flight"]["fence_breach_samples"] == 0
    assert all(z["clearance_m"] > 0 for z in report["sitl"]["nfz"])
    assert "flown clearance (m)" in text


@pytest.fixture(scope="module")
def crossing(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    tmp = tmp_path_factory.mktemp("crossing")
    site = crossing_site(tmp)
    plan, params = plan_for(tmp, site, "--scheme", "conventional", "--dynamics", "none", "--force")
    return site, plan, params


def test_a_leg_across_a_zone_is_caught_by_the_flown_track_and_the_fence(crossing, tmp_path):
    site, plan, params = crossing
    report_only = tmp_path / "report-only.param"
    report_only.write_text(params.read_text().replace("FENCE_ACTION 5", "FENCE_ACTION 0"))
    out = tmp_path / "crossed.json"
    status = validate_mission_main([str(plan), "--site", str(site), "--params",
                                    str(report_only), "--sitl-binary", str(BINARY),
                                    "--report", str(out)])
    report = json.loads(out.read_text())
    assert status == 1
    assert min(z["clearance_m"] for z in report["sitl"]["nfz"]) < 0  # flown into the zone
    assert report["sitl_flight"]["fence_breach_samples"] > 0  # and the autopilot said so


def test_with_the_plans_parameters_a_breach_retraces_the_flown_path(crossing, tmp_path):
    site, plan, params = crossing
    out = tmp_path / "smartrtl.json"
    validate_mission_main([str(plan), "--site", str(site), "--params", str(params),
                           "--sitl-binary", str(BINARY), "--report", str(out)])
    report = json.loads(out.read_text())
    assert report["sitl_flight"]["fence_breach_samples"] > 0
    assert [c["mode"] for c in report["sitl_flight"]["mode_changes"]][:1] == ["SMART_RTL"]
    assert report["sitl_flight"]["end"] == "landed"


@pytest.fixture(scope="module")
def realistic(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path, Path]:
    tmp = tmp_path_factory.mktemp("realistic")
    site = REPO / "samples" / "realistic.yaml"
    report = tmp / "realistic.report.json"
    plan, params = plan_for(tmp, site, "--report", str(report))
    return site, plan, params, report


def test_a_realistic_plan_keeps_its_period_on_the_real_autopilot(realistic, tmp_path):
    site, plan, params, planned = realistic
    out = tmp_path / "realistic.json"
    status = validate_mission_main([str(plan), "--site", str(site), "--params", str(params),
                                    "--sitl-binary", str(BINARY), "--report", str(out)])
    report = json.loads(out.read_text())
    assert status == 0
    cycle = report["sitl"]["cycle"]
    period = yaml.safe_load(site.read_text())["uav"]["period"]
    predicted = json.loads(planned.read_text())["flight"]["replayed_cycle_s"]
    assert cycle["flown_cycle_s"] == pytest.approx(period, rel=0.05)
    assert cycle["flown_cycle_s"] == pytest.approx(predicted, rel=0.03)
    assert all(z["clearance_m"] > 0 for z in report["sitl"]["nfz"])


def test_a_signed_link_works_with_ardupilots_signing_and_an_unsigned_one_is_refused(
        sample, sitl_url, tmp_path, capsys):
    """The key a passphrase file gives is the one MAVProxy's ``signing setup`` puts on the
    autopilot: set it over SERIAL0 (ArduPilot's USB channel, which always takes unsigned
    packets), then talk over SERIAL1, where ArduPilot refuses anything unsigned."""
    _, plan, params = sample
    passphrase = "a-long-random-passphrase-for-the-test"
    key_file = tmp_path / "link.key"
    key_file.write_text(passphrase + "\n")
    with Link(sitl_url, timeout_s=20) as link:
        link.mav.setup_signing_send(*link.target, list(key_from_passphrase(passphrase)),
                                    int((time.time() - SIGNING_EPOCH_UNIX_S) * 100_000))
        link.recv((), time.monotonic() + 1.0)  # ArduPilot acknowledges nothing: give it time
    host, port = sitl_url.rsplit(":", 1)
    serial1 = f"{host}:{int(port) + 2}"
    assert upload_mission_main([str(plan), "--connect", serial1, "--params", str(params),
                                "--timeout", "20", "--signing-key", str(key_file)]) == 0
    assert capsys.readouterr().out.startswith("uploaded and verified")
    assert download_mission_main(["--connect", serial1, "--timeout", "5",
                                  "-o", str(tmp_path / "unsigned.plan")]) == 2
    assert "the vehicle signs its packets and may refuse unsigned ones" in capsys.readouterr().err
    wrong = tmp_path / "wrong.key"
    wrong.write_text("not-the-passphrase\n")
    assert download_mission_main(["--connect", serial1, "--timeout", "5", "--signing-key",
                                  str(wrong), "-o", str(tmp_path / "wrong.plan")]) == 2
    assert "signed with another key" in capsys.readouterr().err
    assert not (tmp_path / "unsigned.plan").exists() and not (tmp_path / "wrong.plan").exists()
