"""The MAVLink wire format of a plan: :class:`Plan` <-> MISSION_ITEM_INT lists. Nothing else.

This is the one module that knows how a QGroundControl plan travels over MAVLink 2:

- mission (``mission_type`` 0): the plan's items in order. ArduPilot keeps its home position
  at seq 0, so for an ArduPilot vehicle a home item (NAV_WAYPOINT, frame GLOBAL, altitude
  AMSL) is put first and the plan's items follow from seq 1, as QGroundControl does. DO_JUMP's
  param1 is a ``doJumpId`` (1-based plan index) in the file and a seq number on the wire.
- fence (1): a circle is one NAV_FENCE_CIRCLE_INCLUSION/EXCLUSION item with param1 = radius
  (m); a polygon is one NAV_FENCE_POLYGON_VERTEX_* item per vertex with param1 = vertex count;
  the breach return point is NAV_FENCE_RETURN_POINT. Frame GLOBAL.
- rally (2): one NAV_RALLY_POINT per point, frame GLOBAL_RELATIVE_ALT: a .plan's rally and
  breach-return altitudes are above home, as QGroundControl writes them and ArduPilot reads
  them by default.

Latitude and longitude travel as int32 degrees x 1e7 (rounded to nearest); params and z as
float32. Importing this module selects pymavlink's MAVLink 2 ArduPilot dialect (MAVLink 1
has no ``mission_type``, so fences and rally points would be lost).
"""

from __future__ import annotations

import dataclasses
import math
import os
import struct
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any

os.environ["MAVLINK20"] = "1"  # must precede pymavlink's first import to get MAVLink 2

from pymavlink import mavutil  # noqa: E402

if mavutil.mavlink.WIRE_PROTOCOL_VERSION != "2.0":  # someone imported pymavlink before us
    mavutil.set_dialect("ardupilotmega")

from validator.errors import InputError  # noqa: E402
from validator.geodesy import E7  # noqa: E402
from validator.plan_format import (  # noqa: E402
    Autopilot,
    Cmd,
    FenceCircle,
    FencePolygon,
    Frame,
    MissionItem,
    Plan,
)

mavlink: Any = mavutil.mavlink  # the MAVLink 2 dialect module (message classes and enums)

NAV_FENCE_RETURN_POINT = 5000
INT32_MAX = 2**31 - 1

# Frames whose x/y are latitude/longitude in degrees x 1e7 in MISSION_ITEM_INT.
GLOBAL_FRAMES = frozenset({0, 3, 5, 6, 10, 11})
# Frames whose x/y are metres x 1e4 in MISSION_ITEM_INT.
LOCAL_FRAMES = frozenset({1, 4, 7, 8, 9, 12, 13, 14, 15, 20, 21})

_FENCE_CIRCLES = (int(Cmd.NAV_FENCE_CIRCLE_INCLUSION), int(Cmd.NAV_FENCE_CIRCLE_EXCLUSION))
_FENCE_VERTICES = (
    int(Cmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION),
    int(Cmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION),
)


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
    scale = E7 if frame in GLOBAL_FRAMES else 1e4 if frame in LOCAL_FRAMES else 1.0
    out = int(round(value * scale))
    if abs(out) > INT32_MAX:
        raise InputError(f"{what}: {value} does not fit MISSION_ITEM_INT (int32)")
    return out


def _xy_float(value: int, frame: int) -> float:
    scale = E7 if frame in GLOBAL_FRAMES else 1e4 if frame in LOCAL_FRAMES else 1.0
    return value / scale


def _check_latlon(lat: float, lon: float, what: str) -> None:
    if not (-90.0 <= lat <= 90.0):
        raise InputError(f"{what}: latitude {lat} outside [-90, 90]")
    if not (-180.0 <= lon <= 180.0):
        raise InputError(f"{what}: longitude {lon} outside [-180, 180]")


def _global(
    seq: int, command: int, lat: float, lon: float, alt: float, mission_type: MissionType,
    what: str, param1: float = 0.0, frame: int = int(Frame.GLOBAL),
) -> WireItem:
    _check_latlon(lat, lon, what)
    return WireItem(
        seq, frame, command, f32(param1), 0.0, 0.0, 0.0,
        _xy_int(lat, frame, what), _xy_int(lon, frame, what), f32(alt), int(mission_type),
    )


