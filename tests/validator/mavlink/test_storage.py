"""ArduPilot's storage rules, one per test: what it reads back of what we send, and the
changes of meaning that make an upload refuse before anything is sent."""

import dataclasses
import math

import pytest

from validator.mavlink.storage import (
    ARDUPILOT,
    PX4,
    first_stored_difference,
    storage_losses,
    stored_form,
)
from validator.mavlink.wire import MissionType, WireItem, plan_to_wire
from validator.plan_format import Cmd

NAN = math.nan
LAT, LON = 375585000, 1269990000


def item(cmd, p=(0.0, 0.0, 0.0, 0.0), frame=3, z=30.0, mtype=0, seq=1, x=LAT, y=LON):
    return WireItem(seq, frame, int(cmd), *p, x, y, z, mtype)


def test_unused_waypoint_params_read_back_as_zero_and_the_hold_is_kept():
    held = stored_form(item(Cmd.NAV_WAYPOINT, (3.0, 2.0, 1.0, NAN)), ARDUPILOT)
    assert (held.param1, held.param2, held.param3, held.param4) == (3.0, 0.0, 0.0, 0.0)
    assert (held.x, held.y, held.z, held.frame, held.autocontinue) == (LAT, LON, 30.0, 3, 1)


def test_a_fractional_hold_is_truncated_to_whole_seconds_and_that_is_a_loss():
    wp = item(Cmd.NAV_WAYPOINT, (1.5, 0.0, 0.0, NAN))
    assert stored_form(wp, ARDUPILOT).param1 == 1.0
    assert storage_losses((wp,), ARDUPILOT) == [
        "mission item 1: ArduPilot would keep param1 1.5 of command 16 as 1"]


def test_land_param4_nan_reads_back_as_plus_one_and_a_negative_as_minus_one():
    assert stored_form(item(Cmd.NAV_LAND, (0.0, 0.0, 0.0, NAN)), ARDUPILOT).param4 == 1.0
    assert stored_form(item(Cmd.NAV_LAND, (0.0, 0.0, 0.0, -3.0)), ARDUPILOT).param4 == -1.0


def test_do_commands_lose_their_frame_and_position():
    sp = item(Cmd.DO_CHANGE_SPEED, (1.0, 7.25, -1.0, 0.0), frame=2, z=0.0, x=0, y=0)
    held = stored_form(sp, ARDUPILOT)
    assert held.frame == 0 and (held.param1, held.param2, held.param3) == (1.0, 7.25, -1.0)


def test_a_changed_speed_or_jump_is_still_a_difference():
    sp = item(Cmd.DO_CHANGE_SPEED, (1.0, 7.25, -1.0, 0.0), frame=2, z=0.0, x=0, y=0)
    slower = dataclasses.replace(stored_form(sp, ARDUPILOT), param2=7.0)
    diff = first_stored_difference((sp,), (slower,), MissionType.MISSION, ARDUPILOT)
    assert diff is not None and "param2" in diff
    jmp = item(Cmd.DO_JUMP, (2.0, 3.0, 0.0, 0.0), frame=2, z=0.0, x=0, y=0)
    fewer = dataclasses.replace(stored_form(jmp, ARDUPILOT), param2=2.0)
    assert "param2" in first_stored_difference((jmp,), (fewer,), MissionType.MISSION,
                                               ARDUPILOT)


def test_a_moved_coordinate_or_changed_command_is_a_difference():
    wp = item(Cmd.NAV_WAYPOINT, (0.0, 0.0, 0.0, NAN))
    moved = dataclasses.replace(stored_form(wp, ARDUPILOT), x=LAT + 1)
    assert "x expected" in first_stored_difference((wp,), (moved,), MissionType.MISSION,
                                                   ARDUPILOT)
    other = dataclasses.replace(stored_form(wp, ARDUPILOT), command=int(Cmd.NAV_LOITER_UNLIM))
    assert "command" in first_stored_difference((wp,), (other,), MissionType.MISSION,
                                                ARDUPILOT)


