"""QGC WPL 110 ``.waypoints`` files (Mission Planner, MAVProxy): reading and writing.

One text file per MAVLink mission type, each a ``QGC WPL 110`` header and one tab-separated
line per item: ``seq current frame command param1 param2 param3 param4 lat lon alt
autocontinue``. The lines are the item lists a vehicle holds, in the order they go over the
wire (:mod:`validator.item_lists`): the mission file's line 0 is the home position (AMSL), so
mission item i of a :class:`~validator.plan_format.Plan` is line i + 1, which is also its
ArduPilot sequence number and the number a DO_JUMP names (a ``.plan`` names it by doJumpId). The
fence and rally files that sit beside it (``NAME.fence.waypoints``, ``NAME.rally.waypoints``)
have no home line: MAVProxy's ``fence load`` and ``rally load`` and pymavlink's ``mavwp`` read
them as they are.

Numbers are written with full double precision; a NaN parameter (a plan's ``null``, e.g.
"keep the current yaw") is written as 0, which ArduPilot reads the same way, because Mission
Planner cannot parse ``nan``.
"""

from __future__ import annotations

import math
from pathlib import Path

from validator.errors import InputError
from validator.input_files import read_text
from validator.item_lists import (
    ListItem,
    fence_from_items,
    fence_items,
    mission_from_items,
    mission_items,
    rally_from_items,
    rally_items,
)
from validator.plan_format import FenceCircle, FencePolygon, Plan

HEADER = "QGC WPL 110"
MAX_ROWS = 65536  # MAVLink numbers items with a uint16


def _num(v: float) -> str:
    v = float(v)
    if math.isnan(v):
        return "0"
    if math.isfinite(v) and v == int(v) and abs(v) < 1e15:
        return str(int(v))
    return repr(v)


def _text(items: tuple[ListItem, ...]) -> str:
    lines = [HEADER]
    for seq, it in enumerate(items):
        fields = [str(seq), "1" if it.current else "0", str(it.frame), str(it.command)]
        fields += [_num(p) for p in it.params]
        fields.append("1" if it.autocontinue else "0")
        lines.append("\t".join(fields))
    return "\n".join(lines) + "\n"


def dumps_waypoints(plan: Plan) -> str:
    """The plan's mission as QGC WPL 110 text: home on line 0, then the items."""
    return _text(mission_items(plan, home_item=True))


def dumps_fence_waypoints(plan: Plan) -> str:
    """The plan's geofence as QGC WPL 110 fence items (polygons, circles, return point)."""
    return _text(fence_items(plan))


def dumps_rally_waypoints(plan: Plan) -> str:
    """The plan's rally points as QGC WPL 110 items (altitude relative to home)."""
    return _text(rally_items(plan))


def sidecar_paths(path: str | Path) -> tuple[Path, Path]:
    """Where the fence and rally files of the mission file ``path`` go."""
    path = Path(path)
    stem = path.name.removesuffix(".waypoints")
    return path.with_name(f"{stem}.fence.waypoints"), path.with_name(f"{stem}.rally.waypoints")


def waypoint_files(plan: Plan, path: str | Path) -> dict[Path, str]:
    """Every file (path -> text) that stores ``plan`` as ``.waypoints`` at ``path``.

    The mission always; the fence and rally files beside it when the plan has any.
    """
    fence_path, rally_path = sidecar_paths(path)
    files = {Path(path): dumps_waypoints(plan)}
    if plan.circles or plan.polygons or plan.breach_return is not None:
        files[fence_path] = dumps_fence_waypoints(plan)
    if plan.rally:
        files[rally_path] = dumps_rally_waypoints(plan)
    return files


def _items(text: str, source: str) -> list[ListItem]:
    """The items of QGC WPL 110 text: finite numbers, at most ``MAX_ROWS``, numbered 0, 1, ..."""
    lines = text.splitlines()
    if not lines or lines[0].strip() != HEADER:
        raise InputError(f"{source}: line 1: expected the header {HEADER!r}")
    items: list[ListItem] = []
    for n, raw in enumerate(lines[1:], start=2):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if len(items) == MAX_ROWS:
            raise InputError(f"{source}: line {n}: more than {MAX_ROWS} items")
        parts = line.split()
        if len(parts) != 12:
            raise InputError(f"{source}: line {n}: expected 12 fields, got {len(parts)}")
        try:
            seq, current, frame, command = (int(p) for p in parts[:4])
            params = tuple(float(p) for p in parts[4:11])
            autocontinue = int(parts[11]) != 0
        except ValueError:
            raise InputError(f"{source}: line {n}: malformed number") from None
        if not all(math.isfinite(p) for p in params):
            raise InputError(f"{source}: line {n}: every number must be finite (no nan or inf)")
        if not (0 <= frame <= 255 and 0 <= command <= 65535):
            raise InputError(f"{source}: line {n}: frame or command out of range")
        if seq != len(items):
            raise InputError(f"{source}: line {n}: sequence number {seq}, expected {len(items)}")
        items.append(ListItem(frame, command, params, autocontinue, current != 0))
    return items


def loads_waypoints(text: str, source: str = "waypoints") -> Plan:
    """Parse a QGC WPL 110 mission (line 0 = home) into a :class:`Plan` without fence or rally."""
    items, home = mission_from_items(_items(text, source), home_item=True)
    if home is None:
        raise InputError(f"{source}: no home line")
    return Plan(items=items, home_lat_deg=home[0], home_lon_deg=home[1], home_alt_m=home[2])


def loads_fence_waypoints(
    text: str, source: str = "fence", home_alt_m: float = 0.0
) -> tuple[list[FenceCircle], list[FencePolygon], tuple[float, float, float] | None]:
    """Parse QGC WPL 110 fence items into circles, polygons and the breach return point
    (``home_alt_m``, AMSL, converts a return point written in an AMSL frame)."""
    return fence_from_items(_items(text, source), home_alt_m, source)


def loads_rally_waypoints(text: str, source: str = "rally",
                          home_alt_m: float = 0.0) -> list[tuple[float, float, float]]:
    """Parse QGC WPL 110 rally items into (lat, lon, alt above home) points."""
    return rally_from_items(_items(text, source), home_alt_m, source)


def read_waypoints(path: str | Path) -> Plan:
    """Read a ``.waypoints`` mission and, when they exist, its fence and rally files."""
    path = Path(path)

    def text_of(p: Path) -> str:
        return read_text(p, "waypoints")

    plan = loads_waypoints(text_of(path), str(path))
    fence_path, rally_path = sidecar_paths(path)
    if fence_path.exists():
        plan.circles, plan.polygons, plan.breach_return = loads_fence_waypoints(
            text_of(fence_path), str(fence_path), plan.home_alt_m)
    if rally_path.exists():
        plan.rally = loads_rally_waypoints(text_of(rally_path), str(rally_path),
                                           plan.home_alt_m)
    return plan
