"""What an autopilot keeps of the mission, fence and rally items it accepts: its storage rules.

An autopilot does not store MISSION_ITEM_INT verbatim. ArduPilot packs each mission item into a
15-byte command and keeps only the params that command uses, in the C type it stores them in;
everything else reads back as 0. :func:`stored_form` gives the item as the autopilot will hold
it, so a read-back can be compared exactly with what was sent *as stored* and every real
corruption (a moved coordinate, a changed command, speed, hold or jump) still shows.
:func:`storage_losses` finds, before anything is sent, items whose *meaning* the storage would
change (a fractional hold ArduPilot truncates to whole seconds): those are refused, because
the vehicle would fly something other than the plan.

ArduPilot 4.5 (``AP_Mission::mavlink_int_to_mission_cmd`` and ``mission_cmd_to_mavlink_int``,
``MissionItemProtocol_Fence``, ``MissionItemProtocol_Rally``; checked against ArduCopter 4.5.6
SITL):

- mission: frame 0 for commands without a location; for those with one, 0 (absolute: from 0,
  2 or 5), 3 (above home: from 3 or 6) or 10 (above terrain: from 10 or 11); altitude kept in
  whole cm (truncated) and read back as float32 ``cm * 0.01``; autocontinue 1; the unused
  params 0 (so NaN "use default" reads back as 0); NAV_WAYPOINT's hold, NAV_TAKEOFF's and
  NAV_LAND's param1 in a uint16 (whole seconds / metres); NAV_LAND's param4 as +1 or -1 (NaN
  reads back +1); DO_CHANGE_SPEED's type in a uint8, speed and throttle as float; DO_JUMP's
  target in a uint16 and repeat count in an int16.
- fence: frame 0, autocontinue 0, altitude 0; param1 is the circle radius (float) or the
  polygon's vertex count (uint8), 0 for the breach-return point, whose altitude is not kept
  (ArduPilot takes it from FENCE_RET_ALT).
- rally: frame as for mission locations, altitude in an int16 of whole metres, params 0,
  autocontinue 0.

PX4 v1.15 (``MavlinkMissionManager::parse_mavlink_mission_item`` and
``format_mavlink_mission_item``):

- items with a position read back in the int frames: 5 (absolute, from 0 or 5) or 6 (above
  home, from 3 or 6), coordinates and altitude as sent, autocontinue as sent; each command keeps
  its own params (NAV_WAYPOINT: hold, acceptance radius and yaw; NAV_TAKEOFF and NAV_LAND:
  yaw; fence circles: radius; polygon vertices: count; rally and return points: none), the rest
  0; yaw is kept in radians in [0, 2pi), so it reads back wrapped to [0, 360) degrees; fence
  items read back in frame 5 (PX4 keeps the frame sent but does not report it) with
  autocontinue 0.
- items in MAV_FRAME_MISSION (DO commands) keep params and x, y, z as sent, DO_JUMP's target
  and repeat count as uint16.

Commands without a rule here are compared param for param, with NaN read back as 0 (ArduPilot)
or as sent (PX4).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from validator.flight.frames import ARDUPILOT_LOCATED
from validator.item_numbers import list_item_label
from validator.mavlink.wire import GLOBAL_FRAMES, MissionType, WireItem, f32, first_difference
from validator.plan_format import Autopilot, Cmd

ARDUPILOT = int(Autopilot.ARDUPILOTMEGA)
PX4 = int(Autopilot.PX4)

Store = Callable[[float], float]  # a param as the autopilot's C type keeps it


def _c_int(bits: int, signed: bool) -> Store:
    """C's float -> integer conversion (truncation toward zero); NaN becomes 0 as on x86/ARM
    builds, out-of-range values saturate (what the autopilot's compilers do in practice)."""
    lo, hi = (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if signed else (0, 2**bits - 1)

    def store(v: float) -> float:
        if math.isnan(v):
            return 0.0
        return float(min(hi, max(lo, math.trunc(v))))

    return store



def _flag(v: float) -> float:
    """A param kept as a bit set when it is positive (loiter exit, forced heading)."""
    return float(v > 0)


def _sign(v: float) -> float:
    """NAV_LAND's param4: stored as a 'counter-clockwise' bit, read back as -1 or +1."""
    return -1.0 if (not math.isnan(v) and v < 0) else 1.0


U8, U16, I16 = _c_int(8, False), _c_int(16, False), _c_int(16, True)

# command -> how param1..param4 are kept (None: not kept, reads back 0) and which of them carry
# meaning for a multicopter (a change to those is a loss, see storage_losses).
_ARDUPILOT_MISSION: dict[int, tuple[tuple[Store | None, ...], frozenset[int]]] = {
    int(Cmd.NAV_WAYPOINT): ((U16, None, None, None), frozenset({0})),  # hold, s
    int(Cmd.NAV_RETURN_TO_LAUNCH): ((None, None, None, None), frozenset()),
    int(Cmd.NAV_LAND): ((U16, None, None, _sign), frozenset()),  # plane-only abort alt, yaw dir
    int(Cmd.NAV_TAKEOFF): ((U16, None, None, None), frozenset()),  # plane-only minimum pitch
    int(Cmd.NAV_LOITER_TIME): ((U16, None, _sign, _flag), frozenset({0})),
    int(Cmd.DO_JUMP): ((U16, I16, None, None), frozenset({0, 1})),
    int(Cmd.DO_CHANGE_SPEED): ((U8, f32, f32, None), frozenset({0, 1})),
}
_LOCATION_FRAME = {0: 0, 2: 0, 5: 0, 3: 3, 6: 3, 10: 10, 11: 10}
ALT_TOLERANCE_M = 0.01  # ArduPilot keeps mission altitudes in whole cm: not a loss
RALLY_ALT_TOLERANCE_M = 1.0  # ... and rally altitudes in whole metres


def _cm_alt(z: float) -> float:
    """A mission altitude (m) after ArduPilot's float32 cm round trip."""
    cm = np.float32(z) * np.float32(100.0)
    kept = np.int32(np.trunc(cm)) if np.isfinite(cm) else np.int32(0)
    return float(np.float32(kept) * np.float32(0.01))


def _ardupilot_mission(item: WireItem) -> WireItem:
    rule = _ARDUPILOT_MISSION.get(item.command)
    raw = (item.param1, item.param2, item.param3, item.param4)
    if rule is None:
        params = tuple(0.0 if math.isnan(v) else v for v in raw)
    else:
        params = tuple(0.0 if keep is None else keep(v) for keep, v in zip(rule[0], raw,
                                                                            strict=True))
    if item.command in ARDUPILOT_LOCATED:
        frame = _LOCATION_FRAME.get(item.frame, item.frame)
        x, y, z = item.x, item.y, _cm_alt(item.z)
    elif rule is not None:
        frame, x, y, z = 0, 0, 0, 0.0
    else:
        frame, x, y, z = 0, item.x, item.y, item.z
    return dataclasses.replace(item, frame=frame, param1=params[0], param2=params[1],
                               param3=params[2], param4=params[3], x=x, y=y, z=z,
                               autocontinue=1)


def _ardupilot_fence(item: WireItem) -> WireItem:
    if item.command in (int(Cmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION),
                        int(Cmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION)):
        p1 = U8(item.param1)
    elif item.command in (int(Cmd.NAV_FENCE_CIRCLE_INCLUSION),
                          int(Cmd.NAV_FENCE_CIRCLE_EXCLUSION)):
        p1 = f32(item.param1)
    else:  # the breach-return point
        p1 = 0.0
    return dataclasses.replace(item, frame=0, param1=p1, param2=0.0, param3=0.0, param4=0.0,
                               z=0.0, autocontinue=0)


def _ardupilot_rally(item: WireItem) -> WireItem:
    return dataclasses.replace(item, frame=_LOCATION_FRAME.get(item.frame, item.frame),
                               param1=0.0, param2=0.0, param3=0.0, param4=0.0,
                               z=I16(item.z), autocontinue=0)


def _yaw(v: float) -> float:
    """PX4's yaw: kept in radians wrapped to [0, 2pi), read back in degrees."""
    return v if math.isnan(v) else f32(math.fmod(math.fmod(f32(v), 360.0) + 360.0, 360.0))


def _vertex_count(v: float) -> float:
    """PX4 rounds a polygon's vertex count to the nearest whole number."""
    return U16(v + 0.5)


def _zero(_v: float) -> float:
    return 0.0



YAW_TOLERANCE_DEG = 1e-3  # PX4's float32 degree-radian round trip moves a yaw by ~1e-5 deg
_PX4_POSITIONED: dict[int, tuple[Store, Store, Store, Store]] = {
    int(Cmd.NAV_WAYPOINT): (f32, f32, _zero, _yaw),
    int(Cmd.NAV_LOITER_UNLIM): (_zero, _zero, f32, _yaw),
    int(Cmd.NAV_LOITER_TIME): (f32, _flag, f32, _flag),
    int(Cmd.NAV_LAND): (_zero, U8, _zero, _yaw),
    int(Cmd.NAV_TAKEOFF): (_zero, _zero, _zero, _yaw),
    int(Cmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION): (_vertex_count, _zero, _zero, _zero),
    int(Cmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION): (_vertex_count, _zero, _zero, _zero),
    int(Cmd.NAV_FENCE_CIRCLE_INCLUSION): (f32, _zero, _zero, _zero),
    int(Cmd.NAV_FENCE_CIRCLE_EXCLUSION): (f32, _zero, _zero, _zero),
    5000: (_zero, _zero, _zero, _zero),  # NAV_FENCE_RETURN_POINT
    int(Cmd.NAV_RALLY_POINT): (_zero, _zero, _zero, _zero),
}
_PX4_INT_FRAME = {0: 5, 5: 5, 3: 6, 6: 6}


def _px4(item: WireItem) -> WireItem:
    raw = (item.param1, item.param2, item.param3, item.param4)
    if item.frame == 2:
        keep: tuple[Store, ...] = ((U16, U16, f32, f32) if item.command == int(Cmd.DO_JUMP)
                                   else (f32,) * 4)
        frame = 2
    elif item.frame in _PX4_INT_FRAME:
        keep = _PX4_POSITIONED.get(item.command, (f32,) * 4)
        frame = _PX4_INT_FRAME[item.frame]
    else:
        return item
    p = tuple(k(v) for k, v in zip(keep, raw, strict=True))
    autocontinue = item.autocontinue
    if item.mission_type == int(MissionType.FENCE):
        # A fence point is stored with its frame but without an autocontinue flag, and read
        # back without its altitude reference: frame 5 whatever was sent, autocontinue 0.
        frame, autocontinue = 5, 0
    return dataclasses.replace(item, frame=frame, param1=p[0], param2=p[1], param3=p[2],
                               param4=p[3], autocontinue=autocontinue)


def _yaw_close(expected: WireItem, held: WireItem) -> WireItem:
    """``expected`` with ``held``'s yaw when the two are the same angle to within
    :data:`YAW_TOLERANCE_DEG` (PX4's float32 radian round trip is not bit-exact)."""
    a, b = expected.param4, held.param4
    if math.isfinite(a) and math.isfinite(b):
        diff = abs((a - b + 180.0) % 360.0 - 180.0)
        if diff < YAW_TOLERANCE_DEG:
            return dataclasses.replace(expected, param4=b)
    return expected


def stored_form(item: WireItem, autopilot: int) -> WireItem:
    """``item`` as ``autopilot`` (MAV_AUTOPILOT) holds it after accepting it; unchanged for an
    autopilot without known rules (our built-in vehicle stores verbatim)."""
    if autopilot == PX4:
        return _px4(item)
    if autopilot != ARDUPILOT:
        return item
    kind = MissionType(item.mission_type)
    if kind == MissionType.MISSION:
        return _ardupilot_mission(item)
    if kind == MissionType.FENCE:
        return _ardupilot_fence(item)
    return _ardupilot_rally(item)


def storage_losses(items: tuple[WireItem, ...], autopilot: int) -> list[str]:
    """One line per item whose meaning ``autopilot``'s storage would change: a hold, speed or
    jump the vehicle would not keep as planned, an altitude moved by more than its storage
    resolution. Params the autopilot ignores on a multicopter are not losses. Nor is an item
    the autopilot refuses or misplaces for its frame (a frame-2 waypoint ArduPilot flies toward
    0°N 0°E): that is :func:`validator.flight.frames.plan_refusal`'s rule, which
    :func:`~validator.mavlink.link.upload_to` asks first."""
    if autopilot != ARDUPILOT:
        return []
    out: list[str] = []
    for it in items:
        kept = stored_form(it, autopilot)
        label = list_item_label(it.seq, home_item=True, mission_type=it.mission_type)
        rule = _ARDUPILOT_MISSION.get(it.command) if it.mission_type == 0 else None
        for i in sorted(rule[1]) if rule else ():
            sent = (it.param1, it.param2, it.param3, it.param4)[i]
            held = (kept.param1, kept.param2, kept.param3, kept.param4)[i]
            if math.isfinite(sent) and f32(sent) != held:
                out.append(f"{label}: ArduPilot would keep param{i + 1} {sent:g} of command "
                           f"{it.command} as {held:g}")
        located = it.mission_type == 2 or (it.mission_type == 0
                                           and it.command in ARDUPILOT_LOCATED)
        if located and it.frame in GLOBAL_FRAMES:
            tol = RALLY_ALT_TOLERANCE_M if it.mission_type == 2 else ALT_TOLERANCE_M
            if not abs(kept.z - it.z) < tol:
                out.append(f"{label}: ArduPilot would keep altitude {it.z:g} m as {kept.z:g} m")
    return out


def first_stored_difference(
    sent: tuple[WireItem, ...], held: tuple[WireItem, ...], mission_type: MissionType,
    autopilot: int, *, skip_seq0: bool = False,
) -> str | None:
    """One line naming the first field in which ``held`` differs from ``sent``, or None when
    the vehicle holds each item either verbatim or exactly as its autopilot's storage rules
    turn it (:func:`stored_form`): both mean the vehicle keeps what we sent."""
    if len(held) != len(sent):
        return first_difference(sent, held, mission_type, home_item=autopilot != PX4)
    expected = tuple(h if h.content() == s.content() else stored_form(s, autopilot)
                     for s, h in zip(sent, held, strict=True))
    if autopilot == PX4:
        expected = tuple(_yaw_close(e, h) if e.command in _PX4_POSITIONED else e
                         for e, h in zip(expected, held, strict=True))
    label = {ARDUPILOT: "expected (as ArduPilot stores what we sent)",
             PX4: "expected (as PX4 stores what we sent)"}.get(autopilot, "sent")
    return first_difference(expected, held, mission_type, skip_seq0=skip_seq0, expected=label,
                            home_item=autopilot != PX4)