@pytest.mark.parametrize("sent, kept", [(0, 0), (5, 0), (6, 3), (3, 3), (2, 0), (11, 10)])
def test_location_frames_are_kept_as_absolute_relative_or_terrain(sent, kept):
    assert stored_form(item(Cmd.NAV_WAYPOINT, frame=sent), ARDUPILOT).frame == kept


def test_altitudes_are_kept_in_whole_centimetres():
    held = stored_form(item(Cmd.NAV_WAYPOINT, z=30.006), ARDUPILOT)
    assert held.z == pytest.approx(30.0, abs=1e-5)
    assert storage_losses((item(Cmd.NAV_WAYPOINT, z=30.006),), ARDUPILOT) == []


def test_fence_items_read_back_with_autocontinue_0_frame_0_and_no_altitude():
    circle = item(Cmd.NAV_FENCE_CIRCLE_EXCLUSION, (32.5, 0.0, 0.0, 0.0), frame=0, z=0.0, mtype=1)
    ret = item(5000, frame=3, z=25.0, mtype=1)
    held_c, held_r = stored_form(circle, ARDUPILOT), stored_form(ret, ARDUPILOT)
    assert (held_c.autocontinue, held_c.frame, held_c.param1) == (0, 0, 32.5)
    assert (held_r.frame, held_r.z, held_r.autocontinue) == (0, 0.0, 0)


def test_rally_altitudes_are_whole_metres():
    rally = item(Cmd.NAV_RALLY_POINT, frame=3, z=30.4, mtype=2)
    assert stored_form(rally, ARDUPILOT).z == 30.0
    assert storage_losses((rally,), ARDUPILOT) == []  # within its metre resolution


def test_a_vehicle_that_stores_verbatim_also_passes():
    wp = item(Cmd.NAV_WAYPOINT, (0.0, 0.0, 0.0, NAN))
    assert first_stored_difference((wp,), (wp,), MissionType.MISSION, ARDUPILOT) is None


def test_other_autopilots_are_compared_verbatim():
    wp = item(Cmd.NAV_WAYPOINT, (0.0, 0.0, 0.0, NAN))
    assert stored_form(wp, 0) == wp and storage_losses((wp,), 0) == []


@pytest.mark.parametrize("sent, kept", [(3, 6), (0, 5), (6, 6), (2, 2)])
def test_px4_reads_positions_back_in_the_int_frames(sent, kept):
    assert stored_form(item(Cmd.NAV_WAYPOINT, frame=sent), PX4).frame == kept


def test_px4_keeps_waypoint_hold_and_radius_and_wraps_the_yaw():
    held = stored_form(item(Cmd.NAV_WAYPOINT, (2.5, 1.0, 7.0, -90.0)), PX4)
    assert (held.param1, held.param2, held.param3, held.param4) == (2.5, 1.0, 0.0, 270.0)
    nan_yaw = stored_form(item(Cmd.NAV_WAYPOINT, (2.5, 1.0, 0.0, NAN)), PX4)
    assert math.isnan(nan_yaw.param4)  # "keep the current heading" survives
    assert storage_losses((item(Cmd.NAV_WAYPOINT, (2.5, 0.0, 0.0, NAN)),), PX4) == []


def test_px4_yaw_within_its_float_round_trip_is_not_a_difference():
    wp = item(Cmd.NAV_WAYPOINT, (0.0, 0.0, 0.0, 45.0))
    held = dataclasses.replace(stored_form(wp, PX4), param4=45.00001)
    assert first_stored_difference((wp,), (held,), MissionType.MISSION, PX4) is None
    turned = dataclasses.replace(held, param4=46.0)
    assert "param4" in first_stored_difference((wp,), (turned,), MissionType.MISSION, PX4)


def test_px4_keeps_do_commands_as_sent():
    sp = item(Cmd.DO_CHANGE_SPEED, (1.0, 7.25, -1.0, 0.0), frame=2, z=0.0, x=0, y=0)
    assert stored_form(sp, PX4) == sp


def test_our_plans_lose_nothing_in_ardupilot_storage(plan):
    wire = plan_to_wire(plan, home_item=True)
    assert [line for t in MissionType for line in storage_losses(wire.of(t), ARDUPILOT)] == []
