"""The failsafe audit: the path each failsafe action would fly from every point of the mission,
checked exactly against every zone and its buffer.

For each failsafe of the plan's autopilot (:mod:`validator.autopilot.failsafe`: the action a
parameter file sets, or the firmware's default where it sets none) every path the action may fly
is checked, fallbacks included:

- a straight return (ArduCopter RTL; PX4 Return with RTL_TYPE 0, 1 or 3): the vehicle climbs
  where it is (RTL_ALT / RTL_RETURN_ALT; zones are walls of any height, so the climb changes
  nothing here) and flies straight to its destination: home, or the rally point the autopilot
  picks from where it is (ArduCopter: the nearest, unless further than RALLY_LIMIT_KM, and home
  when RALLY_INCL_HOME and home is nearer; PX4: the nearest of home and the rally points more
  than 10 m from home, a rally point only when 2 m nearer; RTL_TYPE 1 prefers any rally point).
  "Home" is the home in force on the leg (``Flight.home_of``): the plan's until a mission's
  DO_SET_HOME moves it, as both autopilots pick the destination against the home they hold
  when the return starts (:mod:`validator.flight.home`).
  The straight lines from every point of a leg to one destination fill the triangle of the leg's
  ends and the destination, so each leg is cut where the destination changes (found to 1e-9 of
  the leg; a destination region shorter than :data:`SPLIT_STEP_M` along a leg could be missed)
  and each piece's triangle is measured against each zone: circles exactly, polygons exactly in
  sign with a depth to within :data:`DEPTH_GRID_M`;
- SmartRTL and PX4's mission-path Return (RTL_TYPE 2) retrace the mission's own path (SmartRTL
  within SRTL_ACCURACY, 2 m by default): clear wherever the mission audit is;
- Land, Brake, Hold: where the vehicle is, on the mission's path;
- an action that is off or only warns: the mission goes on.

Points are taken on the planned legs (a loiter's circle included); the corners the autopilot
cuts inside its waypoint radius, and the few metres a fence breach takes to stop, are left to
the buffer. Each path that enters a zone or its buffer is a :class:`PathFinding`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from validator.audit import zone_leg_clearances
from validator.autopilot import failsafe as fs
from validator.autopilot.tables import param_table
from validator.flight import Flight, Home, Leg
from validator.geodesy import E7_ROUNDING_MARGIN_M
from validator.geometry import segment_point_distance
from validator.item_numbers import item_label, item_number
from validator.plan_format import Autopilot, Plan
from validator.position_loss import (
    PositionLossFinding,
    audit_position_loss,
    coasting_failsafe,
)
from validator.site import Site
from validator.zones import PolygonZone, point_clearance_m

SPLIT_STEP_M = 0.5  # where a leg is probed for a change of return destination
DEPTH_GRID_M = 0.25  # the depth of a return path inside a polygon zone, to within this
CLEARANCE_TOLERANCE_M = E7_ROUNDING_MARGIN_M  # as the mission audit: MAVLink's rounding
LOITER_SEGMENTS = 16  # a loiter circle as a polygon of 4 x this many sides, drawn outside it


@dataclass(frozen=True)
class PathFinding:
    """A failsafe path that enters a zone or its buffer: the action (parameter, value, path),
    the zone, the leg it is flown from (``leg`` into Flight.legs; items as in the plan), the
    least clearance of the path from the zone's published boundary (negative: that deep
    inside), where on the leg the failsafe fires for that path, and the destination."""

    trigger: str
    param: str
    value: float
    action: str
    path: str
    zone: str
    leg: int
    from_item: int  # 0-based index, -1: from home (text and report give item numbers)
    item: int
    clearance_m: float
    buffer_m: float
    start_xy_m: tuple[float, float]
    destination: str
    destination_xy_m: tuple[float, float]

    @property
    def message(self) -> str:
        depth = (f"enters {self.zone} {-self.clearance_m:.2f} m deep" if self.clearance_m < 0
                 else f"passes {self.clearance_m:.2f} m from {self.zone}, inside its "
                      f"{self.buffer_m:g} m buffer")
        return (f"failsafe {self.trigger}: {self.param} {self.value:g} ({self.action}) flies "
                f"{self.path.upper()} straight to {self.destination} and {depth}, from the leg "
                f"{item_label(self.from_item)} -> {item_label(self.item)} (first at "
                f"x {self.start_xy_m[0]:.1f}, y {self.start_xy_m[1]:.1f} m)")

    def as_dict(self) -> dict[str, Any]:
        return {"trigger": self.trigger, "param": self.param, "value": self.value,
                "action": self.action, "path": self.path, "zone": self.zone, "leg": self.leg,
                "from_item": item_number(self.from_item), "item": item_number(self.item),
                "clearance_m": self.clearance_m, "depth_m": max(0.0, -self.clearance_m),
                "buffer_m": self.buffer_m, "start_xy_m": list(self.start_xy_m),
                "destination": self.destination,
                "destination_xy_m": list(self.destination_xy_m), "message": self.message}


@dataclass(frozen=True)
class FailsafeCheck:
    """One failsafe as the parameters leave it: the value, where it came from, its paths."""

    trigger: str
    param: str
    value: float
    source: str  # "file" or "default"
    action: str
    paths: tuple[str, ...]

    def as_dict(self) -> dict[str, Any]:
        return {"trigger": self.trigger, "param": self.param, "value": self.value,
                "source": self.source, "action": self.action, "paths": list(self.paths)}


@dataclass(frozen=True)
class ReturnPoint:
    """Where on the mission a straight return comes closest to a zone: the leg, the point on
    it, the clearance of its return path, the zone."""

    leg: int
    item: int
    xy_m: tuple[float, float]
    clearance_m: float
    zone: str
    destination: str
    destination_xy_m: tuple[float, float]

    def as_dict(self) -> dict[str, Any]:
        return {"leg": self.leg, "item": item_number(self.item), "xy_m": list(self.xy_m),
                "clearance_m": self.clearance_m, "zone": self.zone,
                "destination": self.destination,
                "destination_xy_m": list(self.destination_xy_m)}


@dataclass(frozen=True)
class FailsafeReport:
    """The failsafe audit of one plan on one site under one parameter set."""

    autopilot: str
    checks: tuple[FailsafeCheck, ...]
    findings: tuple[PathFinding, ...]
    notes: tuple[str, ...]
    worst_return: ReturnPoint | None
    params: Mapping[str, float] = field(default_factory=dict)
    # the outline of every straight return's line when an action flies one (rings, (P, 2)
    # each; for a view, not in as_dict): the region the audit proved clear, or not
    return_region_xy_m: tuple[NDArray[np.float64], ...] = ()
    # a GPS loss (either autopilot): the legs whose coast may reach a zone (position_loss;
    # a warning: no failsafe parameter steers a vehicle without a position)
    position_loss: tuple[PositionLossFinding, ...] = ()
    # the parameter of the failsafe that acts after a GPS loss (position_loss.coasting_failsafe)
    gps_loss_failsafe: str = ""

    @property
    def ok(self) -> bool:
        return not self.findings

    def as_dict(self) -> dict[str, Any]:
        return {"autopilot": self.autopilot, "ok": self.ok,
                "checks": [c.as_dict() for c in self.checks],
                "findings": [f.as_dict() for f in self.findings], "notes": list(self.notes),
                "worst_return": None if self.worst_return is None else
                self.worst_return.as_dict(), "params": dict(self.params),
                "position_loss": [f.as_dict() for f in self.position_loss],
                "gps_loss_failsafe": self.gps_loss_failsafe}


# --------------------------------------------------------------------------------------------
# where a straight return goes


@dataclass(frozen=True)
class _Destinations:
    """The points a straight return may fly to and the rule choosing among them: the home in
    force (``home_label`` names it) and the rally points."""

    autopilot: str
    home_xy_m: NDArray[np.float64]
    rally_xy_m: NDArray[np.float64]  # (R, 2)
    incl_home: bool = True
    limit_m: float = 0.0  # ArduCopter RALLY_LIMIT_KM in m; 0: none
    prefer_rally: bool = False  # PX4 RTL_TYPE 1
    home_label: str = "home"

    def with_home(self, home: Home) -> _Destinations:
        """The same rule from a leg where ``home`` is in force: both autopilots choose against
        the home they hold when the return starts (:mod:`validator.flight.home`)."""
        return dataclasses.replace(self, home_xy_m=home.xy_m, home_label=home.label)

    def choose(self, p: NDArray[np.float64]) -> int:
        """The destination of a return from ``p``: -1 home, else the rally point's index."""
        if not len(self.rally_xy_m):
            return -1
        d = np.linalg.norm(self.rally_xy_m - p, axis=1)
        home = float(np.linalg.norm(self.home_xy_m - p))
        if self.autopilot == "px4":  # rtl.cpp findRtlDestination, in the rally points' order
            far = np.linalg.norm(self.rally_xy_m - self.home_xy_m, axis=1)
            best, least = -1, math.inf if self.prefer_rally else home
            for i in range(len(d)):
                if far[i] > fs.PX4_RALLY_MIN_FROM_HOME_M and d[i] + fs.PX4_RALLY_MARGIN_M < least:
                    best, least = i, float(d[i])
            return best
        i = int(np.argmin(d))  # AP_Rally::calc_best_rally_or_home_location
        if self.limit_m > 0 and d[i] > self.limit_m:
            return -1
        return i if (not self.incl_home or d[i] < home) else -1

    def point(self, k: int) -> NDArray[np.float64]:
        return self.home_xy_m if k < 0 else self.rally_xy_m[k]

    def name(self, k: int) -> str:
        return self.home_label if k < 0 else f"rally point {k + 1}"


