"""QGC WPL 110 files: our writer and reader, and pymavlink's mavwp reading what we write."""

from __future__ import annotations

import os

os.environ["MAVLINK20"] = "1"  # before pymavlink's first import: fences need MAVLink 2

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from pymavlink import mavutil, mavwp  # noqa: E402

from tests.validator.builders import jump, make_site, nav, plan_of, speed  # noqa: E402
from validator.errors import InputError  # noqa: E402
from validator.mavlink.wire import plan_to_wire  # noqa: E402
from validator.plan_format import Cmd, FencePolygon  # noqa: E402
from validator.waypoints_format import (  # noqa: E402
    HEADER,
    dumps_waypoints,
    loads_waypoints,
    read_waypoints,
    sidecar_paths,
    waypoint_files,
)

if mavutil.mavlink.WIRE_PROTOCOL_VERSION != "2.0":  # pymavlink was imported before us
    mavutil.set_dialect("ardupilotmega")


@pytest.fixture(scope="module")
def site():
    return make_site()


@pytest.fixture()
def plan(site):
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(7.25),
             nav(site, Cmd.NAV_WAYPOINT, (50.123456789, 60.987654321)),
             nav(site, Cmd.NAV_WAYPOINT, (80.0, 10.0), p1=3.0), jump(2, 4),
             nav(site, Cmd.NAV_LAND, site.home_xy_m, 0.0)]
    p = plan_of(site, items, rally=[(0.0, 0.0)])
    p.breach_return = p.rally[0]
    lat, lon = site.frame.to_geodetic(np.array([[-50, -50], [250, -50], [250, 150]]))
    p.polygons = [FencePolygon(list(zip(lat.tolist(), lon.tolist(), strict=True)), True)]
    return p


def _write(tmp_path, plan):
    files = waypoint_files(plan, tmp_path / "m.waypoints")
    for path, text in files.items():
        path.write_text(text)
    return tmp_path / "m.waypoints"


def test_home_is_line_zero_and_items_follow_with_their_sequence_numbers(plan):
    lines = dumps_waypoints(plan).splitlines()
    assert lines[0] == HEADER
    home = lines[1].split("\t")
    assert home[:4] == ["0", "1", "0", "16"]
    assert float(home[8]) == plan.home_lat_deg and float(home[10]) == plan.home_alt_m
    assert [int(line.split("\t")[0]) for line in lines[1:]] == list(range(len(plan.items) + 1))


def test_our_reader_gets_back_exactly_what_we_wrote(tmp_path, plan):
    back = read_waypoints(_write(tmp_path, plan))
    assert len(back.items) == len(plan.items)
    for a, b in zip(plan.items, back.items, strict=True):
        assert (a.command, a.frame) == (b.command, b.frame)
        np.testing.assert_array_equal(np.nan_to_num(a.params), b.params)  # full precision
    assert back.circles == plan.circles
    assert back.polygons == plan.polygons
    assert back.rally == plan.rally
    assert back.breach_return == plan.breach_return


def test_the_files_hold_the_lists_that_go_over_the_wire(tmp_path, plan):
    files = waypoint_files(plan, tmp_path / "m.waypoints")
    assert len(files) == 3
    wire = plan_to_wire(plan, home_item=True)
    for text, sent in zip(files.values(), (wire.mission, wire.fence, wire.rally), strict=True):
        rows = [line.split("\t") for line in text.splitlines()[1:]]
        assert [tuple(int(f) for f in (*r[:4], r[11])) for r in rows] == [
            (w.seq, w.current, w.frame, w.command, w.autocontinue) for w in sent]
        assert [(round(float(r[8]) * 1e7), round(float(r[9]) * 1e7)) for r in rows] == [
            (w.x, w.y) for w in sent]
        for r, w in zip(rows, sent, strict=True):
            params = [w.param1, w.param2, w.param3, w.param4, w.z]
            np.testing.assert_allclose([float(f) for f in (*r[4:8], r[10])],
                                       np.nan_to_num(params), rtol=1e-6, atol=1e-6)


def test_mavwp_loads_mission_fence_and_rally_files(tmp_path, plan):
    path = _write(tmp_path, plan)
    fence_path, rally_path = sidecar_paths(path)
    wp = mavwp.MAVWPLoader()
    assert wp.load(str(path)) == len(plan.items) + 1
    for i, it in enumerate(plan.items, start=1):
        w = wp.wp(i)
        assert w.command == it.command
        if it.command in (Cmd.NAV_WAYPOINT, Cmd.NAV_TAKEOFF, Cmd.NAV_LAND):
            assert (w.x, w.y) == (it.lat_deg, it.lon_deg)
    assert wp.wp(5).param1 == 3  # DO_JUMP names seq 3 = item 2, counting home as 0
    fence = mavwp.MissionItemProtocol_Fence()
    fence.load(str(fence_path))
    assert fence.count() == 1 + len(plan.circles) + len(plan.polygons[0].vertices_deg)
    rally = mavwp.MissionItemProtocol_Rally()
    rally.load(str(rally_path))
    assert rally.count() == 1 and rally.wp(0).command == Cmd.NAV_RALLY_POINT


def test_mavwp_save_reads_back_within_its_six_decimals(tmp_path, plan):
    wp = mavwp.MAVWPLoader()
    wp.load(str(_write(tmp_path, plan)))
    wp.save(str(tmp_path / "again.waypoints"))
    back = loads_waypoints((tmp_path / "again.waypoints").read_text())
    assert [it.command for it in back.items] == [it.command for it in plan.items]
    for a, b in zip(plan.items, back.items, strict=True):
        np.testing.assert_allclose(b.params, np.nan_to_num(a.params), atol=1e-6)


def test_a_plan_without_fence_or_rally_writes_one_file(tmp_path, site):
    p = plan_of(site, [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m)], fence=False)
    assert list(waypoint_files(p, tmp_path / "x.waypoints")) == [tmp_path / "x.waypoints"]


@pytest.mark.parametrize("text, match", [
    ("QGC WPL 100\n", "line 1: expected the header"),
    (f"{HEADER}\n0\t1\t0\t16\t0\t0\t0\t0\t37\t127\t40\n", "line 2: expected 12 fields"),
    (f"{HEADER}\n0\t1\t0\t16\t0\t0\t0\t0\t37\tx\t40\t1\n", "line 2: malformed number"),
    (f"{HEADER}\n1\t1\t0\t16\t0\t0\t0\t0\t37\t127\t40\t1\n", "line 2: sequence number 1"),
    (f"{HEADER}\n", "no home line"),
])
def test_bad_files_are_refused_naming_the_line(text, match):
    with pytest.raises(InputError, match=match):
        loads_waypoints(text, "bad.waypoints")
