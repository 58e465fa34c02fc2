"""QGC WPL 110 ``.waypoints`` files (Mission Planner, MAVProxy): reading and writing.

One text file per MAVLink mission type, each a ``QGC WPL 110`` header and one tab-separated
line per item: ``seq current frame command param1 param2 param3 param4 lat lon alt
autocontinue``. The mission file's line 0 is the home position (AMSL), so mission item i of a
:class:`~validator.plan_format.Plan` is line i + 1, which is also its ArduPilot sequence
number and the number a DO_JUMP names (as the plan's doJumpId does). The fence and rally files
that sit beside it (``NAME.fence.waypoints``, ``NAME.rally.waypoints``) have no home line:
MAVProxy's ``fence load`` and ``rally load`` and pymavlink's ``mavwp`` read them as they are.

Numbers are written with full double precision; a NaN parameter (a plan's ``null``, e.g.
"keep the current yaw") is written as 0, which ArduPilot reads the same way, because Mission
Planner cannot parse ``nan``.
"""

from __future__ import annotations

import math
from pathlib import Path

from validator.errors import InputError
from validator.input_files import read_text
from validator.plan_format import Cmd, FenceCircle, FencePolygon, Frame, MissionItem, Plan

HEADER = "QGC WPL 110"
NAV_FENCE_RETURN_POINT = 5000
MAX_ROWS = 65536  # MAVLink numbers items with a uint16


def _num(v: float) -> str:
    v = float(v)
    if math.isnan(v):
        return "0"
    if math.isfinite(v) and v == int(v) and abs(v) < 1e15:
        return str(int(v))
    return repr(v)


def _line(seq: int, current: int, frame: int, command: int, params: list[float],
          autocontinue: bool) -> str:
    fields = [str(seq), str(current), str(int(frame)), str(int(command))]
    fields += [_num(p) for p in params]
    fields.append("1" if autocontinue else "0")
    return "\t".join(fields)


def dumps_waypoints(plan: Plan) -> str:
    """The plan's mission as QGC WPL 110 text: home on line 0, then the items."""
    lines = [HEADER, _line(0, 1, Frame.GLOBAL, Cmd.NAV_WAYPOINT,
                           [0, 0, 0, 0, plan.home_lat_deg, plan.home_lon_deg, plan.home_alt_m],
                           True)]
    for i, it in enumerate(plan.items, start=1):
        lines.append(_line(i, 0, it.frame, it.command, list(it.params), it.autocontinue))
    return "\n".join(lines) + "\n"


def dumps_fence_waypoints(plan: Plan) -> str:
    """The plan's geofence as QGC WPL 110 fence items (return point, polygons, circles)."""
    rows: list[tuple[int, int, list[float]]] = []
    if plan.breach_return is not None:
        lat, lon, alt = plan.breach_return
        rows.append((Frame.GLOBAL_RELATIVE_ALT, NAV_FENCE_RETURN_POINT,
                     [0, 0, 0, 0, lat, lon, alt]))
    for poly in plan.polygons:
        cmd = (Cmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION if poly.inclusion
               else Cmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION)
        for lat, lon in poly.vertices_deg:
            rows.append((Frame.GLOBAL, cmd, [len(poly.vertices_deg), 0, 0, 0, lat, lon, 0]))
    for c in plan.circles:
        cmd = Cmd.NAV_FENCE_CIRCLE_INCLUSION if c.inclusion else Cmd.NAV_FENCE_CIRCLE_EXCLUSION
        rows.append((Frame.GLOBAL, cmd, [c.radius_m, 0, 0, 0, c.lat_deg, c.lon_deg, 0]))
    lines = [HEADER] + [_line(i, 0, f, cmd, p, False) for i, (f, cmd, p) in enumerate(rows)]
    return "\n".join(lines) + "\n"


def dumps_rally_waypoints(plan: Plan) -> str:
    """The plan's rally points as QGC WPL 110 items (altitude relative to home)."""
    lines = [HEADER] + [
        _line(i, 0, Frame.GLOBAL_RELATIVE_ALT, Cmd.NAV_RALLY_POINT, [0, 0, 0, 0, lat, lon, alt],
              False)
        for i, (lat, lon, alt) in enumerate(plan.rally)
    ]
    return "\n".join(lines) + "\n"


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


_Row = tuple[int, int, int, int, list[float], bool]  # seq, current, frame, command, params, auto