def mission_to_wire(plan: Plan, *, home_item: bool) -> tuple[WireItem, ...]:
    """The plan's mission items as MISSION_ITEM_INT (``mission_type`` 0).

    With ``home_item`` (ArduPilot) the plan's home comes first at seq 0 and DO_JUMP targets
    keep their ``doJumpId`` as seq; without it (PX4) seq = doJumpId - 1.
    """
    out: list[WireItem] = []
    offset = 1 if home_item else 0
    if home_item:
        out.append(_global(0, int(Cmd.NAV_WAYPOINT), plan.home_lat_deg, plan.home_lon_deg,
                           plan.home_alt_m, MissionType.MISSION, "mission.plannedHomePosition"))
    for i, it in enumerate(plan.items):
        what = f"mission.items[{i}]"
        p = [float(v) for v in it.params]
        if it.frame in GLOBAL_FRAMES and not (math.isnan(p[4]) and math.isnan(p[5])):
            _check_latlon(p[4], p[5], what)
        if it.command == Cmd.DO_JUMP:
            target = int(round(p[0]))
            if not 1 <= target <= len(plan.items):
                raise InputError(f"{what}: DO_JUMP target {p[0]:g} is not an item of the plan")
            p[0] = float(target - 1 + offset)
        out.append(
            WireItem(
                seq=i + offset,
                frame=int(it.frame),
                command=int(it.command),
                param1=f32(p[0]),
                param2=f32(p[1]),
                param3=f32(p[2]),
                param4=f32(p[3]),
                x=_xy_int(p[4], it.frame, f"{what} param5"),
                y=_xy_int(p[5], it.frame, f"{what} param6"),
                z=f32(p[6]),
                mission_type=int(MissionType.MISSION),
                autocontinue=int(bool(it.autocontinue)),
            )
        )
    if out:  # QGroundControl and MAVSDK flag the first item as current; ArduPilot ignores it
        out[0] = dataclasses.replace(out[0], current=1)
    return tuple(out)


def fence_to_wire(plan: Plan) -> tuple[WireItem, ...]:
    """The plan's geofence as fence items (``mission_type`` 1)."""
    out: list[WireItem] = []
    fence = MissionType.FENCE
    for i, poly in enumerate(plan.polygons):
        cmd = _FENCE_VERTICES[0] if poly.inclusion else _FENCE_VERTICES[1]
        n = len(poly.vertices_deg)
        for lat, lon in poly.vertices_deg:
            out.append(_global(len(out), cmd, lat, lon, 0.0, fence,
                               f"geoFence.polygons[{i}]", param1=n))
    for i, c in enumerate(plan.circles):
        if not c.radius_m > 0:
            raise InputError(f"geoFence.circles[{i}].radius: must be > 0")
        cmd = _FENCE_CIRCLES[0] if c.inclusion else _FENCE_CIRCLES[1]
        out.append(_global(len(out), cmd, c.lat_deg, c.lon_deg, 0.0, fence,
                           f"geoFence.circles[{i}]", param1=c.radius_m))
    if plan.breach_return is not None:
        lat, lon, alt = plan.breach_return
        out.append(_global(len(out), NAV_FENCE_RETURN_POINT, lat, lon, alt, fence,
                           "geoFence.breachReturn", frame=int(Frame.GLOBAL_RELATIVE_ALT)))
    return tuple(out)


def rally_to_wire(plan: Plan) -> tuple[WireItem, ...]:
    """The plan's rally points as NAV_RALLY_POINT items (``mission_type`` 2), altitude above
    home."""
    return tuple(
        _global(i, int(Cmd.NAV_RALLY_POINT), lat, lon, alt, MissionType.RALLY,
                f"rallyPoints.points[{i}]", frame=int(Frame.GLOBAL_RELATIVE_ALT))
        for i, (lat, lon, alt) in enumerate(plan.rally)
    )


def plan_to_wire(plan: Plan, *, home_item: bool) -> WireLists:
    """All three lists of ``plan`` as they go over the wire (see :func:`mission_to_wire`)."""
    return WireLists(mission_to_wire(plan, home_item=home_item), fence_to_wire(plan),
                     rally_to_wire(plan))


def _latlon(item: WireItem) -> tuple[float, float]:
    return item.x / E7, item.y / E7


