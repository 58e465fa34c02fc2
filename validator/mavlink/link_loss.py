"""When the link to a flying vehicle stays down: what the vehicle will do on its own, and
bringing it to a safe mode if the link comes back.

A vehicle flying an uploaded mission does not need the ground station: it flies on through a
link gap, and :class:`~validator.mavlink.telemetry.Recorder` keeps recording when the link
returns (the track then misses the gap). A link silent for the connection's whole timeout is
lost: :func:`after_link_loss` keeps commanding LAND for one more timeout, and if the vehicle
answers says so; if it never does, the verdict says what its own ground-station failsafe
(read before the flight by :func:`gcs_failsafe`) will do.

LAND, not a return: the vehicle descends where it is, on the mission it was flying (whose
path the audit proved clear of every zone); a return home flies a path nobody audited
(ArduCopter's RTL is a straight line at RTL_ALT), and SmartRTL retraces a flown path that the
lost link kept from us.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from validator.autopilot import failsafe as fs
from validator.mavlink.connection import Connection
from validator.mavlink.modes import ModeNumbers, mode_name
from validator.mavlink.param_protocol import decode_param
from validator.mavlink.wire import mavlink, mavutil

# How long to wait for a failsafe parameter at the flight's start: a vehicle that does not
# know it (the built-in model) never answers, and the flight should not wait a timeout for it.
PARAM_PATIENCE_S = 2.0
COMMAND_EVERY_S = 1.0  # LAND is repeated this often while the link is down

# What the vehicle does when it stops hearing the ground station is its failsafe table's
# (validator.autopilot.failsafe: ArduCopter FS_GCS_ENABLE after FS_GCS_TIMEOUT, where
# FS_OPTIONS bit 1 keeps a vehicle in AUTO on its mission; PX4 NAV_DLL_ACT after COM_DL_LOSS_T).


def _read_quickly(link: Connection, name: str, patience_s: float) -> float | None:
    """A parameter's value, or None when the vehicle does not answer within ``patience_s``."""
    ts, tc = link.target
    deadline = time.monotonic() + patience_s
    while time.monotonic() < deadline:
        link.mav.param_request_read_send(ts, tc, name.encode("ascii"), -1)
        msg = link.recv(["PARAM_VALUE"], min(deadline, time.monotonic() + link.retry_s),
                        lambda m: m.param_id == name)
        if msg is not None:
            return decode_param(msg.param_value, msg.param_type, link.vehicle.is_px4)
    return None


def gcs_failsafe(link: Connection, patience_s: float = PARAM_PATIENCE_S) -> str:
    """What the vehicle says it will do when it stops hearing us (one phrase, from its own
    failsafe parameter), or that it did not say."""
    autopilot = "px4" if link.vehicle.is_px4 else "ardupilot"
    name, after_name = fs.GCS_LOSS_PARAMS[autopilot]
    value = _read_quickly(link, name, patience_s)
    if value is None:
        return f"the vehicle did not report {name}: what it does without a link is unknown"
    failsafe = fs.failsafe_of(autopilot, name)
    if int(value) not in failsafe.actions:
        return f"{name} {value:g}: an action this tool does not know ({name} {value:g})"
    act = failsafe.action(value)
    if act.paths == ("mission",):
        return f"its {failsafe.trigger} failsafe is off: {fs.said(act)} ({name} {value:g})"
    action = fs.said(act)
    bit = fs.FS_OPTIONS_CONTINUE_AUTO.get(name, 0)
    if bit:
        options = _read_quickly(link, "FS_OPTIONS", patience_s)
        if options is not None and int(options) & bit:
            action = ("it flies the mission on in AUTO (FS_OPTIONS continues it), "
                      f"else {action.removeprefix('it ')}")
    after = _read_quickly(link, after_name, patience_s)
    when = f"after {after:g} s without us, " if after is not None else ""
    return f"{when}{action} ({name} {value:g}: {act.name})"


def land_mode(modes: ModeNumbers) -> int:
    """The custom mode number of LAND on the vehicle's autopilot."""
    if modes.px4:
        return (mavutil.PX4_CUSTOM_MAIN_MODE_AUTO << 16) | (
            mavutil.PX4_CUSTOM_SUB_MODE_AUTO_LAND << 24)
    return int(mavutil.mode_mapping_byname(mavlink.MAV_TYPE_QUADROTOR)["LAND"])


def after_link_loss(link: Connection, modes: ModeNumbers, own_failsafe: str,
                    say: Callable[[str], None] | None = None) -> tuple[bool, str]:
    """Command LAND, once a second, for one more of the link's timeouts. Returns (whether
    the vehicle accepted LAND, the verdict in one phrase)."""
    say = say or (lambda _text: None)
    land = land_mode(modes)
    name = mode_name(link, land)
    ts, tc = link.target
    say(f"link lost: commanding {name} until it answers")
    deadline = time.monotonic() + link.timeout_s
    while time.monotonic() < deadline:
        link.mav.command_long_send(ts, tc, mavlink.MAV_CMD_DO_SET_MODE, 0,
                                   *modes.set_mode_params(land), 0, 0, 0, 0)
        ack = link.recv(["COMMAND_ACK"], min(deadline, time.monotonic() + COMMAND_EVERY_S),
                        lambda m: int(m.command) == mavlink.MAV_CMD_DO_SET_MODE)
        if ack is None:
            continue
        if ack.result == mavlink.MAV_RESULT_ACCEPTED:
            return True, f"the link came back and the vehicle accepted {name}"
        result = mavlink.enums["MAV_RESULT"][int(ack.result)].name
        return False, (f"the link came back but the vehicle refused {name} ({result}); "
                       f"{own_failsafe}")
    return False, f"it did not come back within {link.timeout_s:g} s; {own_failsafe}"
