"""``validate-mission --sitl`` on a bad link (the built-in vehicle behind the lossy relay): the
vehicle flies on through link gaps and the report says what the track misses; a link that
stays down ends the run with a clear verdict, the vehicle commanded to LAND if the link comes
back and the verdict saying what its own failsafe does if it does not."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator

import pytest
import yaml

from tests.validator.builders import make_site, waypoint_plan
from tests.validator.mavlink.conftest import url_of
from validator.cli import validate_mission_main
from validator.mavlink.lossy_relay import LinkFaults, LossyRelay
from validator.mavlink.sim.arducopter import CopterMode
from validator.mavlink.telemetry import track_gaps
from validator.plan_format import write_plan
from validator.site import site_to_dict

SPEEDUP = 5.0
COMMAND_LONG = 76  # MAVLink message id: the tool's LAND (DO_SET_MODE)
MISSION_START = 300  # MAV_CMD: the tool's last command before the flight is its own


@pytest.fixture()
def files(tmp_path):
    site = make_site(nfz=((100.0, 0.0, 20.0),))
    site_path = tmp_path / "site.yaml"
    site_path.write_text(yaml.safe_dump(site_to_dict(site)))
    plan = waypoint_plan(site, [(40.0, 30.0), (160.0, 30.0), (160.0, -40.0)], v=8.0)
    plan_path = tmp_path / "mission.plan"
    write_plan(plan, plan_path)
    return tmp_path, site_path, plan_path, plan


@pytest.fixture()
def relayed(files, start_vehicle) -> Iterator[tuple]:
    *_, plan = files
    vehicle = start_vehicle(plan, speedup=SPEEDUP)
    with LossyRelay(url_of(vehicle), LinkFaults.lossy(0.05), seed=4) as relay:
        yield vehicle, relay


def cut_in_auto(vehicle, relay, *, after_s: float, for_s: float | None,
                until_commanded: bool = False) -> threading.Thread:
    """Cut the link ``after_s`` wall seconds after the tool has heard MISSION_START accepted,
    for ``for_s`` (None: for good); ``until_commanded``: until the tool, having given the link
    up, sends its first command (LAND) into the gap, whatever the machine's load made of the
    wall clock. (A cut timed from the vehicle's AUTO once caught the tool still waiting for an
    ACK that 5 % loss had eaten, and the run ended on "no COMMAND_ACK" instead.)"""

    def run() -> None:
        deadline = time.monotonic() + 60.0
        while MISSION_START not in relay.acked_to_gcs and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(after_s)
        relay.cut()
        if until_commanded:
            while COMMAND_LONG not in relay.swallowed_to_vehicle and \
                    time.monotonic() < deadline + 60.0:
                time.sleep(0.02)
            relay.restore()
        elif for_s is not None:
            time.sleep(for_s)
            relay.restore()

    t = threading.Thread(target=run, daemon=True)
    t.start()
    return t


def validate(files, relay, *extra: str) -> tuple[int, dict]:
    tmp, site, plan, _ = files
    out = tmp / "report.json"
    status = validate_mission_main([str(plan), "--site", str(site), "--connect", relay.url,
                                    "--report", str(out), *extra])
    # exit 2 writes no report: its one-line reason is in the captured stderr below
    assert out.exists(), f"validate-mission exited {status} with no report"
    return status, json.loads(out.read_text())


def messages(report: dict) -> list[str]:
    return [f["message"] for f in report["sitl"]["findings"]]


def test_gaps_are_found_in_the_recorded_times():
    assert track_gaps([0.0, 0.05, 0.1, 2.1, 2.15, 2.2, 5.0]) == [(0.1, 2.0), (2.2, 2.8)]
    assert track_gaps([0.0, 0.5, 1.0]) == []
    assert track_gaps([1.0]) == []


@pytest.mark.realtime  # the cut is timed on the wall clock, the flight too
def test_the_vehicle_flies_on_through_a_gap_and_the_report_says_what_the_track_misses(
        files, relayed):
    vehicle, relay = relayed
    cut = cut_in_auto(vehicle, relay, after_s=1.0, for_s=1.5)
    status, report = validate(files, relay, "--timeout", "6")
    cut.join()
    assert relay.outage_drops > 0
    assert status == 0 and report["result"] == "clear"
    assert report["sitl_flight"]["end"] == "landed"
    gap = [m for m in messages(report) if m.startswith("the link dropped")]
    assert len(gap) == 1 and "the link dropped 1 time(s) in flight" in gap[0]
    missed_s = float(gap[0].split("misses ")[1].split(" s")[0])
    assert missed_s > 0.5 * 1.5 * SPEEDUP  # most of the cut, in vehicle seconds


@pytest.mark.realtime  # the cut is timed on the wall clock, the flight too
def test_a_link_down_for_good_ends_the_run_with_a_verdict(files, relayed, capsys):
    vehicle, relay = relayed
    cut = cut_in_auto(vehicle, relay, after_s=1.0, for_s=None)
    status, report = validate(files, relay, "--timeout", "3")
    cut.join()
    assert status == 1 and report["result"] == "violation"
    assert report["sitl_flight"]["end"] == "link lost"
    lost = [m for m in messages(report) if m.startswith("link lost")]
    assert len(lost) == 1
    assert "it did not come back within 3 s" in lost[0]
    # the built-in model reports ArduCopter's default FS_GCS_ENABLE 0 (it flies no
    # ground-station failsafe), and the verdict says it flies the mission on
    assert "(FS_GCS_ENABLE 0)" in lost[0]
    assert vehicle.mode == CopterMode.AUTO  # nobody could tell it otherwise
    assert "link lost" in capsys.readouterr().out


@pytest.mark.realtime  # the cut is timed on the wall clock, the flight too
def test_a_link_that_comes_back_too_late_lands_the_vehicle(files, relayed):
    vehicle, relay = relayed
    # back once the tool has given the link up and commands LAND into the gap: a fixed 4.5 s
    # left LAND 1.5 s to get through 5 % loss, too little on a loaded machine; and a 3 s
    # timeout left two more LANDs after the first, swallowed one (both lost on one CI run of
    # about ten), so 5 s: four, each through 5 % loss both ways
    cut = cut_in_auto(vehicle, relay, after_s=1.0, for_s=None, until_commanded=True)
    status, report = validate(files, relay, "--timeout", "5")
    cut.join()
    assert status == 1
    lost = [m for m in messages(report) if m.startswith("link lost")]
    assert len(lost) == 1 and "the link came back and the vehicle accepted LAND" in lost[0]
    assert vehicle.mode == CopterMode.LAND