def _pieces(a: NDArray[np.float64], b: NDArray[np.float64], dest: _Destinations
            ) -> list[tuple[NDArray[np.float64], NDArray[np.float64], int]]:
    """The leg a→b cut where the return destination changes: (start, end, destination)."""
    length = float(np.linalg.norm(b - a))
    n = max(2, int(math.ceil(length / SPLIT_STEP_M)) + 1)
    s = np.linspace(0.0, 1.0, n)
    ks = [dest.choose(a + t * (b - a)) for t in s]
    out, start, k0 = [], a, ks[0]
    for i in range(1, n):
        if ks[i] == k0:
            continue
        lo, hi = float(s[i - 1]), float(s[i])
        for _ in range(40):  # to ~1e-12 of the step
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if dest.choose(a + mid * (b - a)) == k0 else (lo, mid)
        cut = a + hi * (b - a)
        out.append((start, cut, k0))
        start, k0 = cut, ks[i]
    out.append((start, b, k0))
    return out


def _region(start: NDArray[np.float64], end: NDArray[np.float64], loiter_m: float,
            target: NDArray[np.float64]) -> shapely.Geometry:
    """Every straight line from a point of the piece start→end (or of a loiter circle of
    ``loiter_m`` round ``end``) to ``target``: their convex hull."""
    if loiter_m > 0:
        grow = 1.0 / math.cos(math.pi / (4 * LOITER_SEGMENTS))  # the polygon holds the circle
        src = shapely.Point(end).buffer(loiter_m * grow, quad_segs=LOITER_SEGMENTS)
        return shapely.convex_hull(shapely.union(src, shapely.Point(target)))
    return shapely.convex_hull(shapely.MultiPoint([start, end, target]))


