"""A recording that ends at the disarm ends on a sample marked disarmed
(:meth:`validator.mavlink.telemetry.Recorder.disarm_recorded`)."""

from __future__ import annotations

import time
from types import SimpleNamespace

from validator.mavlink.telemetry import Recorder
from validator.mavlink.wire import mavlink

MAV = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)


def _recorder() -> Recorder:
    return Recorder(SimpleNamespace(listeners=[]))  # type: ignore[arg-type]


def _heartbeat(armed: bool):
    flags = mavlink.MAV_MODE_FLAG_SAFETY_ARMED if armed else 0
    return MAV.heartbeat_encode(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                flags | mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 9, 4)


def _position(t_ms: int):
    return MAV.global_position_int_encode(t_ms, 523000000, 40000000, 1000, 0, 0, 0, 0, 0)


def test_the_disarm_heartbeat_alone_does_not_end_the_recording():
    rec = _recorder()
    rec.take(_heartbeat(True))
    rec.take(_position(1000))
    done = rec.disarm_recorded(grace_s=60.0)
    assert not done()
    rec.take(_heartbeat(False))
    assert not done()  # the last sample still says armed
    rec.take(_position(1050))
    assert done() and not rec.rows[-1][8]


def test_without_a_position_after_the_disarm_it_ends_after_the_grace():
    rec = _recorder()
    rec.take(_heartbeat(True))
    rec.take(_position(1000))
    rec.take(_heartbeat(False))
    done = rec.disarm_recorded(grace_s=0.05)
    assert not done()
    time.sleep(0.06)
    assert done()


def test_the_clock_and_a_mode_change_go_on_without_position_reports():
    # PX4 after a GPS loss: no GLOBAL_POSITION_INT, a 1 Hz heartbeat; ATTITUDE keeps the
    # time, CURRENT_MODE (asked for) says the failsafe's mode as it changes
    rec = Recorder(SimpleNamespace(listeners=[], vehicle=SimpleNamespace(  # type: ignore[arg-type]
        is_px4=False)))
    rec.take(_heartbeat(True))
    rec.take(MAV.current_mode_encode(0, 3, 3))  # AUTO
    rec.mission_mode = 3
    rec.take(_position(1000))
    rec.take(MAV.attitude_encode(5300, 0, 0, 0, 0, 0, 0))
    rec.take(MAV.current_mode_encode(0, 9, 9))  # LAND
    rec.take(MAV.attitude_encode(5200, 0, 0, 0, 0, 0, 0))  # overtaken: no step back
    rec.take(_heartbeat(True))  # the heartbeat's LAND (9) is no news by then
    assert rec.t_s == 5.3 and len(rec.rows) == 1
    assert rec.mode_changes == [(5.3, "LAND")]