def _rows(text: str, source: str) -> list[_Row]:
    """The items of QGC WPL 110 text: finite numbers, at most ``MAX_ROWS``, numbered 0, 1, ..."""
    lines = text.splitlines()
    if not lines or lines[0].strip() != HEADER:
        raise InputError(f"{source}: line 1: expected the header {HEADER!r}")
    rows: list[_Row] = []
    for n, raw in enumerate(lines[1:], start=2):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if len(rows) == MAX_ROWS:
            raise InputError(f"{source}: line {n}: more than {MAX_ROWS} items")
        parts = line.split()
        if len(parts) != 12:
            raise InputError(f"{source}: line {n}: expected 12 fields, got {len(parts)}")
        try:
            seq, current, frame, command = (int(p) for p in parts[:4])
            params = [float(p) for p in parts[4:11]]
            autocontinue = int(parts[11]) != 0
        except ValueError:
            raise InputError(f"{source}: line {n}: malformed number") from None
        if not all(math.isfinite(p) for p in params):
            raise InputError(f"{source}: line {n}: every number must be finite (no nan or inf)")
        if not (0 <= frame <= 255 and 0 <= command <= 65535):
            raise InputError(f"{source}: line {n}: frame or command out of range")
        if seq != len(rows):
            raise InputError(f"{source}: line {n}: sequence number {seq}, expected {len(rows)}")
        rows.append((seq, current, frame, command, params, autocontinue))
    return rows


def loads_waypoints(text: str, source: str = "waypoints") -> Plan:
    """Parse a QGC WPL 110 mission (line 0 = home) into a :class:`Plan` without fence or rally."""
    rows = _rows(text, source)
    if not rows:
        raise InputError(f"{source}: no home line")
    home = rows[0][4]
    items = [MissionItem(cmd, params, frame, auto) for _, _, frame, cmd, params, auto in rows[1:]]
    return Plan(items=items, home_lat_deg=home[4], home_lon_deg=home[5], home_alt_m=home[6])


def loads_fence_waypoints(
    text: str, source: str = "fence"
) -> tuple[list[FenceCircle], list[FencePolygon], tuple[float, float, float] | None]:
    """Parse QGC WPL 110 fence items into circles, polygons and the breach return point."""
    circles: list[FenceCircle] = []
    polygons: list[FencePolygon] = []
    breach: tuple[float, float, float] | None = None
    rows = _rows(text, source)
    k = 0
    while k < len(rows):
        seq, _, _, cmd, p, _ = rows[k]
        where = f"{source}: item {seq}"
        if cmd == NAV_FENCE_RETURN_POINT:
            breach = (p[4], p[5], p[6])
        elif cmd in (Cmd.NAV_FENCE_CIRCLE_INCLUSION, Cmd.NAV_FENCE_CIRCLE_EXCLUSION):
            if not p[0] > 0:
                raise InputError(f"{where}: circle radius must be > 0")
            circles.append(FenceCircle(p[4], p[5], p[0], cmd == Cmd.NAV_FENCE_CIRCLE_INCLUSION))
        elif cmd in (Cmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                     Cmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION):
            count = int(p[0])
            block = rows[k:k + count]
            if count < 3 or len(block) < count or any(r[3] != cmd for r in block):
                raise InputError(f"{where}: polygon of {count} vertices is incomplete")
            polygons.append(FencePolygon([(r[4][4], r[4][5]) for r in block],
                                         cmd == Cmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION))
            k += count
            continue
        else:
            raise InputError(f"{where}: command {cmd} is not a fence item")
        k += 1
    return circles, polygons, breach


def loads_rally_waypoints(text: str, source: str = "rally") -> list[tuple[float, float, float]]:
    """Parse QGC WPL 110 rally items into (lat, lon, alt) points."""
    out = []
    for seq, _, _, cmd, p, _ in _rows(text, source):
        if cmd != Cmd.NAV_RALLY_POINT:
            raise InputError(f"{source}: item {seq}: command {cmd} is not a rally point")
        out.append((p[4], p[5], p[6]))
    return out


def read_waypoints(path: str | Path) -> Plan:
    """Read a ``.waypoints`` mission and, when they exist, its fence and rally files."""
    path = Path(path)

    def text_of(p: Path) -> str:
        return read_text(p, "waypoints")

    plan = loads_waypoints(text_of(path), str(path))
    fence_path, rally_path = sidecar_paths(path)
    if fence_path.exists():
        plan.circles, plan.polygons, plan.breach_return = loads_fence_waypoints(
            text_of(fence_path), str(fence_path))
    if rally_path.exists():
        plan.rally = loads_rally_waypoints(text_of(rally_path), str(rally_path))
    return plan