def _above_home(item: WireItem, home: tuple[float, float, float]) -> float:
    """A rally or return point's altitude above home, whatever frame the vehicle used."""
    return item.z - home[2] if item.frame in (0, 5) else item.z


def wire_to_plan(
    lists: WireLists,
    *,
    home_item: bool,
    home: tuple[float, float, float] | None = None,
    firmware_type: int = int(Autopilot.ARDUPILOTMEGA),
) -> Plan:
    """A plan from the three lists a vehicle holds.

    With ``home_item`` (ArduPilot) seq 0 is the vehicle's home and becomes the plan's
    ``plannedHomePosition``; otherwise ``home`` (lat, lon, alt AMSL) is used, or the first
    positioned item at altitude 0 when the vehicle reported none.
    """
    items_in = list(lists.mission)
    offset = 0
    if home_item and items_in:
        h = items_in.pop(0)
        home = (h.x / E7, h.y / E7, h.z)
        offset = 1
    items: list[MissionItem] = []
    for w in items_in:
        p1 = w.param1
        if w.command == Cmd.DO_JUMP:
            p1 = float(int(round(p1)) - offset + 1)
        params = [p1, w.param2, w.param3, w.param4,
                  _xy_float(w.x, w.frame), _xy_float(w.y, w.frame), w.z]
        items.append(MissionItem(w.command, params, w.frame, bool(w.autocontinue)))
    if home is None:
        pos = [w for w in items_in if w.frame in GLOBAL_FRAMES and (w.x or w.y)]
        home = (pos[0].x / E7, pos[0].y / E7, 0.0) if pos else (0.0, 0.0, 0.0)

    circles: list[FenceCircle] = []
    polygons: list[FencePolygon] = []
    breach: tuple[float, float, float] | None = None
    fence = list(lists.fence)
    i = 0
    while i < len(fence):
        w = fence[i]
        if w.command in _FENCE_CIRCLES:
            lat, lon = _latlon(w)
            circles.append(FenceCircle(lat, lon, w.param1,
                                       inclusion=w.command == Cmd.NAV_FENCE_CIRCLE_INCLUSION))
            i += 1
        elif w.command in _FENCE_VERTICES:
            n = int(round(w.param1))
            group = fence[i : i + n]
            if n < 3 or len(group) < n or any(g.command != w.command for g in group):
                raise InputError(f"fence item {i}: polygon of {w.param1:g} vertices is broken")
            polygons.append(FencePolygon([_latlon(g) for g in group],
                                         inclusion=w.command == _FENCE_VERTICES[0]))
            i += n
        elif w.command == NAV_FENCE_RETURN_POINT:
            lat, lon = _latlon(w)
            breach = (lat, lon, _above_home(w, home))
            i += 1
        else:
            raise InputError(f"fence item {i}: unknown fence command {w.command}")
    rally = []
    for j, w in enumerate(lists.rally):
        if w.command != Cmd.NAV_RALLY_POINT:
            raise InputError(f"rally item {j}: expected NAV_RALLY_POINT, got command {w.command}")
        lat, lon = _latlon(w)
        rally.append((lat, lon, _above_home(w, home)))
    return Plan(
        items=items,
        home_lat_deg=home[0],
        home_lon_deg=home[1],
        home_alt_m=home[2],
        firmware_type=firmware_type,
        circles=circles,
        polygons=polygons,
        rally=rally,
        breach_return=breach,
    )


def first_difference(
    sent: tuple[WireItem, ...], held: tuple[WireItem, ...], mission_type: MissionType,
    *, skip_seq0: bool = False, expected: str = "sent",
) -> str | None:
    """One line describing the first difference between two lists, or None if identical.

    ``skip_seq0``: ArduPilot replaces the mission's seq 0 with its own home, so it is not
    compared. ``expected`` names the first list in the message.
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
                return (f"{label} item {a.seq}: {name} {expected} {shown_a!r}, "
                        f"vehicle holds {shown_b!r}")
    return None


def mission_result_name(code: int) -> str:
    """MAV_MISSION_RESULT name of ``code`` (e.g. ``MAV_MISSION_INVALID_PARAM1``)."""
    entry = mavlink.enums["MAV_MISSION_RESULT"].get(int(code))
    return entry.name if entry is not None else f"MAV_MISSION_RESULT {code}"
