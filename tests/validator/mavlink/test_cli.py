"""upload-mission, download-mission and sitl-vehicle as commands: exit status, one-line
errors, no partial output file."""

import dataclasses
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from tests.validator.builders import make_site, waypoint_plan
from tests.validator.mavlink.conftest import FakeVehicle, free_udp_port, url_of
from validator.mavlink.cli import (
    download_mission_main,
    is_loopback,
    listen_url,
    sitl_parser,
    sitl_vehicle_main,
    upload_mission_main,
)
from validator.mavlink.link import download_plan
from validator.mavlink.wire import plan_to_wire
from validator.plan_format import read_plan, write_plan
from validator.site import site_to_dict


def test_upload_mission_sets_params_and_verifies(tmp_path, plan, start_vehicle, capsys):
    vehicle = start_vehicle(plan)
    path = tmp_path / "m.plan"
    write_plan(plan, path)
    params = tmp_path / "copter.param"
    params.write_text("WPNAV_SPEED 1200\nWPNAV_RADIUS 150\n")
    status = upload_mission_main([str(path), "--connect", url_of(vehicle), "--params",
                                  str(params)])
    assert status == 0
    assert capsys.readouterr().out.startswith("uploaded and verified 7 mission, 6 fence and 2 "
                                              "rally items on system 1 (ArduPilot); 2 parameters")
    assert vehicle.params["WPNAV_RADIUS"][0] == 150.0


def test_upload_mission_refuses_a_plan_the_audit_rejects_unless_forced(tmp_path, start_vehicle,
                                                                       capsys):
    site = make_site(nfz=((100.0, 0.0, 20.0),))
    site_path = tmp_path / "site.yaml"
    site_path.write_text(yaml.safe_dump(site_to_dict(site)))
    bad = waypoint_plan(site, [(40.0, 0.0), (160.0, 0.0)])
    path = tmp_path / "bad.plan"
    write_plan(bad, path)
    vehicle = start_vehicle(bad)
    args = [str(path), "--connect", url_of(vehicle), "--site", str(site_path)]
    assert upload_mission_main(args) == 1
    assert "enters NFZ1" in capsys.readouterr().err
    assert vehicle.lists().mission == ()
    assert upload_mission_main([*args, "--force"]) == 0


def test_upload_mission_refuses_a_flight_beyond_the_endurance(tmp_path, start_vehicle, capsys):
    site = make_site(nfz=((100.0, 0.0, 20.0),))
    plan = waypoint_plan(site, [(40.0, 60.0), (160.0, 60.0)])  # clear of NFZ1
    path = tmp_path / "m.plan"
    write_plan(plan, path)
    site_path = tmp_path / "site.yaml"
    vehicle = start_vehicle(plan)
    args = [str(path), "--connect", url_of(vehicle), "--site", str(site_path)]
    for endurance_s, status in ((3600.0, 0), (10.0, 1)):
        site_path.write_text(yaml.safe_dump(site_to_dict(site.with_limits(
            endurance_s=endurance_s))))
        assert upload_mission_main(args) == status
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "beyond the UAV's endurance of 10 s" in err, err


def test_upload_mission_nack_exits_2_with_one_line(tmp_path, plan, capsys):
    path = tmp_path / "m.plan"
    write_plan(plan, path)
    with FakeVehicle(nack=1) as fake:
        assert upload_mission_main([str(path), "--connect", fake.url, "--timeout", "2"]) == 2
    err = capsys.readouterr().err
    assert err == ("upload-mission: mission upload: vehicle rejected it with MAV_MISSION_ERROR"
                   "\n")


def _refused_upload(tmp_path, plan, item: int, **change) -> Path:
    """upload-mission of ``plan`` with item ``item`` changed by ``change`` to a fake vehicle:
    refused with exit 2 and nothing sent; the plan's path."""
    items = list(plan.items)
    items[item] = dataclasses.replace(items[item], **change)
    path = tmp_path / "m.plan"
    write_plan(dataclasses.replace(plan, items=items), path)
    with FakeVehicle() as fake:
        assert upload_mission_main([str(path), "--connect", fake.url, "--timeout", "2"]) == 2
        assert fake.lists[0] == []  # nothing was sent
    return path


def test_upload_mission_refuses_a_waypoint_arducopter_would_fly_toward_0_0(tmp_path, plan,
                                                                             capsys):
    """A frame-2 waypoint carries whole degrees, which ArduPilot reads as degrees x 1e7: it
    was refused only with --site (by the resolver), and without it uploaded and verified."""
    lat, lon = round(plan.items[3].params[4]), round(plan.items[3].params[5])
    path = _refused_upload(tmp_path, plan, 3, params=[*plan.items[3].params[:4], lat, lon, 30.0],
                           frame=2)
    err = capsys.readouterr().err
    assert err.startswith(f"upload-mission: {path}: item 4: frame 2 (MISSION) carries latitude "
                          "and longitude unscaled"), err
    assert err.count("\n") == 1 and "0°N 0°E" in err


