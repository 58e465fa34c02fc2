"""A plan as the three MAVLink item lists a vehicle holds (mission, fence, rally), and back:
the one encoding the wire format (:mod:`validator.mavlink.wire`) and QGC WPL 110 files
(:mod:`validator.waypoints_format`) share. Degrees and float parameters; how each format
stores the numbers (int32 1e-7°, float32, text) is its own business.

- mission: with ``home_item`` (ArduPilot, and every ``.waypoints`` file) the plan's home comes
  first (NAV_WAYPOINT, frame GLOBAL, altitude AMSL) and the plan's items follow, so item i is
  number i + 1, and a DO_JUMP's param1 is its target's number as in the :class:`Plan` (where
  :mod:`validator.plan_format` put a ``.plan``'s ``doJumpId``), as QGroundControl uploads it;
  without it (PX4) item i is number i and a DO_JUMP's param1 is one less. The first item is
  the current one (QGroundControl and MAVSDK flag it; ArduPilot ignores it).
- fence: each polygon as one NAV_FENCE_POLYGON_VERTEX_* item per vertex (param1 = vertex
  count), then each circle as one NAV_FENCE_CIRCLE_* item (param1 = radius, m), frame GLOBAL;
  then the breach return point, NAV_FENCE_RETURN_POINT in frame GLOBAL_RELATIVE_ALT.
- rally: one NAV_RALLY_POINT per point, frame GLOBAL_RELATIVE_ALT: a plan's rally and
  breach-return altitudes are above home, as QGroundControl writes them and ArduPilot reads them
  by default.

Every item is sent with autocontinue 1 (what ArduPilot and PX4 store of it for fence and rally
items is :mod:`validator.mavlink.storage`'s business). Read back, a rally or return point in an
AMSL frame (0, 5) is converted to above home.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

from validator.errors import InputError
from validator.plan_format import Cmd, FenceCircle, FencePolygon, Frame, MissionItem, Plan

NAV_FENCE_RETURN_POINT = 5000
# Frames whose x/y are latitude/longitude in degrees.
GLOBAL_FRAMES = frozenset({0, 3, 5, 6, 10, 11})
AMSL_FRAMES = frozenset({0, 5})

FENCE_CIRCLES = (int(Cmd.NAV_FENCE_CIRCLE_INCLUSION), int(Cmd.NAV_FENCE_CIRCLE_EXCLUSION))
FENCE_VERTICES = (
    int(Cmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION),
    int(Cmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION),
)

Point = tuple[float, float, float]  # lat (deg), lon (deg), alt (m)


@dataclass(frozen=True)
class ListItem:
    """One item of a list: ``params`` are param1..param4, x, y, z (in a global frame x and y
    are latitude and longitude in degrees). ``label`` names it in the plan, for messages."""

    frame: int
    command: int
    params: tuple[float, ...]
    autocontinue: bool = True
    current: bool = False
    label: str = field(default="", compare=False)


@dataclass(frozen=True)
class ItemLists:
    """The three lists of a plan."""

    mission: tuple[ListItem, ...] = ()
    fence: tuple[ListItem, ...] = ()
    rally: tuple[ListItem, ...] = ()


def _check_latlon(lat: float, lon: float, what: str) -> None:
    if not (-90.0 <= lat <= 90.0):
        raise InputError(f"{what}: latitude {lat} outside [-90, 90]")
    if not (-180.0 <= lon <= 180.0):
        raise InputError(f"{what}: longitude {lon} outside [-180, 180]")


def _located(frame: int, command: int, lat: float, lon: float, alt: float, what: str,
             param1: float = 0.0) -> ListItem:
    _check_latlon(lat, lon, what)
    return ListItem(frame, command, (float(param1), 0.0, 0.0, 0.0, float(lat), float(lon),
                                     float(alt)), label=what)


def mission_items(plan: Plan, *, home_item: bool) -> tuple[ListItem, ...]:
    """The plan's mission list (see the module doc). Raises :class:`InputError` for a
    latitude or longitude out of range and a DO_JUMP to an item the plan does not have."""
    out: list[ListItem] = []
    offset = 1 if home_item else 0
    if home_item:
        out.append(_located(int(Frame.GLOBAL), int(Cmd.NAV_WAYPOINT), plan.home_lat_deg,
                            plan.home_lon_deg, plan.home_alt_m, "mission.plannedHomePosition"))
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
        out.append(ListItem(int(it.frame), int(it.command), tuple(p), bool(it.autocontinue),
                            label=what))
    if out:
        out[0] = replace(out[0], current=True)
    return tuple(out)


def fence_items(plan: Plan) -> tuple[ListItem, ...]:
    """The plan's geofence list (see the module doc); a circle's radius must be > 0."""
    out: list[ListItem] = []
    glob = int(Frame.GLOBAL)
    for i, poly in enumerate(plan.polygons):
        cmd = FENCE_VERTICES[0] if poly.inclusion else FENCE_VERTICES[1]
        n = len(poly.vertices_deg)
        out += [_located(glob, cmd, lat, lon, 0.0, f"geoFence.polygons[{i}]", param1=n)
                for lat, lon in poly.vertices_deg]
    for i, c in enumerate(plan.circles):
        if not c.radius_m > 0:
            raise InputError(f"geoFence.circles[{i}].radius: must be > 0")
        cmd = FENCE_CIRCLES[0] if c.inclusion else FENCE_CIRCLES[1]
        out.append(_located(glob, cmd, c.lat_deg, c.lon_deg, 0.0, f"geoFence.circles[{i}]",
                            param1=c.radius_m))
    if plan.breach_return is not None:
        lat, lon, alt = plan.breach_return
        out.append(_located(int(Frame.GLOBAL_RELATIVE_ALT), NAV_FENCE_RETURN_POINT, lat, lon,
                            alt, "geoFence.breachReturn"))
    return tuple(out)


def rally_items(plan: Plan) -> tuple[ListItem, ...]:
    """The plan's rally points as NAV_RALLY_POINT items, altitude above home."""
    return tuple(
        _located(int(Frame.GLOBAL_RELATIVE_ALT), int(Cmd.NAV_RALLY_POINT), lat, lon, alt,
                 f"rallyPoints.points[{i}]")
        for i, (lat, lon, alt) in enumerate(plan.rally)
    )


