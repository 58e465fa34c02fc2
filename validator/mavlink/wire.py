"""The MAVLink wire format of a plan: :class:`Plan` <-> MISSION_ITEM_INT lists. Nothing else.

The lists themselves (what goes in which order: home at seq 0 for ArduPilot, fence polygons,
circles and the breach return point, rally points) are :mod:`validator.item_lists`, shared
with ``.waypoints`` files. Here they travel: latitude and longitude as int32 degrees x 1e7
(rounded to nearest, :func:`validator.geodesy.to_int_e7`), local x/y as int32 metres x 1e4,
params and z as float32, each item with its ``mission_type`` (0 mission, 1 fence, 2 rally).
In any other frame, frame 2 (MISSION) above all, params 5 and 6 go unscaled, as
QGroundControl and MAVSDK send a ``.plan`` item's (what autopilots make of that is
:mod:`validator.flight.frames`): a whole number as it is, a fraction refused, since they would
cut it and the item read back would not be the item sent. Read back, x and y are decoded by the
same frame rules, so a list sent and read back unchanged gives back the plan sent.
Importing this module selects pymavlink's MAVLink 2 ArduPilot dialect (MAVLink 1 has no
``mission_type``, so fences and rally points would be lost).
"""

from __future__ import annotations

import math
import os
import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any

os.environ["MAVLINK20"] = "1"  # must precede pymavlink's first import to get MAVLink 2

from pymavlink import mavutil  # noqa: E402

if mavutil.mavlink.WIRE_PROTOCOL_VERSION != "2.0":  # someone imported pymavlink before us
    mavutil.set_dialect("ardupilotmega")

from validator.errors import InputError  # noqa: E402
from validator.geodesy import from_int_e7, to_int_e7  # noqa: E402
from validator.item_lists import (  # noqa: E402
    GLOBAL_FRAMES,
    ItemLists,
    ListItem,
    fence_from_items,
    mission_from_items,
    plan_items,
    rally_from_items,
)
from validator.item_numbers import list_item_label, wire_item_number  # noqa: E402
from validator.plan_format import Autopilot, Plan  # noqa: E402

mavlink: Any = mavutil.mavlink  # the MAVLink 2 dialect module (message classes and enums)

INT32_MAX = 2**31 - 1

# GLOBAL_FRAMES (validator.item_lists): x/y are latitude/longitude, int32 degrees x 1e7 here.
# Frames whose x/y are metres x 1e4 in MISSION_ITEM_INT.
LOCAL_FRAMES = frozenset({1, 4, 7, 8, 9, 12, 13, 14, 15, 20, 21})
LOCAL_SCALE = 1e4


class MissionType(IntEnum):
    """MAV_MISSION_TYPE: the three lists a vehicle holds."""

    MISSION = 0
    FENCE = 1
    RALLY = 2

    @property
    def label(self) -> str:
        return self.name.lower()


def f32(v: float) -> float:
    """``v`` after a trip through a float32 field."""
    return float(struct.unpack("<f", struct.pack("<f", float(v)))[0])


_NAN_BITS = struct.pack("<f", math.nan)


def _f32_bits(v: float) -> bytes:
    """``v`` as float32 bytes; every NaN alike (autopilots return NaNs of either sign)."""
    return _NAN_BITS if math.isnan(v) else struct.pack("<f", float(v))