def _polygon_clearance(zone: PolygonZone, region: shapely.Geometry) -> float:
    """Signed clearance of ``region`` from a polygon zone: the distance, or minus the depth of
    its deepest point inside (to within DEPTH_GRID_M)."""
    d = float(shapely.distance(zone.shape, region))
    if d > 0.0:
        return d
    inter = shapely.intersection(zone.shape, region)
    if inter.is_empty:
        return 0.0
    x0, y0, x1, y1 = inter.bounds
    step = max(DEPTH_GRID_M, max(x1 - x0, y1 - y0) / 400.0)
    gx, gy = np.meshgrid(np.arange(x0, x1 + step, step), np.arange(y0, y1 + step, step))
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
    pts = pts[shapely.contains_xy(inter, pts[:, 0], pts[:, 1])]
    corners = shapely.get_coordinates(inter)
    pts = np.vstack([pts, corners]) if len(pts) else corners
    return float(np.min(point_clearance_m(zone, pts)))


def _zone_clearances(site: Site, region: shapely.Geometry) -> NDArray[np.float64]:
    """Signed clearance of ``region`` from every zone, in ``Site.zone_names`` order."""
    circles = [float(shapely.distance(shapely.Point(c), region)) - float(r)
               for c, r in zip(site.nfz_xy_m, site.nfz_radius_m, strict=True)]
    polys = [_polygon_clearance(z, region) for z in site.polygon_zones]
    return np.array(circles + polys, dtype=float)