def test_upload_mission_names_the_plan_of_a_hold_arducopter_would_cut(tmp_path, plan, capsys):
    """ArduCopter keeps a waypoint's hold as whole seconds: refused before sending, naming the
    file as every other refusal of the command does."""
    path = _refused_upload(tmp_path, plan, 3, params=[1.5, *plan.items[3].params[1:]])
    err = capsys.readouterr().err
    assert err.startswith(f"upload-mission: {path}: the vehicle would not keep the plan as "
                          "written: mission item 4: ArduPilot would keep param1 1.5"), err
    assert err.count("\n") == 1


def test_upload_mission_corrupt_plan_exits_2(tmp_path, capsys):
    path = tmp_path / "m.plan"
    path.write_text("{not json")
    assert upload_mission_main([str(path), "--connect", "udpout:127.0.0.1:9"]) == 2
    assert "not valid JSON" in capsys.readouterr().err


def test_download_mission_writes_what_the_vehicle_holds(tmp_path, plan, start_vehicle):
    vehicle = start_vehicle(plan)
    src = tmp_path / "m.plan"
    write_plan(plan, src)
    assert upload_mission_main([str(src), "--connect", url_of(vehicle)]) == 0
    out = tmp_path / "held.plan"
    assert download_mission_main(["--connect", url_of(vehicle), "-o", str(out)]) == 0
    held = read_plan(out)
    assert [it.command for it in held.items] == [it.command for it in plan.items]
    assert len(held.polygons) == 1 and len(held.rally) == 2


def test_download_mission_warns_when_the_first_waypoint_stands_in_for_home(tmp_path, plan,
                                                                            capsys):
    wire = plan_to_wire(plan, home_item=True)
    out = tmp_path / "held.plan"
    with FakeVehicle() as fake:  # an ArduPilot before its GPS fix: seq 0 at 0°, 0°
        fake.lists[0] = [dataclasses.replace(wire.mission[0], x=0, y=0), *wire.mission[1:]]
        assert download_mission_main(["--connect", fake.url, "-o", str(out), "--quiet"]) == 0
    assert capsys.readouterr().err == (
        "download-mission: warning: the vehicle reported no home (its seq 0 at 0°, 0°); the "
        "plan's home is the position of item 1, the first item with one, at "
        "altitude 0 m AMSL\n")


def test_download_mission_from_a_dead_link_writes_nothing(tmp_path, capsys):
    out = tmp_path / "held.plan"
    status = download_mission_main(["--connect", f"udpout:127.0.0.1:{free_udp_port()}",
                                    "--timeout", "1", "-o", str(out)])
    assert status == 2
    assert not out.exists() and list(tmp_path.iterdir()) == []
    err = capsys.readouterr().err  # how long it takes is benchmarks/bench_mavlink.py's figure
    assert err.count("\n") == 1 and "no heartbeat within 1 s" in err


def test_sitl_vehicle_bad_home_exits_2(capsys):
    assert sitl_vehicle_main(["--connect", "udpin:127.0.0.1:0", "--home", "-35.3,500,0"]) == 2
    assert capsys.readouterr().err == ("sitl-vehicle: --home -35.3,500,0: latitude or longitude "
                                       "out of range\n")


def test_sitl_vehicle_home_altitude_beyond_reach_exits_2(capsys):
    assert sitl_vehicle_main(["--connect", "udpin:127.0.0.1:0", "--home", "37.5,127,1e9"]) == 2
    assert capsys.readouterr().err == ("sitl-vehicle: --home 37.5,127,1e9: altitude must be "
                                       "within ±100000 m\n")


