"""Which frames the autopilot takes a navigation item's position in (validator.flight.frames)."""

import dataclasses

import numpy as np
import pytest

from tests.validator.builders import make_site, waypoint_plan
from validator.errors import InputError
from validator.flight import resolve_flight
from validator.plan_format import Autopilot, Cmd, Frame, MissionItem

NAN = float("nan")


@pytest.fixture(scope="module")
def site():
    return make_site()


def _with_item_3(site, command: int, lat: float, lon: float, *, px4: bool = False):
    """The second waypoint of a plain plan replaced by ``command`` in frame 2, 30 m above home."""
    plan = waypoint_plan(site, [(50, -40), (150, -40)])
    plan.items[3] = MissionItem(command, [0.0, 0.0, 0.0, NAN, lat, lon, plan.home_alt_m + 30.0],
                                int(Frame.MISSION))
    return dataclasses.replace(plan, firmware_type=int(Autopilot.PX4)) if px4 else plan


@pytest.mark.parametrize("command", [Cmd.NAV_WAYPOINT, Cmd.NAV_LOITER_UNLIM,
                                     Cmd.NAV_LOITER_TURNS, Cmd.NAV_LOITER_TIME, Cmd.NAV_LAND])
def test_an_arducopter_item_with_coordinates_in_the_mission_frame_is_refused(site, command):
    """Frame 2 carries them unscaled (whole degrees, as QGroundControl sends them) and
    AP_Mission reads x and y as degrees x 1e7 in any frame: such a waypoint had been judged
    CLEAR at its latitude and longitude while the vehicle flew toward 0°N 0°E."""
    lat, lon = site.frame.to_geodetic(np.array([150.0, -40.0]))
    with pytest.raises(InputError, match=r"^p\.plan: item 3: frame 2 \(MISSION\) carries "
                                         r"latitude and longitude unscaled.*0°N 0°E"):
        resolve_flight(_with_item_3(site, int(command), float(lat), float(lon)), site, "p.plan")


@pytest.mark.parametrize("command", [Cmd.NAV_WAYPOINT, Cmd.NAV_LAND, Cmd.NAV_TAKEOFF])
def test_px4_refuses_a_navigation_item_in_the_mission_frame(site, command):
    # without coordinates too: PX4 takes no navigation command in frame 2 at all
    plan = _with_item_3(site, int(command), NAN, NAN, px4=True)
    with pytest.raises(InputError, match=rf"^p\.plan: item 3: .*PX4 refuses {command.name} "
                                         r"in it \(MAV_MISSION_UNSUPPORTED\)"):
        resolve_flight(plan, site, "p.plan")


def test_an_arducopter_waypoint_without_coordinates_in_the_mission_frame_stays_put(site):
    """x and y 0 are "where the vehicle is" to ArduPilot in any frame; frame 2's altitude is
    above sea level."""
    flight = resolve_flight(_with_item_3(site, int(Cmd.NAV_WAYPOINT), NAN, NAN), site)
    np.testing.assert_allclose(flight.legs[2].end_xy_m, flight.legs[1].end_xy_m, atol=1e-9)
    assert flight.legs[2].end_alt_m == pytest.approx(30.0)


def test_an_arducopter_takeoff_with_coordinates_in_the_mission_frame_climbs_where_it_is(site):
    # ArduCopter's takeoff uses only the item's altitude, so its coordinates mislead nothing
    plan = waypoint_plan(site, [(50, -40)])
    lat, lon = site.frame.to_geodetic(np.array([150.0, -40.0]))
    plan.items[0] = MissionItem(int(Cmd.NAV_TAKEOFF), [0.0, 0.0, 0.0, NAN, float(lat),
                                                       float(lon), plan.home_alt_m + 25.0],
                                int(Frame.MISSION))
    takeoff = resolve_flight(plan, site).legs[0]
    np.testing.assert_allclose(takeoff.end_xy_m, site.home_xy_m, atol=1e-9)
    assert takeoff.end_alt_m == pytest.approx(25.0)


@pytest.mark.parametrize("frame", [10, 11])  # GLOBAL_TERRAIN_ALT, its _INT twin
def test_px4_refuses_a_position_above_terrain(site, frame):
    """PX4 takes a position only in frames 0, 3, 5 and 6: a terrain frame had been read as
    above home with a warning, as ArduPilot may fly it."""
    plan = dataclasses.replace(waypoint_plan(site, [(50, -40), (150, -40)]),
                               firmware_type=int(Autopilot.PX4))
    plan.items[3] = dataclasses.replace(plan.items[3], frame=frame)
    with pytest.raises(InputError, match=rf"^p\.plan: item 3: frame {frame} \(above terrain\): "
                                         r"PX4 refuses the item \(MAV_MISSION_UNSUPPORTED_FRAME\)"):
        resolve_flight(plan, site, "p.plan")