def _worst_start(site: Site, m: int, start: NDArray[np.float64], end: NDArray[np.float64],
                 target: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
    """The point of the piece start→end whose straight return comes closest to zone ``m``
    (sampled: for reporting where, not for the verdict), and that return's clearance."""
    n = max(2, int(math.ceil(float(np.linalg.norm(end - start)) / SPLIT_STEP_M)) + 1)
    pts = start + np.linspace(0.0, 1.0, n)[:, None] * (end - start)
    if m < site.num_nfzs:
        c = segment_point_distance(pts, target[None, :], site.nfz_xy_m[m]) - site.nfz_radius_m[m]
    else:
        zone = site.polygon_zones[m - site.num_nfzs]
        lines = shapely.linestrings(np.stack([pts, np.broadcast_to(target, pts.shape)], axis=1))
        c = np.asarray(shapely.distance(zone.shape, lines), dtype=float)
        c = np.where(c > 0, c, -np.asarray(shapely.length(shapely.intersection(zone.shape,
                                                                                lines))))
    i = int(np.argmin(c))
    return pts[i], float(c[i])


@dataclass(frozen=True)
class _Exposure:
    """The least clearance of the straight returns from one leg piece to each zone, and the
    destination they fly to."""

    leg: int
    start: NDArray[np.float64]
    end: NDArray[np.float64]
    target: str
    target_xy_m: NDArray[np.float64]
    clearance_m: NDArray[np.float64]  # per zone
    region: shapely.Geometry


def _return_exposures(flight: Flight, site: Site, rule: _Destinations) -> list[_Exposure]:
    out = []
    for k, leg in enumerate(flight.legs):
        dest = rule.with_home(flight.home_of(k))
        for start, end, d in _pieces(leg.start_xy_m, leg.end_xy_m, dest):
            target = dest.point(d)
            region = _region(start, end, leg.loiter_radius_m, target)
            out.append(_Exposure(k, start, end, dest.name(d), target,
                                 _zone_clearances(site, region), region))
    return out


# --------------------------------------------------------------------------------------------
# the parameters


def _autopilot(plan: Plan) -> str:
    return "px4" if plan.firmware_type == Autopilot.PX4 else "ardupilot"


def effective_params(autopilot: str, params: Mapping[str, float] | None
                     ) -> tuple[dict[str, float], dict[str, str]]:
    """The failsafe parameters in force: the file's values, else the firmware's defaults; and
    where each came from ("file" or "default")."""
    values = fs.failsafe_defaults(autopilot)
    source = dict.fromkeys(values, "default")
    for name in values:
        if params is not None and name in params:
            values[name] = float(params[name])
            source[name] = "file"
    return values, source


def _checks(autopilot: str, values: Mapping[str, float], source: Mapping[str, str]
            ) -> list[FailsafeCheck]:
    out = []
    for f in fs.FAILSAFES[autopilot]:
        value = values[f.param]
        act = f.action(value)
        paths = act.paths
        if autopilot == "ardupilot" and f.param in fs.FS_OPTIONS_CONTINUE_AUTO:
            if int(values["FS_OPTIONS"]) & fs.FS_OPTIONS_CONTINUE_AUTO[f.param] and value != 0:
                paths, act = ("mission",), fs.Action(f"{act.name}; FS_OPTIONS continues the "
                                                     "mission in Auto", ("mission",))
        if autopilot == "px4" and f.param == "NAV_RCL_ACT" and \
                int(values["COM_RCL_EXCEPT"]) & fs.COM_RCL_EXCEPT_MISSION:
            paths, act = ("mission",), fs.Action(f"{act.name}; COM_RCL_EXCEPT ignores it in a "
                                                 "mission", ("mission",))
        if autopilot == "px4" and "rtl" in paths and int(values["RTL_TYPE"]) == \
                fs.RTL_TYPE_MISSION_PATH:
            paths = tuple("mission_path" if p == "rtl" else p for p in paths)
        out.append(FailsafeCheck(f.trigger, f.param, value, source[f.param], act.name, paths))
    return out


def _destinations(plan: Plan, flight: Flight, site: Site, autopilot: str,
                  values: Mapping[str, float]) -> _Destinations:
    rally = np.array([site.frame.to_local(lat, lon) for lat, lon, _ in plan.rally],
                     dtype=float).reshape(-1, 2)
    if autopilot == "px4":
        return _Destinations("px4", flight.home_xy_m, rally, prefer_rally=int(
            values["RTL_TYPE"]) == 1)
    limit_m = param_table("ardupilot")["RALLY_LIMIT_KM"].to_si * values["RALLY_LIMIT_KM"]
    return _Destinations("ardupilot", flight.home_xy_m, rally,
                         incl_home=values["RALLY_INCL_HOME"] != 0, limit_m=limit_m)


def smartrtl_points_needed(flight: Flight) -> int:
    """The SmartRTL points (SRTL_POINTS) to keep the whole mission's path: SmartRTL keeps a
    straight leg as its two ends once simplified, a blended corner as a short arc; allowing 4
    a leg, without counting the loops it prunes, is an upper bound for our plans."""
    return 4 * len(flight.legs) + 20


def audit_failsafes(plan: Plan, site: Site, flight: Flight,
                    params: Mapping[str, float] | None,
                    tolerance_m: float = CLEARANCE_TOLERANCE_M) -> FailsafeReport:
    """The failsafe audit of ``plan`` (resolved as ``flight``) on ``site`` under ``params``
    (a parameter file's values; None: the firmware's defaults): see the module doc."""
    autopilot = _autopilot(plan)
    values, source = effective_params(autopilot, params)
    checks = _checks(autopilot, values, source)
    notes: list[str] = []
    exposures: list[_Exposure] = []
    dest = _destinations(plan, flight, site, autopilot, values)
    if flight.legs and site.zone_names:
        exposures = _return_exposures(flight, site, dest)
    findings: list[PathFinding] = []
    for c in checks:
        if "rtl" not in c.paths:
            continue
        for m, zone in enumerate(site.zone_names):
            worst: dict[int, _Exposure] = {}
            for e in exposures:
                if e.clearance_m[m] < site.buffer_m - tolerance_m and (
                        e.leg not in worst or e.clearance_m[m] < worst[e.leg].clearance_m[m]):
                    worst[e.leg] = e
            for k, e in sorted(worst.items()):
                leg = flight.legs[k]
                xy, _ = _worst_start(site, m, e.start, e.end, e.target_xy_m)
                findings.append(PathFinding(
                    c.trigger, c.param, c.value, c.action, "rtl", zone, k,
                    _from_item(flight, k), leg.item, float(e.clearance_m[m]), site.buffer_m,
                    _pair(xy), e.target, _pair(e.target_xy_m)))
    if autopilot == "ardupilot" and any("smartrtl" in c.paths for c in checks):
        notes += _smartrtl_notes(flight, site, values["SRTL_ACCURACY"])
        need = smartrtl_points_needed(flight)
        if values["SRTL_POINTS"] < min(need, param_table("ardupilot")["SRTL_POINTS"].maximum):
            notes.append(f"SRTL_POINTS {values['SRTL_POINTS']:g} may not hold the whole "
                         f"mission's path (up to {need} points): SmartRTL then falls back")
    flies_rtl = any("rtl" in c.paths for c in checks)
    lost: tuple[PositionLossFinding, ...] = ()
    if flight.legs:
        lost = tuple(audit_position_loss(flight, site, params, autopilot=autopilot))
    return FailsafeReport(autopilot, tuple(checks), tuple(findings), tuple(notes),
                          _worst_return(flight, site, exposures), dict(values),
                          _outline(exposures) if flies_rtl else (), lost,
                          coasting_failsafe(autopilot, params))


def _pair(xy: NDArray[np.float64]) -> tuple[float, float]:
    return float(xy[0]), float(xy[1])


def _outline(exposures: list[_Exposure], tolerance_m: float = 0.5
             ) -> tuple[NDArray[np.float64], ...]:
    """The outer rings of the union of the straight returns' regions, simplified to within
    ``tolerance_m`` (a drawing, not the verdict; a hole, rare, is left out)."""
    if not exposures:
        return ()
    union = shapely.union_all([e.region for e in exposures]).simplify(tolerance_m)
    polygons = getattr(union, "geoms", [union])
    return tuple(np.asarray(p.exterior.coords, dtype=float) for p in polygons
                 if isinstance(p, shapely.Polygon) and not p.is_empty)


def _smartrtl_notes(flight: Flight, site: Site, accuracy_m: float) -> list[str]:
    """SmartRTL keeps its path's points SRTL_ACCURACY apart and simplifies it: a zone the
    mission passes within that of its buffer may be passed that much closer (measured: 1.94 m
    from a polygon the mission kept 3 m from)."""
    if not flight.legs or not site.zone_names:
        return []
    clr = np.min(zone_leg_clearances(flight, site), axis=0)
    return [f"SmartRTL retraces the flown path to within SRTL_ACCURACY {accuracy_m:g} m: it "
            f"may pass {c - accuracy_m:.2f} m from {zone}, inside its {site.buffer_m:g} m buffer"
            for zone, c in zip(site.zone_names, clr, strict=True)
            if c - accuracy_m < site.buffer_m]


def _from_item(flight: Flight, k: int) -> int:
    return -1 if k == 0 else flight.legs[k - 1].item


def _worst_return(flight: Flight, site: Site, exposures: list[_Exposure]) -> ReturnPoint | None:
    """The point of the mission whose straight return comes closest to a zone."""
    if not exposures:
        return None
    least = [float(np.min(e.clearance_m)) for e in exposures]
    e = exposures[int(np.argmin(least))]
    m = int(np.argmin(e.clearance_m))
    xy, _ = _worst_start(site, m, e.start, e.end, e.target_xy_m)
    leg: Leg = flight.legs[e.leg]
    return ReturnPoint(e.leg, leg.item, _pair(xy), float(e.clearance_m[m]),
                       site.zone_names[m], e.target, _pair(e.target_xy_m))
