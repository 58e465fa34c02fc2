"""The built-in vehicle's answer to a ground station's MAV_CMD_DO_SET_HOME (COMMAND_LONG and
COMMAND_INT), as ArduCopter 4.5's ``GCS_MAVLINK::handle_command_do_set_home`` gives it: the ACK,
the home RTL then flies to, and the home that arming no longer moves (the copter stepped by
hand, no socket; the last test goes over MAVLink)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.validator.builders import make_site
from tests.validator.mavlink.conftest import url_of
from tests.validator.mavlink.test_vehicle_home import (
    A_XY,
    ALT_M,
    B_XY,
    copter_for,
    fly_until,
    set_home_plan,
)
from validator.geodesy import from_int_e7, to_int_e7
from validator.mavlink.link import Link, upload_to
from validator.mavlink.sim import CopterMode
from validator.mavlink.sim.commands import Commands
from validator.mavlink.wire import mavlink

m = mavlink
NEW_HOME_XY = (40.0, -30.0)


@pytest.fixture()
def site():
    return make_site(nfz=((300.0, 300.0, 10.0),), gns=(A_XY, B_XY))


def command_long(p1: float, lat: float = 0.0, lon: float = 0.0, alt: float = 0.0):
    return m.MAVLink_command_long_message(1, 1, m.MAV_CMD_DO_SET_HOME, 0, p1, 0, 0, 0,
                                          lat, lon, alt)


def command_int(p1: float, frame: int, lat: float, lon: float, alt: float):
    return m.MAVLink_command_int_message(1, 1, frame, m.MAV_CMD_DO_SET_HOME, 0, 0, p1, 0, 0,
                                         0, int(to_int_e7(lat)), int(to_int_e7(lon)), alt)


def flying(site):
    """A copter hovering ALT_M above (10, 20), taken there in GUIDED; its Commands and sends."""
    copter, sent = copter_for(set_home_plan(site))
    copter.set_mode(CopterMode.GUIDED)
    copter.arm(True, False)
    copter.takeoff(ALT_M)
    fly_until(copter, lambda: copter.alt_m > ALT_M - 0.05)
    copter._target = (np.array([10.0, 20.0]), ALT_M)
    fly_until(copter, lambda: np.hypot(*(copter.xy - (10.0, 20.0))) < 0.05)
    return copter, Commands(copter), sent


def ack_of(commands: Commands, sent, msg) -> int:
    commands.on_command(msg)
    return int(sent.calls["command_ack_send"][-1][1])


def lat_lon(site, xy):
    lat, lon = site.frame.to_geodetic(np.asarray(xy, dtype=float))
    return float(lat), float(lon)


def test_param1_1_sets_home_where_the_vehicle_is_altitude_included(site):
    copter, commands, sent = flying(site)
    assert ack_of(commands, sent, command_long(1.0)) == m.MAV_RESULT_ACCEPTED
    np.testing.assert_allclose(copter.home.xy_m, copter.xy, atol=1e-9)
    assert copter.home.alt_m == pytest.approx(copter.alt_m)


def test_the_new_home_is_sent_unasked(site):
    copter, commands, sent = flying(site)
    before = len(sent.calls.get("home_position_send", []))
    ack_of(commands, sent, command_long(1.0))
    lat, lon, alt_mm = sent.calls["home_position_send"][before][:3]
    xy = site.frame.to_local(from_int_e7(lat), from_int_e7(lon))
    np.testing.assert_allclose(xy, copter.xy, atol=0.02)
    assert alt_mm / 1000.0 == pytest.approx(site.frame.alt0_m + ALT_M, abs=0.01)


def test_command_long_takes_degrees_and_an_altitude_above_sea_level(site):
    copter, commands, sent = flying(site)
    lat, lon = lat_lon(site, NEW_HOME_XY)
    amsl_m = site.frame.alt0_m + 5.0
    assert ack_of(commands, sent, command_long(0.0, lat, lon, amsl_m)) == m.MAV_RESULT_ACCEPTED
    np.testing.assert_allclose(copter.home.xy_m, NEW_HOME_XY, atol=0.02)
    assert copter.home.alt_m == pytest.approx(5.0, abs=1e-3)


def test_command_int_above_home_is_made_absolute_against_the_home_in_force(site):
    copter, commands, sent = flying(site)
    ack_of(commands, sent, command_long(1.0))  # home now ALT_M up, where the vehicle is
    lat, lon = lat_lon(site, NEW_HOME_XY)
    msg = command_int(0.0, m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, lat, lon, 2.0)
    assert ack_of(commands, sent, msg) == m.MAV_RESULT_ACCEPTED
    np.testing.assert_allclose(copter.home.xy_m, NEW_HOME_XY, atol=0.02)
    assert copter.home.alt_m == pytest.approx(ALT_M + 2.0, abs=1e-3)


def test_latitude_and_longitude_0_is_where_the_vehicle_is(site):
    copter, commands, sent = flying(site)
    assert ack_of(commands, sent, command_long(0.0, 0.0, 0.0, 50.0)) == m.MAV_RESULT_ACCEPTED
    np.testing.assert_allclose(copter.home.xy_m, copter.xy, atol=1e-9)


def test_rtl_after_the_command_lands_at_the_new_home(site):
    copter, commands, sent = flying(site)
    lat, lon = lat_lon(site, NEW_HOME_XY)
    ack_of(commands, sent, command_long(0.0, lat, lon, site.frame.alt0_m))
    copter.set_mode(CopterMode.RTL)
    fly_until(copter, lambda: not copter.armed)
    np.testing.assert_allclose(copter.xy, NEW_HOME_XY, atol=0.1)


@pytest.mark.parametrize("msg", [
    pytest.param(command_long(0.0, 47.0, 8.0, math.nan), id="altitude NaN"),
    pytest.param(command_long(0.0, 47.0, 8.0, 90_000.0), id="altitude beyond 83 km"),
    pytest.param(command_int(0.0, m.MAV_FRAME_MISSION, 47.0, 8.0, 0.0), id="frame MISSION"),
    pytest.param(command_int(0.0, m.MAV_FRAME_LOCAL_NED, 47.0, 8.0, 0.0), id="frame LOCAL_NED"),
])
def test_a_location_arducopter_cannot_read_is_denied_and_home_stays(site, msg):
    copter, commands, sent = flying(site)
    home = copter.home
    assert ack_of(commands, sent, msg) == m.MAV_RESULT_DENIED
    assert copter.home is home


@pytest.mark.parametrize("msg", [
    pytest.param(command_long(0.0, 100.0, 8.0, 500.0), id="latitude 100"),
    pytest.param(command_long(2.0, 47.0, 8.0, 500.0), id="param1 2"),
    pytest.param(command_int(0.0, m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 47.0, 8.0, 60_000.0),
                 id="60 km above the EKF origin"),
])
def test_a_home_set_home_refuses_fails_and_home_stays(site, msg):
    copter, commands, sent = flying(site)
    home = copter.home
    assert ack_of(commands, sent, msg) == m.MAV_RESULT_FAILED
    assert copter.home is home


def test_a_ground_stations_home_is_locked_arming_does_not_move_it(site):
    copter, sent = copter_for(set_home_plan(site))
    commands = Commands(copter)
    lat, lon = lat_lon(site, NEW_HOME_XY)
    ack_of(commands, sent, command_long(0.0, lat, lon, site.frame.alt0_m))
    copter.set_mode(CopterMode.GUIDED)
    assert copter.arm(True, False) == m.MAV_RESULT_ACCEPTED
    np.testing.assert_allclose(copter.home.xy_m, NEW_HOME_XY, atol=0.02)


def test_over_mavlink_the_downloaded_missions_item_0_is_the_commanded_home(site, start_vehicle):
    """ArduPilot's mission item 0 is home as it is now (``AP_Mission::read_cmd_from_storage``
    reads it from AP_AHRS), not the home uploaded as item 0."""
    plan = set_home_plan(site)
    vehicle = start_vehicle(plan, speedup=50.0)
    lat, lon = lat_lon(site, NEW_HOME_XY)
    with Link(url_of(vehicle), timeout_s=3) as link:
        upload_to(link, plan, require_fence=False)
        result = link.command(m.MAV_CMD_DO_SET_HOME, 0.0, 0, 0, 0, lat, lon,
                              site.frame.alt0_m + 3.0)
        lists = link.download()
    assert result == m.MAV_RESULT_ACCEPTED
    home = lists.mission[0]
    assert (home.command, home.frame) == (16, m.MAV_FRAME_GLOBAL)
    # COMMAND_LONG carries degrees as float32 (about 0.2 m here): the home is what it carried
    sent_xy = site.frame.to_local(float(np.float32(lat)), float(np.float32(lon)))
    np.testing.assert_allclose(site.frame.to_local(from_int_e7(home.x), from_int_e7(home.y)),
                               sent_xy, atol=0.02)
    assert home.z == pytest.approx(site.frame.alt0_m + 3.0, abs=1e-3)
