"""QGroundControl ``.plan`` files (JSON): the data model, reading and writing. Nothing else.

A :class:`Plan` holds what the file holds: mission items with MAVLink command numbers, the
planned home, geofence circles and polygons, rally points, and one extra key of our own
(``EXTRA_KEY``, ignored by QGroundControl) that carries the planner's schedule and power so the
validator can score a flown track. Angles are degrees WGS84; altitudes metres (item altitudes
in the item's frame; the planned home AMSL; rally and breach-return points above home, as
QGroundControl and ArduPilot read them).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from enum import IntEnum
from pathlib import Path
from typing import Any

from validator.errors import InputError
from validator.fileio import write_atomic

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
    """MAV_AUTOPILOT numbers used as ``firmwareType``."""

    GENERIC = 0
    ARDUPILOTMEGA = 3
    PX4 = 12


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
    extra: dict[str, Any] | None = None  # our EXTRA_KEY metadata, if any


def _num(v: Any) -> float:
    """A JSON number, or NaN for null (as QGroundControl reads it)."""
    return math.nan if v is None else float(v)


def _json_num(v: float) -> float | None:
    return None if isinstance(v, float) and math.isnan(v) else v


def plan_to_dict(plan: Plan) -> dict[str, Any]:
    """The QGroundControl JSON structure of ``plan`` (full double precision)."""
    items = []
    for i, it in enumerate(plan.items, start=1):
        entry: dict[str, Any] = {
            "autoContinue": it.autocontinue,
            "command": int(it.command),
            "doJumpId": i,
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
    fence: dict[str, Any] = {
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
    out: dict[str, Any] = {
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


def _need(d: Any, key: str, where: str) -> Any:
    if not isinstance(d, dict):
        raise InputError(f"{where}: expected a JSON object")
    if key not in d:
        raise InputError(f"{where}.{key}: missing field")
    return d[key]


def plan_from_dict(data: Any, source: str = "plan") -> Plan:
    """Parse a QGroundControl plan structure, raising :class:`InputError` naming the field."""
    if _need(data, "fileType", source) != "Plan":
        raise InputError(f"{source}.fileType: expected 'Plan'")
    mission = _need(data, "mission", source)
    try:
        home = [float(v) for v in _need(mission, "plannedHomePosition", f"{source}.mission")]
        if len(home) != 3:
            raise ValueError
    except (TypeError, ValueError):
        raise InputError(
            f"{source}.mission.plannedHomePosition: expected [lat, lon, alt]"
        ) from None
    items: list[MissionItem] = []
    raw_items = _need(mission, "items", f"{source}.mission")
    if not isinstance(raw_items, list):
        raise InputError(f"{source}.mission.items: expected a list")
    for i, entry in enumerate(raw_items):
        where = f"{source}.mission.items[{i}]"
        kind = _need(entry, "type", where)
        if kind == "ComplexItem":
            raise InputError(
                f"{where}: ComplexItem ({entry.get('complexItemType', '?')}) is not supported; "
                "convert the survey or structure scan to waypoints in QGroundControl first"
            )
        if kind != "SimpleItem":
            raise InputError(f"{where}.type: unknown item type {kind!r}")
        try:
            params = [_num(p) for p in _need(entry, "params", where)]
            if len(params) != 7:
                raise ValueError
        except (TypeError, ValueError):
            raise InputError(f"{where}.params: expected 7 numbers or nulls") from None
        try:
            command = int(_need(entry, "command", where))
            frame = int(entry.get("frame", Frame.GLOBAL_RELATIVE_ALT))
        except (TypeError, ValueError):
            raise InputError(f"{where}: command and frame must be integers") from None
        items.append(MissionItem(command, params, frame, bool(entry.get("autoContinue", True))))

    fence = data.get("geoFence") or {}
    circles: list[FenceCircle] = []
    polygons: list[FencePolygon] = []
    breach: tuple[float, float, float] | None = None
    try:
        for i, c in enumerate(fence.get("circles", [])):
            where = f"{source}.geoFence.circles[{i}]"
            circle = _need(c, "circle", where)
            lat, lon = (float(v) for v in _need(circle, "center", f"{where}.circle"))
            radius = float(_need(circle, "radius", f"{where}.circle"))
            if not radius > 0:
                raise InputError(f"{where}.circle.radius: must be > 0")
            circles.append(FenceCircle(lat, lon, radius, bool(_need(c, "inclusion", where))))
        for i, p in enumerate(fence.get("polygons", [])):
            where = f"{source}.geoFence.polygons[{i}]"
            verts = [(float(a), float(b)) for a, b in _need(p, "polygon", where)]
            if len(verts) < 3:
                raise InputError(f"{where}.polygon: needs at least 3 vertices")
            polygons.append(FencePolygon(verts, bool(p.get("inclusion", True))))
        if fence.get("breachReturn") is not None:
            b = [float(v) for v in fence["breachReturn"]]
            breach = (b[0], b[1], b[2])
        rally_raw = (data.get("rallyPoints") or {}).get("points", [])
        rally = [(float(a), float(b), float(c)) for a, b, c in rally_raw]
        plan = Plan(
            items=items,
            home_lat_deg=home[0],
            home_lon_deg=home[1],
            home_alt_m=home[2],
            firmware_type=int(mission.get("firmwareType", Autopilot.ARDUPILOTMEGA)),
            vehicle_type=int(mission.get("vehicleType", 2)),
            cruise_speed_mps=float(mission.get("cruiseSpeed", 15.0)),
            hover_speed_mps=float(mission.get("hoverSpeed", 5.0)),
            circles=circles,
            polygons=polygons,
            rally=rally,
            breach_return=breach,
            extra=data.get(EXTRA_KEY),
        )
    except InputError:
        raise
    except (TypeError, ValueError, AttributeError) as err:
        raise InputError(f"{source}: malformed geoFence or rallyPoints ({err})") from None
    fence_version = fence.get("version") if fence else 2
    if fence and fence_version != 2:
        raise InputError(f"{source}.geoFence.version: expected 2, got {fence_version!r}")
    return plan


def loads_plan(text: str, source: str = "plan") -> Plan:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise InputError(f"{source}: not valid JSON (line {err.lineno}: {err.msg})") from None
    return plan_from_dict(data, source)


def read_plan(path: str | Path) -> Plan:
    """Read a QGroundControl ``.plan`` file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"{path}: cannot read plan file ({err})") from None
    return loads_plan(text, str(path))