def test_sitl_vehicle_port_beyond_65535_exits_2(capsys):
    assert sitl_vehicle_main(["--connect", "udpin:127.0.0.1:99999", "--home", "37.5,127,1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--connect: port 99999 is outside 0..65535" in err


@pytest.mark.parametrize("port", ["99999", "-1"])
def test_upload_mission_port_outside_0_65535_exits_2(tmp_path, capsys, port):
    assert upload_mission_main([str(tmp_path / "m.plan"), "--connect", f"udpout:127.0.0.1:{port}",
                                "--timeout", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--connect: port {port} is outside 0..65535" in err


def test_sitl_vehicle_bad_loss_exits_2(capsys):
    assert sitl_vehicle_main(["--connect", "udpin:127.0.0.1:0", "--home", "1,2,3",
                              "--loss", "1.5"]) == 2
    assert "--loss: must be in [0, 1)" in capsys.readouterr().err


@pytest.mark.parametrize("text, url", [
    (None, "udpin:127.0.0.1:14550"),
    ("14551", "udpin:127.0.0.1:14551"),
    ("udpin::14552", "udpin:127.0.0.1:14552"),  # pymavlink: every interface
    (":0", "udpin:127.0.0.1:0"),
    ("udp:14553", "udp:127.0.0.1:14553"),
    ("udpin:0.0.0.0:14550", "udpin:0.0.0.0:14550"),  # asked for: every interface
    ("192.168.1.5:14550", "udpin:192.168.1.5:14550"),
    ("udpin:localhost:14550", "udpin:localhost:14550"),
])
def test_sitl_vehicle_listens_on_loopback_unless_a_host_is_named(text, url):
    args = sitl_parser().parse_args(["--home", "1,2,3"] + ([] if text is None else
                                                           ["--connect", text]))
    assert listen_url(args.connect) == url


@pytest.mark.parametrize("listen", ["0", "udpin::0"])
def test_sitl_vehicle_command_serves_and_stops_on_sigterm(plan, listen):
    code = "import sys; from validator.mavlink.cli import sitl_vehicle_main as m; sys.exit(m())"
    proc = subprocess.Popen(
        [sys.executable, "-c", code, "--connect", listen, "--home",
         f"{plan.home_lat_deg},{plan.home_lon_deg},{plan.home_alt_m}", "--speedup", "10"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()  # the address the socket is bound to
        assert line.startswith("sitl-vehicle: listening on udpin:127.0.0.1:")
        port = int(line.split(":")[3].split()[0])
        held = download_plan(f"udpout:127.0.0.1:{port}", timeout_s=5)
        assert held.items == [] and held.circles == []
        assert held.home_lat_deg == pytest.approx(plan.home_lat_deg, abs=1e-7)
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
    assert proc.stderr is not None and "not loopback" not in proc.stderr.read()


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_sitl_vehicle_stops_on_a_signal_within_seconds_at_any_speedup(plan, sig):
    """SIGTERM waited for the simulation to catch up, which at x1e6 (x1e4 on a slower machine)
    grows without end: it never stopped, where SIGINT stopped it at once."""
    code = "import sys; from validator.mavlink.cli import sitl_vehicle_main as m; sys.exit(m())"
    proc = subprocess.Popen(
        [sys.executable, "-c", code, "--connect", "0", "--home",
         f"{plan.home_lat_deg},{plan.home_lon_deg},{plan.home_alt_m}", "--speedup", "1e6",
         "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().startswith("sitl-vehicle: listening on")
        time.sleep(1.0)  # deep into a catch-up of simulated time
        proc.send_signal(sig)
        assert proc.wait(timeout=15) == 0  # (before: never, at x1e6)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_sitl_vehicle_started_with_sigint_ignored_still_stops_on_it(plan):
    """A shell without job control starts a background job with SIGINT ignored, and Python
    keeps it so: ``kill -INT`` did nothing there."""
    code = "import sys; from validator.mavlink.cli import sitl_vehicle_main as m; sys.exit(m())"
    proc = subprocess.Popen(
        [sys.executable, "-c", code, "--connect", "0", "--home",
         f"{plan.home_lat_deg},{plan.home_lon_deg},{plan.home_alt_m}", "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN),
    )
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().startswith("sitl-vehicle: listening on")
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=15) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.parametrize("host, loopback", [("127.0.0.1", True), ("127.0.0.2", True),
                                            ("::1", True), ("localhost", True),
                                            ("0.0.0.0", False), ("192.168.1.5", False),
                                            ("example.org", False)])
def test_sitl_vehicle_warns_when_not_on_loopback(host, loopback):
    assert is_loopback(host) == loopback


def test_download_mission_to_one_path_twice_is_refused_before_connecting(tmp_path, capsys):
    out = tmp_path / "held.plan"
    status = download_mission_main(["--connect", f"udpout:127.0.0.1:{free_udp_port()}",
                                    "--timeout", "1", "-o", str(out), "--params-out", str(out)])
    assert status == 2 and list(tmp_path.iterdir()) == []
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "named for two outputs" in err


def test_download_mission_to_a_folder_names_the_folder(tmp_path, capsys):
    status = download_mission_main(["--connect", f"udpout:127.0.0.1:{free_udp_port()}",
                                    "--timeout", "1", "-o", str(tmp_path)])
    assert status == 2
    assert capsys.readouterr().err == f"download-mission: {tmp_path}: is a folder\n"