@dataclass(frozen=True)
class WireItem:
    """One MISSION_ITEM_INT, field for field (``current`` is vehicle state, not content)."""

    seq: int
    frame: int
    command: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int
    y: int
    z: float
    mission_type: int
    autocontinue: int = 1
    current: int = field(default=0, compare=False)

    def content(self) -> tuple[Any, ...]:
        """What must survive an upload and download unchanged: floats compared bit for bit
        as float32 (so NaN equals NaN), ``current`` left out."""
        return (
            self.seq,
            self.frame,
            self.command,
            _f32_bits(self.param1),
            _f32_bits(self.param2),
            _f32_bits(self.param3),
            _f32_bits(self.param4),
            self.x,
            self.y,
            _f32_bits(self.z),
            self.mission_type,
            int(bool(self.autocontinue)),
        )

    def send(self, mav: Any, target_system: int, target_component: int) -> None:
        """Send as MISSION_ITEM_INT through a pymavlink ``MAVLink`` object."""
        mav.mission_item_int_send(
            target_system,
            target_component,
            self.seq,
            self.frame,
            self.command,
            self.current,
            self.autocontinue,
            self.param1,
            self.param2,
            self.param3,
            self.param4,
            self.x,
            self.y,
            self.z,
            self.mission_type,
        )

    @classmethod
    def from_msg(cls, msg: Any) -> WireItem:
        """From a received MISSION_ITEM_INT message."""
        return cls(
            seq=int(msg.seq),
            frame=int(msg.frame),
            command=int(msg.command),
            param1=float(msg.param1),
            param2=float(msg.param2),
            param3=float(msg.param3),
            param4=float(msg.param4),
            x=int(msg.x),
            y=int(msg.y),
            z=float(msg.z),
            mission_type=int(msg.mission_type),
            autocontinue=int(msg.autocontinue),
            current=int(msg.current),
        )


@dataclass(frozen=True)
class WireLists:
    """The three lists a vehicle holds, as they travel."""

    mission: tuple[WireItem, ...] = ()
    fence: tuple[WireItem, ...] = ()
    rally: tuple[WireItem, ...] = ()

    def of(self, mission_type: MissionType) -> tuple[WireItem, ...]:
        return (self.mission, self.fence, self.rally)[int(mission_type)]


def _xy_int(value: float, frame: int, what: str) -> int:
    """A param5/param6 value as MISSION_ITEM_INT's int32 x/y for ``frame``."""
    if math.isnan(value):
        return 0
    if frame in GLOBAL_FRAMES:
        out = int(to_int_e7(value))
    elif frame in LOCAL_FRAMES:
        out = int(round(value * LOCAL_SCALE))
    elif float(value).is_integer():
        out = int(value)
    else:
        raise InputError(f"{what}: {value:g} is no whole number, and frame {frame} carries it "
                         "unscaled (QGroundControl would cut the fraction); a latitude or "
                         "longitude belongs in frame 3 or 0")
    if abs(out) > INT32_MAX:
        raise InputError(f"{what}: {value} does not fit MISSION_ITEM_INT (int32)")
    return out


def _xy_float(value: int, frame: int) -> float:
    if frame in GLOBAL_FRAMES:
        return float(from_int_e7(value))
    return value / (LOCAL_SCALE if frame in LOCAL_FRAMES else 1.0)


def _to_wire(items: tuple[ListItem, ...], mission_type: MissionType) -> tuple[WireItem, ...]:
    out = []
    for seq, it in enumerate(items):
        p = it.params
        out.append(WireItem(
            seq=seq, frame=it.frame, command=it.command,
            param1=f32(p[0]), param2=f32(p[1]), param3=f32(p[2]), param4=f32(p[3]),
            x=_xy_int(p[4], it.frame, f"{it.label} param5"),
            y=_xy_int(p[5], it.frame, f"{it.label} param6"),
            z=f32(p[6]), mission_type=int(mission_type),
            autocontinue=int(it.autocontinue), current=int(it.current),
        ))
    return tuple(out)


def _from_wire(items: tuple[WireItem, ...]) -> tuple[ListItem, ...]:
    return tuple(
        ListItem(w.frame, w.command, (w.param1, w.param2, w.param3, w.param4,
                                      _xy_float(w.x, w.frame), _xy_float(w.y, w.frame), w.z),
                 bool(w.autocontinue), bool(w.current))
        for w in items)


def plan_to_wire(plan: Plan, *, home_item: bool) -> WireLists:
    """All three lists of ``plan`` as they go over the wire. With ``home_item`` (ArduPilot)
    the plan's home comes first at seq 0 and a DO_JUMP's target is its item number as seq;
    without it (PX4) that number - 1 (:func:`validator.item_lists.mission_items`)."""
    lists = plan_items(plan, home_item=home_item)
    return WireLists(_to_wire(lists.mission, MissionType.MISSION),
                     _to_wire(lists.fence, MissionType.FENCE),
                     _to_wire(lists.rally, MissionType.RALLY))