def plan_items(plan: Plan, *, home_item: bool) -> ItemLists:
    """All three lists of ``plan`` (see :func:`mission_items`)."""
    return ItemLists(mission_items(plan, home_item=home_item), fence_items(plan),
                     rally_items(plan))


# ---------------------------------------------------------------------------- reading back


def mission_from_items(items: Sequence[ListItem], *, home_item: bool
                       ) -> tuple[list[MissionItem], Point | None]:
    """A plan's mission items from a mission list, and the home the list starts with
    (``home_item``; None otherwise). DO_JUMP targets become the plan's item numbers again."""
    rest = list(items)
    home: Point | None = None
    offset = 0
    if home_item and rest:
        h = rest.pop(0).params
        home = (h[4], h[5], h[6])
        offset = 1
    out = []
    for it in rest:
        p = list(it.params)
        if it.command == Cmd.DO_JUMP:
            p[0] = float(int(round(p[0])) - offset + 1)
        out.append(MissionItem(it.command, p, it.frame, bool(it.autocontinue)))
    return out, home


def _above_home(item: ListItem, home_alt_m: float) -> float:
    """A rally or return point's altitude above home, whatever frame it came in."""
    z = item.params[6]
    return z - home_alt_m if item.frame in AMSL_FRAMES else z


def fence_from_items(items: Sequence[ListItem], home_alt_m: float, source: str
                     ) -> tuple[list[FenceCircle], list[FencePolygon], Point | None]:
    """Circles, polygons and the breach return point of a fence list; ``home_alt_m`` (AMSL)
    converts a return point given in an AMSL frame. Errors name ``source`` and the item."""
    circles: list[FenceCircle] = []
    polygons: list[FencePolygon] = []
    breach: Point | None = None
    i = 0
    while i < len(items):
        it = items[i]
        p = it.params
        where = f"{source}: fence item {i}"  # its seq (validator.item_numbers)
        if it.command in FENCE_CIRCLES:
            if not p[0] > 0:
                raise InputError(f"{where}: circle radius must be > 0")
            circles.append(FenceCircle(p[4], p[5], p[0], it.command == FENCE_CIRCLES[0]))
            i += 1
        elif it.command in FENCE_VERTICES:
            n = int(round(p[0]))
            group = items[i:i + n]
            if n < 3 or len(group) < n or any(g.command != it.command for g in group):
                raise InputError(f"{where}: polygon of {p[0]:g} vertices is incomplete")
            polygons.append(FencePolygon([(g.params[4], g.params[5]) for g in group],
                                         it.command == FENCE_VERTICES[0]))
            i += n
        elif it.command == NAV_FENCE_RETURN_POINT:
            breach = (p[4], p[5], _above_home(it, home_alt_m))
            i += 1
        else:
            raise InputError(f"{where}: command {it.command} is not a fence item")
    return circles, polygons, breach


def rally_from_items(items: Sequence[ListItem], home_alt_m: float, source: str) -> list[Point]:
    """The rally points of a rally list, altitudes above home (see :func:`fence_from_items`)."""
    out = []
    for i, it in enumerate(items):
        if it.command != Cmd.NAV_RALLY_POINT:
            raise InputError(f"{source}: rally item {i}: command {it.command} is not a rally "
                             "point")
        out.append((it.params[4], it.params[5], _above_home(it, home_alt_m)))
    return out
