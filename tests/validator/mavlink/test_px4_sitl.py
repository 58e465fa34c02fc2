"""The real PX4 firmware in the loop: upload, read-back, the geofence action, and a flight.

These tests run PX4's SITL build with its built-in SIH quadrotor: ``$PX4_SITL``, else
``/opt/sitl/px4/build/px4_sitl_default/bin/px4`` (a ``px4_sitl_default`` build: ``bin/px4``
beside ``etc/``). Without one they are skipped, saying how to enable them. The plan is made by
``plan-mission --autopilot px4`` as a user makes it, once for the module.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from tests.validator.mavlink.sitl_binaries import (
    PLAN_MISSION,
    REPO,
    crossing_site,
    plan_for,
    sitl_binary,
)
from validator.autopilot.param_file import read_params
from validator.cli import validate_mission_main
from validator.mavlink.cli import download_mission_main, upload_mission_main
from validator.mavlink.link import Link
from validator.mavlink.sitl_process import px4_sih
from validator.plan_format import Cmd, read_plan
from validator.site import load_site
from validator.track_file import read_track

DOCUMENTED_PATH = Path("/opt/sitl/px4/build/px4_sitl_default/bin/px4")
# PX4 SIH is not lockstepped: starved of CPU it flies its controllers with longer steps and
# runs late (a realistic cycle took 1.05 T at x4 while the rest of the suite ran on the other
# worker, 1.00 T alone). x2 leaves it the headroom a loaded CI machine may not.
SPEEDUP = "2"


BINARY = sitl_binary("PX4_SITL", DOCUMENTED_PATH)
pytestmark = [pytest.mark.realtime, pytest.mark.xdist_group("real-sitl"), pytest.mark.skipif(
    BINARY is None,
    reason="no PX4 SITL binary: build PX4 v1.15 px4_sitl_default (SIH) for this machine and "
           "set PX4_SITL=/path/to/build/px4_sitl_default/bin/px4 (or build it at "
           f"{DOCUMENTED_PATH.parents[3]}) to run the real-PX4 tests")]


@pytest.fixture(scope="module")
def realistic(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    """samples/realistic.yaml planned for PX4: (site, plan, parameter file)."""
    tmp = tmp_path_factory.mktemp("px4")
    site = REPO / "samples" / "realistic.yaml"
    out = tmp / "realistic.plan"
    subprocess.run([str(PLAN_MISSION), str(site), "--autopilot", "px4", "-o", str(out)],
                   check=True, capture_output=True)
    return site, out, out.with_suffix(".param")


def test_upload_verifies_against_px4s_storage_and_the_fence_action_holds(realistic, tmp_path,
                                                                         capsys):
    _, plan_path, params = realistic
    plan = read_plan(plan_path)
    assert BINARY is not None
    with px4_sih(BINARY, (plan.home_lat_deg, plan.home_lon_deg, plan.home_alt_m),
                 speedup=1.0) as url:
        assert upload_mission_main([str(plan_path), "--connect", url, "--params",
                                    str(params), "--timeout", "20"]) == 0
        assert capsys.readouterr().out.startswith("uploaded and verified")
        with Link(url, timeout_s=20) as link:
            assert link.vehicle.is_px4
            assert link.read_param("GF_ACTION").value == read_params(params)["GF_ACTION"]
            assert link.read_param("NAV_ACC_RAD").value == read_params(params)["NAV_ACC_RAD"]
        back = tmp_path / "back.plan"
        assert download_mission_main(["--connect", url, "-o", str(back), "--timeout",
                                      "20"]) == 0
    held = read_plan(back)
    assert [it.command for it in held.items] == [it.command for it in plan.items]
    waypoints = [it for it in plan.items if it.command == Cmd.NAV_WAYPOINT]
    assert [it.params[0] for it in held.items if it.command == Cmd.NAV_WAYPOINT] == \
        pytest.approx([it.params[0] for it in waypoints], rel=1e-7)  # fractional holds, float32
    assert len(held.circles) == len(plan.circles) and len(held.rally) == len(plan.rally)
    assert [c.radius_m for c in held.circles] == pytest.approx(
        [c.radius_m for c in plan.circles], abs=1e-3)


def test_the_realistic_px4_plan_flies_on_time_clear_of_every_nfz(realistic, tmp_path,
                                                                  capsys):
    site, plan, params = realistic
    out = tmp_path / "flown.json"
    status = validate_mission_main([str(plan), "--site", str(site), "--params", str(params),
                                    "--sitl-binary", str(BINARY), "--sitl-speedup", SPEEDUP,
                                    "--report", str(out),
                                    "--track", str(tmp_path / "track.csv.gz")])
    captured = capsys.readouterr()
    assert status == 0, captured.out + captured.err
    report = json.loads(out.read_text())
    flight = report["sitl_flight"]
    assert flight["kind"] == "sitl-binary" and flight["vehicle"].startswith("PX4")
    assert flight["end"] == "landed"  # the mission's NAV_LAND, then PX4's own disarm
    assert flight["mode_changes"] == []  # Mission mode throughout: no breach, no failsafe
    assert all(z["clearance_m"] > 0 for z in report["sitl"]["nfz"])
    # planned with PX4's own timing: the cycle keeps T, and the px4 replay predicted it
    flown, replayed = report["sitl"]["cycle"], report["replay"]["cycle"]
    assert flown["ratio_to_planned"] == pytest.approx(1.0, abs=0.05)
    assert replayed["flown_cycle_s"] == pytest.approx(flown["flown_cycle_s"], rel=0.03)
    thr = report["sitl"]["throughput"]
    # 0.98-0.99 of planned in quiet runs; one run at load 6 fell below 0.97 (the issue's
    # target for the rate is ArduCopter's; this keeps a margin for a loaded CI machine)
    assert thr["flown_min_bps_hz"] >= 0.95 * thr["planned_min_bps_hz"]
    assert read_track(tmp_path / "track.csv.gz").t_s.size == flight["samples"]


def test_a_breach_holds_the_vehicle_short_of_crossing_the_zone(tmp_path):
    """A conventional plan that hops across a zone (forced out), flown with the plan's
    parameters: PX4 detects the geofence breach and holds (GF_ACTION 2) instead of flying on
    across. It stops within its braking distance of the fence: inside the zone, which is what
    the buffer is for; the fence is the last line, not the plan's clearance."""
    site = crossing_site(tmp_path)
    plan, params = plan_for(tmp_path, site, "--scheme", "conventional", "--dynamics", "none",
                            "--force", "--autopilot", "px4")
    out, track = tmp_path / "breach.json", tmp_path / "breach.csv"
    # the breach comes about 140 s into the mission (its takeoff varies by seconds): the
    # recording must outlast it
    status = validate_mission_main([str(plan), "--site", str(site), "--params", str(params),
                                    "--sitl-binary", str(BINARY), "--sitl-speedup", SPEEDUP,
                                    "--sitl-time-limit", "240",
                                    "--report", str(out), "--track", str(track)])
    assert status == 1  # the audit refuses the plan's legs across MID
    report = json.loads(out.read_text())
    flight = report["sitl_flight"]
    assert [c["mode"] for c in flight["mode_changes"]][:1] == ["LOITER"]
    assert any("Geofence" in m["text"] for m in flight["messages"])
    # It held within its braking distance of where it came in, so short of the far side: the
    # leg's chord through MID is about 61 m, PX4 brakes from 8.5 m/s in 15-20 m. How deep it
    # went depends on when PX4 caught the breach (8-16 m in; up to 4 s late under CI load), and
    # PX4 may then move its loiter point back to the fence edge, so depth is not the test.
    rec = read_track(track)
    xy = load_site(site).frame.to_local(rec.lat_deg, rec.lon_deg)
    inside = np.flatnonzero(np.hypot(xy[:, 0] - 120.0, xy[:, 1]) < 40.0)
    assert inside.size, "the track never entered MID: the breach was not flown"
    entry, last = xy[inside[0]], xy[-1]
    assert np.hypot(last[0] - 120.0, last[1]) < 40.0 + 2.0  # in MID or at its fence edge
    assert np.hypot(*(last - entry)) < 30.0