def wire_to_plan(
    lists: WireLists,
    *,
    home_item: bool,
    home: tuple[float, float, float] | None = None,
    firmware_type: int = int(Autopilot.ARDUPILOTMEGA),
    note: Callable[[str], None] | None = None,
) -> Plan:
    """A plan from the three lists a vehicle holds.

    With ``home_item`` (ArduPilot) seq 0 is the vehicle's home and becomes the plan's
    ``plannedHomePosition``; otherwise (and when seq 0 is at 0°, 0°: a vehicle without a home
    yet) ``home`` (lat, lon, alt AMSL) is used, or the first positioned item at altitude 0
    when the vehicle reported none, which ``note`` is told in one line: that plan's home is
    not where the vehicle returns to.
    """
    decoded = ItemLists(_from_wire(lists.mission), _from_wire(lists.fence),
                        _from_wire(lists.rally))
    items, first = mission_from_items(decoded.mission, home_item=home_item)
    if first is not None and (first[0], first[1]) != (0.0, 0.0):
        home = first
    if home is None:
        pos = [w for w in lists.mission if w.frame in GLOBAL_FRAMES and (w.x or w.y)]
        home = ((float(from_int_e7(pos[0].x)), float(from_int_e7(pos[0].y)), 0.0) if pos
                else (0.0, 0.0, 0.0))
        if note is not None:
            why = ("its seq 0 at 0°, 0°" if first is not None else
                   "no mission, no HOME_POSITION" if home_item else "no HOME_POSITION")
            number = wire_item_number(pos[0].seq, home_item=home_item)
            stand_in = (f"the position of item {number}, the "
                        "first item with one, at altitude 0 m AMSL" if pos else
                        "0°, 0°: no item has a position")
            note(f"the vehicle reported no home ({why}); the plan's home is {stand_in}")
    circles, polygons, breach = fence_from_items(decoded.fence, home[2], "fence")
    return Plan(
        items=items,
        home_lat_deg=home[0],
        home_lon_deg=home[1],
        home_alt_m=home[2],
        firmware_type=firmware_type,
        circles=circles,
        polygons=polygons,
        rally=rally_from_items(decoded.rally, home[2], "rally"),
        breach_return=breach,
    )


def first_difference(
    sent: tuple[WireItem, ...], held: tuple[WireItem, ...], mission_type: MissionType,
    *, skip_seq0: bool = False, expected: str = "sent", home_item: bool = True,
) -> str | None:
    """One line describing the first difference between two lists, or None if identical.

    ``skip_seq0``: ArduPilot replaces the mission's seq 0 with its own home, so it is not
    compared. ``expected`` names the first list in the message. ``home_item``: the vehicle
    keeps home at mission seq 0 (ArduPilot; False for PX4): the item is named by its number
    (:func:`~validator.item_numbers.list_item_label`), the same for both.
    """
    label = mission_type.label
    if len(sent) != len(held):
        return f"{label}: sent {len(sent)} items, vehicle holds {len(held)}"
    names = ("seq", "frame", "command", "param1", "param2", "param3", "param4", "x", "y", "z",
             "mission_type", "autocontinue")
    for a, b in zip(sent, held, strict=True):
        if skip_seq0 and a.seq == 0:
            continue
        ca, cb = a.content(), b.content()
        for name, va, vb in zip(names, ca, cb, strict=True):
            if va != vb:
                shown_a, shown_b = getattr(a, name), getattr(b, name)
                where = list_item_label(a.seq, home_item=home_item,
                                        mission_type=int(mission_type))
                return (f"{where}: {name} {expected} {shown_a!r}, "
                        f"vehicle holds {shown_b!r}")
    return None


def mission_result_name(code: int) -> str:
    """MAV_MISSION_RESULT name of ``code`` (e.g. ``MAV_MISSION_INVALID_PARAM1``)."""
    entry = mavlink.enums["MAV_MISSION_RESULT"].get(int(code))
    return entry.name if entry is not None else f"MAV_MISSION_RESULT {code}"
