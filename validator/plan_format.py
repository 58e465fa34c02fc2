"""QGroundControl ``.plan`` files (JSON): the data model, reading and writing. Nothing else.

A :class:`Plan` holds what the file holds: mission items with MAVLink command numbers, the
planned home, geofence circles and polygons, rally points, and one extra key of our own
(``EXTRA_KEY``, ignored by QGroundControl) that carries the planner's schedule and power so the
validator can score a flown track. A DO_JUMP's param1 is its target's number (item i is i + 1,
ArduPilot's seq); the file names the target by ``doJumpId`` instead, written as that number.
Angles are degrees WGS84; altitudes metres (item altitudes in the item's frame; the planned home
AMSL; rally and breach-return points above home, as QGroundControl and ArduPilot read them).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from enum import IntEnum
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from validator.errors import InputError
from validator.fileio import write_atomic
from validator.input_files import parse_json, read_text
from validator.item_numbers import item_number

if TYPE_CHECKING:
    from validator.autopilot.fence import FenceRules
    from validator.autopilot.spec import ParamSpec

EXTRA_KEY = "nfzMission"  # our metadata inside a .plan; QGroundControl ignores unknown keys


class Cmd(IntEnum):
    """MAV_CMD numbers used in missions."""

    NAV_WAYPOINT = 16
    NAV_LOITER_UNLIM = 17
    NAV_LOITER_TURNS = 18
    NAV_LOITER_TIME = 19
    NAV_RETURN_TO_LAUNCH = 20
    NAV_LAND = 21
    NAV_TAKEOFF = 22
    NAV_DELAY = 93
    DO_JUMP = 177
    DO_CHANGE_SPEED = 178
    NAV_FENCE_POLYGON_VERTEX_INCLUSION = 5001
    NAV_FENCE_POLYGON_VERTEX_EXCLUSION = 5002
    NAV_FENCE_CIRCLE_INCLUSION = 5003
    NAV_FENCE_CIRCLE_EXCLUSION = 5004
    NAV_RALLY_POINT = 5100


class Frame(IntEnum):
    """MAV_FRAME numbers used in missions."""

    GLOBAL = 0  # altitude AMSL
    MISSION = 2  # no position
    GLOBAL_RELATIVE_ALT = 3  # altitude above home
    GLOBAL_TERRAIN_ALT = 10


class Autopilot(IntEnum):
    """Which autopilot: its MAV_AUTOPILOT number (a plan's ``firmwareType``, a heartbeat's
    ``autopilot``), and everything the project keys on it: :attr:`key` (the ``--autopilot``
    word), :attr:`profile_name` (the validator's flight model), :attr:`param_table` and
    :attr:`fence_rules`. A plan or vehicle of any other firmware (GENERIC) is flown and judged
    by ArduPilot's rules, as QGroundControl plans without a firmware are (:meth:`of`)."""

    GENERIC = 0
    ARDUPILOTMEGA = 3
    PX4 = 12

    @classmethod
    def of(cls, source: object) -> Autopilot:
        """The autopilot whose rules fly a plan (its ``firmware_type``), a flight, or a
        MAV_AUTOPILOT number: PX4 for PX4, ArduPilot for anything else."""
        number = getattr(source, "firmware_type", source)
        return cls.PX4 if number == cls.PX4 else cls.ARDUPILOTMEGA

    @classmethod
    def known(cls, number: int) -> Autopilot | None:
        """ArduPilot or PX4 for their MAV_AUTOPILOT number (a heartbeat's), else None."""
        return cls(number) if number in (cls.ARDUPILOTMEGA, cls.PX4) else None

    @classmethod
    def named(cls, key: str) -> Autopilot:
        """The autopilot of an ``--autopilot`` word ("ardupilot", "px4")."""
        for a in (cls.ARDUPILOTMEGA, cls.PX4):
            if a.key == key:
                return a
        raise InputError(f"autopilot: unknown {key!r} (choose from ardupilot, px4)")

    @property
    def key(self) -> str:
        """The ``--autopilot`` word: "px4", else "ardupilot"."""
        return "px4" if self is Autopilot.PX4 else "ardupilot"

    @property
    def mavlink_id(self) -> int:
        """MAV_AUTOPILOT number."""
        return int(self)

    @property
    def label(self) -> str:
        """The name a person reads: "PX4", "ArduPilot" (or "MAV_AUTOPILOT 0")."""
        return {3: "ArduPilot", 12: "PX4"}.get(int(self), f"MAV_AUTOPILOT {int(self)}")

    @property
    def profile_name(self) -> Literal["arducopter", "px4"]:
        """The validator's flight model of this autopilot (:mod:`validator.motion`)."""
        return "px4" if self is Autopilot.PX4 else "arducopter"

    @property
    def param_table(self) -> dict[str, ParamSpec]:
        """The parameters it documents (:mod:`validator.autopilot.tables`)."""
        from validator.autopilot.tables import param_table

        return param_table(self.key)

    @property
    def fence_rules(self) -> FenceRules:
        """Its geofence parameters and safe breach actions (:mod:`validator.autopilot.fence`)."""
        from validator.autopilot.fence import FENCE_RULES

        return FENCE_RULES[self.key]


@dataclass
class MissionItem:
    """One mission item: ``params`` are MAVLink's param1..param4, x = lat, y = lon, z = alt."""

    command: int
    params: list[float] = field(default_factory=lambda: [0.0] * 7)
    frame: int = int(Frame.GLOBAL_RELATIVE_ALT)
    autocontinue: bool = True

    @property
    def lat_deg(self) -> float:
        return self.params[4]

    @property
    def lon_deg(self) -> float:
        return self.params[5]

    @property
    def alt_m(self) -> float:
        return self.params[6]


@dataclass
class FenceCircle:
    lat_deg: float
    lon_deg: float
    radius_m: float
    inclusion: bool = False


@dataclass
class FencePolygon:
    vertices_deg: list[tuple[float, float]]  # (lat, lon), not closed
    inclusion: bool = True


@dataclass
class Plan:
    """Everything a QGroundControl plan file holds."""

    items: list[MissionItem]
    home_lat_deg: float
    home_lon_deg: float
    home_alt_m: float  # AMSL
    firmware_type: int = int(Autopilot.ARDUPILOTMEGA)
    vehicle_type: int = 2  # MAV_TYPE_QUADROTOR
    cruise_speed_mps: float = 15.0
    hover_speed_mps: float = 5.0
    circles: list[FenceCircle] = field(default_factory=list)
    polygons: list[FencePolygon] = field(default_factory=list)
    # lat, lon, alt above home
    rally: list[tuple[float, float, float]] = field(default_factory=list)
    breach_return: tuple[float, float, float] | None = None
    extra: dict[str, object] | None = None  # our EXTRA_KEY metadata, if any


def _num(v: object) -> float:
    """A JSON number, or NaN for null (as QGroundControl reads it); nothing else."""
    if v is None:
        return math.nan
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise TypeError("not a number")
    out = float(v)
    if not math.isfinite(out):  # a huge integer
        raise ValueError("not finite")
    return out


def _finite(v: object) -> float:
    """A finite JSON number (no null)."""
    if v is None:
        raise TypeError("null")
    return _num(v)


def _json_num(v: float) -> float | None:
    return None if isinstance(v, float) and math.isnan(v) else v


def plan_to_dict(plan: Plan) -> dict[str, object]:
    """The QGroundControl JSON structure of ``plan`` (full double precision)."""
    items = []
    for i, it in enumerate(plan.items):
        entry: dict[str, object] = {
            "autoContinue": it.autocontinue,
            "command": int(it.command),
            "doJumpId": item_number(i),
            "frame": int(it.frame),
            "params": [_json_num(float(p)) for p in it.params],
            "type": "SimpleItem",
        }
        if it.frame in (
            Frame.GLOBAL_RELATIVE_ALT,
            Frame.GLOBAL,
            Frame.GLOBAL_TERRAIN_ALT,
        ) and it.command not in (Cmd.DO_JUMP, Cmd.DO_CHANGE_SPEED):
            mode = {Frame.GLOBAL_RELATIVE_ALT: 1, Frame.GLOBAL: 2, Frame.GLOBAL_TERRAIN_ALT: 3}
            entry["AMSLAltAboveTerrain"] = None
            entry["Altitude"] = it.params[6]
            entry["AltitudeMode"] = mode[Frame(it.frame)]
        items.append(entry)
    fence: dict[str, object] = {
        "circles": [
            {
                "circle": {"center": [c.lat_deg, c.lon_deg], "radius": c.radius_m},
                "inclusion": c.inclusion,
                "version": 1,
            }
            for c in plan.circles
        ],
        "polygons": [
            {"inclusion": p.inclusion, "polygon": [list(v) for v in p.vertices_deg], "version": 1}
            for p in plan.polygons
        ],
        "version": 2,
    }
    if plan.breach_return is not None:
        fence["breachReturn"] = list(plan.breach_return)
    out: dict[str, object] = {
        "fileType": "Plan",
        "geoFence": fence,
        "groundStation": "QGroundControl",
        "mission": {
            "cruiseSpeed": plan.cruise_speed_mps,
            "firmwareType": plan.firmware_type,
            "globalPlanAltitudeMode": 1,
            "hoverSpeed": plan.hover_speed_mps,
            "items": items,
            "plannedHomePosition": [plan.home_lat_deg, plan.home_lon_deg, plan.home_alt_m],
            "vehicleType": plan.vehicle_type,
            "version": 2,
        },
        "rallyPoints": {"points": [list(p) for p in plan.rally], "version": 2},
        "version": 1,
    }
    if plan.extra is not None:
        out[EXTRA_KEY] = plan.extra
    return out


def dumps_plan(plan: Plan) -> str:
    """The plan as QGroundControl JSON text; ``repr`` floats keep full double precision."""
    return json.dumps(plan_to_dict(plan), indent=1, allow_nan=False) + "\n"


def write_plan(plan: Plan, path: str | Path) -> None:
    """Write ``plan`` to ``path`` atomically."""
    write_atomic(path, dumps_plan(plan))


# Versions of each part of a .plan this reader knows (QGroundControl's current ones). object
# other value is refused rather than warned about: QGroundControl itself refuses a plan of a
# newer version, and the older mission (1) and geoFence (1) layouts hold their items in other
# places, so reading them as the current layout would silently lose items. A missing version
# is read as the current one (hand-written plans often omit it).
PLAN_VERSION = 1
MISSION_VERSION = 2
GEOFENCE_VERSION = 2
RALLY_VERSION = 2
FENCE_SHAPE_VERSION = 1  # each geoFence circle and polygon
MAX_ITEMS = 65535  # per list: MAVLink's MISSION_COUNT is a uint16
# Commands whose params 5-7 are a position the vehicle flies to: null (NaN) there is no place.
_POSITION_COMMANDS = frozenset({16, 17, 18, 19, 21, 22, 31, 82, 84, 85})


def _need(d: object, key: str, where: str) -> object:
    if not isinstance(d, dict):
        raise InputError(f"{where}: expected a JSON object")
    if key not in d:
        raise InputError(f"{where}.{key}: missing field")
    return d[key]


def _object(v: object, where: str) -> dict[str, object]:
    if not isinstance(v, dict):
        raise InputError(f"{where}: expected a JSON object")
    return v


def _list(v: object, where: str, max_len: int = MAX_ITEMS) -> list[object]:
    if not isinstance(v, list):
        raise InputError(f"{where}: expected a list")
    if len(v) > max_len:
        raise InputError(f"{where}: {len(v)} entries, at most {max_len} allowed")
    return v


def _int(v: object, where: str, lo: int, hi: int) -> int:
    if isinstance(v, float) and v.is_integer():
        v = int(v)
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise InputError(f"{where}: expected an integer in {lo}..{hi}, got {v!r}")
    return v


def _number(v: object, where: str) -> float:
    try:
        return _finite(v)
    except (TypeError, ValueError):
        raise InputError(f"{where}: expected a finite number, got {_short(v)}") from None


def _bool(v: object, where: str) -> bool:
    if not isinstance(v, bool):
        raise InputError(f"{where}: expected true or false, got {_short(v)}")
    return v


def _short(v: object) -> str:
    text = json.dumps(v) if isinstance(v, (int, float, str, bool, type(None))) else type(v).__name__
    return text if len(text) <= 40 else text[:37] + "..."


def _latlon(v: object, where: str, size: int = 2) -> list[float]:
    """[lat, lon] (``size`` 2) or [lat, lon, alt] (3), finite, degrees in range."""
    if not isinstance(v, list) or len(v) != size:
        raise InputError(f"{where}: expected [lat, lon{', alt' if size == 3 else ''}]")
    out = [_number(x, f"{where}[{i}]") for i, x in enumerate(v)]
    _check_latlon(out[0], out[1], where)
    return out


def _check_latlon(lat: float, lon: float, where: str) -> None:
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise InputError(f"{where}: latitude/longitude ({lat}, {lon}) out of range")


def _version(part: dict[str, object], expected: int, where: str) -> None:
    if "version" in part and part["version"] != expected:
        raise InputError(f"{where}.version: expected {expected}, got {_short(part['version'])} "
                         "(not a QGroundControl plan layout this tool reads; re-save it with "
                         "a current QGroundControl)")


def _item(raw_entry: object, where: str) -> MissionItem:
    entry = _object(raw_entry, where)
    kind = _need(entry, "type", where)
    if kind == "ComplexItem":
        raise InputError(
            f"{where}: ComplexItem ({_short(entry.get('complexItemType', '?'))}) is not "
            "supported; convert the survey or structure scan to waypoints in QGroundControl first"
        )
    if kind != "SimpleItem":
        raise InputError(f"{where}.type: unknown item type {_short(kind)}")
    raw = _need(entry, "params", where)
    if not isinstance(raw, list) or len(raw) != 7:
        raise InputError(f"{where}.params: expected 7 numbers or nulls")
    try:
        params = [_num(p) for p in raw]
    except (TypeError, ValueError):
        raise InputError(f"{where}.params: expected 7 finite numbers or nulls") from None
    command = _int(_need(entry, "command", where), f"{where}.command", 0, 65535)
    frame = _int(entry.get("frame", int(Frame.GLOBAL_RELATIVE_ALT)), f"{where}.frame", 0, 255)
    if command in _POSITION_COMMANDS and frame != Frame.MISSION:
        for i, name in ((4, "latitude"), (5, "longitude"), (6, "altitude")):
            if math.isnan(params[i]):
                raise InputError(f"{where}.params[{i}]: the {name} must be a number, not null")
        _check_latlon(params[4], params[5], f"{where}.params")
    auto = _bool(entry.get("autoContinue", True), f"{where}.autoContinue")
    return MissionItem(command, params, frame, auto)


def _number_jump_targets(items: list[MissionItem], ids: list[object], where: str) -> None:
    """Each DO_JUMP's param1 from its target's ``doJumpId`` to the target's number (from 1), as
    QGroundControl loads a plan (MissionController: the item carrying that id; none is a load
    error): ids written by hand or by another tool need not be the numbers. An item without
    ``doJumpId`` has its number, the id QGroundControl would write for it."""
    first: dict[int, int] = {}  # doJumpId -> the first item carrying it
    second: dict[int, int] = {}  # doJumpId -> a later item carrying it too
    for i, raw in enumerate(ids):
        jump_id = _int(raw, f"{where}[{i}].doJumpId", -(2**31), 2**31 - 1)
        (second if jump_id in first else first).setdefault(jump_id, i)
    for i, it in enumerate(items):
        if it.command != Cmd.DO_JUMP:
            continue
        p1 = it.params[0]
        named = int(p1) if math.isfinite(p1) and p1.is_integer() else None
        if named is None or named not in first:
            raise InputError(f"{where}[{i}] (item {item_number(i)}, DO_JUMP): no item has "
                             f"doJumpId {p1:g}, the target its param1 names")
        if named in second:  # QGroundControl takes the first; another tool may not
            raise InputError(f"{where}[{i}] (item {item_number(i)}, DO_JUMP): its target, "
                             f"doJumpId {named}, is ambiguous: items[{first[named]}] and "
                             f"items[{second[named]}] both have it")
        it.params[0] = float(item_number(first[named]))


def plan_from_dict(raw: object, source: str = "plan") -> Plan:
    """Parse a QGroundControl plan structure, raising :class:`InputError` naming the field.

    Versions other than the current ones are refused (see ``PLAN_VERSION``); every number
    must be finite, except the params QGroundControl writes as null (NaN: "unchanged").
    """
    data = _object(raw, source)
    if _need(data, "fileType", source) != "Plan":
        raise InputError(f"{source}.fileType: expected 'Plan'")
    mission = _object(_need(data, "mission", source), f"{source}.mission")
    _version(data, PLAN_VERSION, source)
    _version(mission, MISSION_VERSION, f"{source}.mission")
    home = _latlon(_need(mission, "plannedHomePosition", f"{source}.mission"),
                   f"{source}.mission.plannedHomePosition", 3)
    raw_items = _list(_need(mission, "items", f"{source}.mission"), f"{source}.mission.items")
    items = [_item(e, f"{source}.mission.items[{i}]") for i, e in enumerate(raw_items)]
    ids = [_object(e, "").get("doJumpId", i + 1) for i, e in enumerate(raw_items)]
    _number_jump_targets(items, ids, f"{source}.mission.items")

    fence = _object(data.get("geoFence") or {}, f"{source}.geoFence")
    if fence:
        _version(fence, GEOFENCE_VERSION, f"{source}.geoFence")
    circles: list[FenceCircle] = []
    for i, c in enumerate(_list(fence.get("circles", []), f"{source}.geoFence.circles")):
        where = f"{source}.geoFence.circles[{i}]"
        c = _object(c, where)
        _version(c, FENCE_SHAPE_VERSION, where)
        circle = _need(c, "circle", where)
        lat, lon = _latlon(_need(circle, "center", f"{where}.circle"), f"{where}.circle.center")
        radius = _number(_need(circle, "radius", f"{where}.circle"), f"{where}.circle.radius")
        if not radius > 0:
            raise InputError(f"{where}.circle.radius: must be > 0")
        inclusion = _bool(_need(c, "inclusion", where), f"{where}.inclusion")
        circles.append(FenceCircle(lat, lon, radius, inclusion))
    polygons: list[FencePolygon] = []
    for i, p in enumerate(_list(fence.get("polygons", []), f"{source}.geoFence.polygons")):
        where = f"{source}.geoFence.polygons[{i}]"
        p = _object(p, where)
        _version(p, FENCE_SHAPE_VERSION, where)
        raw_verts = _list(_need(p, "polygon", where), f"{where}.polygon")
        verts = [_latlon(v, f"{where}.polygon[{j}]") for j, v in enumerate(raw_verts)]
        if len(verts) < 3:
            raise InputError(f"{where}.polygon: needs at least 3 vertices")
        inclusion = _bool(p.get("inclusion", True), f"{where}.inclusion")
        polygons.append(FencePolygon([(a, b) for a, b in verts], inclusion))
    breach: tuple[float, float, float] | None = None
    if fence.get("breachReturn") is not None:
        b = _latlon(fence["breachReturn"], f"{source}.geoFence.breachReturn", 3)
        breach = (b[0], b[1], b[2])
    rally_part = _object(data.get("rallyPoints") or {}, f"{source}.rallyPoints")
    if rally_part:
        _version(rally_part, RALLY_VERSION, f"{source}.rallyPoints")
    rally: list[tuple[float, float, float]] = []
    for i, r in enumerate(_list(rally_part.get("points", []), f"{source}.rallyPoints.points")):
        lat, lon, alt = _latlon(r, f"{source}.rallyPoints.points[{i}]", 3)
        rally.append((lat, lon, alt))
    where = f"{source}.mission"
    return Plan(
        items=items,
        home_lat_deg=home[0],
        home_lon_deg=home[1],
        home_alt_m=home[2],
        firmware_type=_int(mission.get("firmwareType", int(Autopilot.ARDUPILOTMEGA)),
                           f"{where}.firmwareType", 0, 255),
        vehicle_type=_int(mission.get("vehicleType", 2), f"{where}.vehicleType", 0, 255),
        cruise_speed_mps=_number(mission.get("cruiseSpeed", 15.0), f"{where}.cruiseSpeed"),
        hover_speed_mps=_number(mission.get("hoverSpeed", 5.0), f"{where}.hoverSpeed"),
        circles=circles,
        polygons=polygons,
        rally=rally,
        breach_return=breach,
        extra=_object(data[EXTRA_KEY], f"{source}.{EXTRA_KEY}") if EXTRA_KEY in data else None,
    )


def loads_plan(text: str, source: str = "plan") -> Plan:
    """Parse ``.plan`` text (limits and finite numbers: :mod:`validator.input_files`)."""
    return plan_from_dict(parse_json(text, source), source)


def read_plan(path: str | Path) -> Plan:
    """Read a QGroundControl ``.plan`` file."""
    return loads_plan(read_text(path, "plan"), str(path))
