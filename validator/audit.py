"""Exact pre-flight checks of a mission's straight legs and geofence against a site.

:func:`audit` proves (or refutes) continuous-path clearance: for every straight leg the vehicle
flies (as resolved by :func:`~validator.flight.resolve_flight`: takeoff, waypoints, DO_JUMP
repeats, RTL as a straight line home, LAND) it computes the exact minimum distance to every
no-fly zone (circles exactly; polygons exactly in sign, a depth to within
:data:`validator.zones.DEPTH_STEP_M`), and checks the geofence: each NFZ inside an exclusion
fence at least as large, no
leg entering an exclusion fence or leaving the inclusion fences, home, rally and breach-return
points outside exclusions and inside inclusions. It also checks commanded speeds against the
site's V, altitudes against its H, and lists what the flight model could not resolve.

Clearances are metres from the NFZ boundary as published (negative = inside); the site's
safety buffer is reported but only its breach of the published radius is a violation, unless
the buffer is required (``require_buffer``: the planner's own safety gate, which planned every
leg R + buffer away). One tolerance, :data:`CLEARANCE_TOLERANCE_M`, absorbs MAVLink's 1e-7°
coordinate rounding in every clearance check here and in the replay.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray

from validator.autopilot.fence_storage import fence_storage_problem
from validator.autopilot.rules import stored_hold_s
from validator.fence_geometry import local_fence
from validator.flight import Finding, Flight, resolve_flight
from validator.geodesy import E7_ROUNDING_MARGIN_M
from validator.geometry import leg_clearances, segment_point_closest_fraction
from validator.item_numbers import item_label, item_number
from validator.motion.ideal import ideal_leg_times
from validator.motion.limits import site_limits
from validator.motion.profile import make_profile
from validator.plan_format import Autopilot, Cmd, Plan
from validator.site import Site
from validator.zones import leg_closest_m, path_clearances_m, point_clearance_m

CLEARANCE_TOLERANCE_M = E7_ROUNDING_MARGIN_M  # MAVLink's 1e-7° rounding (validator.geodesy)
ALTITUDE_TOLERANCE_M = 0.5
HOME_MISMATCH_M = 1.0


@dataclass(frozen=True)
class NfzClosest:
    """Where the planned legs come closest to one NFZ."""

    name: str
    clearance_m: float  # from the published radius; negative = inside
    leg: int  # index into Flight.legs
    from_item: int  # 0-based index; -1: from home (the report gives item numbers)
    item: int  # 0-based index of the leg's destination
    t_s: float  # mission time at the commanded speeds (ideal timing)
    xy_m: tuple[float, float]

    def as_dict(self) -> dict[str, object]:
        return {"nfz": self.name, "clearance_m": self.clearance_m, "leg": self.leg,
                "from_item": item_number(self.from_item), "item": item_number(self.item),
                "t_s": self.t_s,
                "xy_m": list(self.xy_m)}


@dataclass(frozen=True)
class AuditReport:
    """The audit's results. ``leg_clearance_m`` is (legs, zones), the zones in ``nfz_names``
    order (``Site.zone_names``: circles, then polygons); ``findings`` include the flight
    resolution's findings."""

    flight: Flight
    nfz_names: tuple[str, ...]
    leg_clearance_m: NDArray[np.float64]
    nfz: tuple[NfzClosest, ...]
    findings: tuple[Finding, ...]

    @property
    def violations(self) -> list[Finding]:
        return [f for f in self.findings if f.severity == "violation"]

    @property
    def ok(self) -> bool:
        return not self.violations

    def unique_legs(self) -> list[dict[str, object]]:
        """Legs by (from item, to item), repeated legs (DO_JUMP) counted once; ``from_item`` and
        ``item`` are item numbers (:mod:`validator.item_numbers`, home 0)."""
        seen: dict[tuple[int, int, str], dict[str, object]] = {}
        counts: dict[tuple[int, int, str], int] = {}
        for k, leg in enumerate(self.flight.legs):
            key = (_from_item(self.flight, k), leg.item, leg.kind)
            counts[key] = counts.get(key, 0) + 1
            if key in seen:
                seen[key]["count"] = counts[key]
                continue
            seen[key] = {
                "leg": k, "from_item": item_number(key[0]), "item": item_number(leg.item),
                "kind": leg.kind,
                "length_m": leg.length_m, "speed_mps": leg.speed_mps, "hold_s": leg.hold_s,
                "clearance_m": {n: float(c) for n, c in zip(self.nfz_names,
                                                            self.leg_clearance_m[k], strict=True)},
                "count": 1,
            }
        return list(seen.values())

    def as_dict(self) -> dict[str, object]:
        return {
            "ok": self.ok,
            "legs": self.unique_legs(),
            "nfz": [n.as_dict() for n in self.nfz],
            "findings": [f.as_dict() for f in self.findings],
            "cycle": None if self.flight.cycle is None else {
                "source": self.flight.cycle.source, "cycles": self.flight.cycle.cycles,
                "first_leg": self.flight.cycle.start_leg, "last_leg": self.flight.cycle.end_leg,
            },
        }


def _from_item(flight: Flight, k: int) -> int:
    return flight.legs[k - 1].item if k > 0 else -1


def _leg_name(flight: Flight, k: int) -> str:
    leg = flight.legs[k]
    src = _from_item(flight, k)
    return f"leg {item_label(src)} -> {item_label(leg.item)} ({leg.kind})"


def _check_legs(
    flight: Flight, site: Site, clr: NDArray[np.float64], tol: float, require_buffer: bool
) -> list[Finding]:
    out: list[Finding] = []
    reported: set[tuple[int, int, int]] = set()
    rows, cols = np.nonzero(clr < site.buffer_m - tol)
    for k, m in zip(rows.tolist(), cols.tolist(), strict=True):
        leg = flight.legs[k]
        key = (_from_item(flight, k), leg.item, int(m))
        if key in reported:
            continue
        reported.add(key)
        name = site.zone_names[m]
        c = float(clr[k, m])
        if c < -tol:
            out.append(Finding("violation", f"{_leg_name(flight, k)} enters {name} by "
                               f"{-c:.2f} m", leg.item))
        elif site.buffer_m > 0:
            out.append(Finding("violation" if require_buffer else "warning",
                               f"{_leg_name(flight, k)} passes {c:.2f} m from "
                               f"{name}, inside its {site.buffer_m:g} m safety buffer",
                               leg.item))
    return out


# A fence polygon smaller than this (m²) is a line: three vertices in a row on the 1e-7° grid
# enclose a sliver of a few cm², which the breach test treats as a fence of no width
MIN_FENCE_AREA_M2 = 1.0


def _invalid_reason(poly: shapely.Polygon) -> str:
    """Why shapely finds ``poly`` invalid, its point in local metres."""
    reason = shapely.is_valid_reason(poly)  # e.g. "Self-intersection[44.17 221.97]"
    what, _, at = reason.partition("[")
    try:
        x, y = (float(v) for v in at.rstrip("]").split())
    except ValueError:
        return reason
    return f"{what.lower()} at x {x:.1f}, y {y:.1f} m"


def _check_fence(plan: Plan, flight: Flight, site: Site, tol: float) -> list[Finding]:
    out: list[Finding] = []
    fence = local_fence(plan, site.frame)
    circles, polygons = fence.circles, []
    for i, (poly, inclusion) in enumerate(fence.polygons):
        if poly.is_valid and poly.area >= MIN_FENCE_AREA_M2:
            polygons.append((poly, inclusion))
            continue  # the others are of no use in the checks below
        why = (_invalid_reason(poly) if not poly.is_valid else
               f"it has no area (under {MIN_FENCE_AREA_M2:g} m²: collinear vertices)")
        out.append(Finding("violation", f"fence polygon {i} "
                           f"({'inclusion' if inclusion else 'exclusion'}): {why}: the "
                           "autopilot's breach test of it is not the shape drawn", None))
    excl_c = [(c, r) for c, r, inc in circles if not inc]
    incl_c = [(c, r) for c, r, inc in circles if inc]
    excl_p = [p for p, inc in polygons if not inc]
    incl_p = [p for p, inc in polygons if inc]
    # every NFZ inside an exclusion fence at least as large
    for m, name in enumerate(site.nfz_names):
        centre, radius = site.nfz_xy_m[m], float(site.nfz_radius_m[m])
        covered = any(
            float(np.hypot(*(c - centre))) + radius <= r + tol for c, r in excl_c
        ) or any(
            p.buffer(tol).contains(shapely.Point(centre).buffer(radius, quad_segs=32))
            for p in excl_p
        )
        if not covered:
            if excl_c:
                gap = min(float(np.hypot(*(c - centre))) + radius - r for c, r in excl_c)
                detail = f" (the closest exclusion circle misses it by {gap:.2f} m)"
            else:
                detail = " (the plan has no exclusion fence)"
            out.append(Finding("violation", f"{name} is not inside an exclusion fence at least "
                               f"as large{detail}", None))
    for zone in site.polygon_zones:
        covered = any(
            all(float(np.hypot(*(v - c))) <= r + tol for v in zone.vertices_xy_m)
            for c, r in excl_c
        ) or any(p.buffer(tol).contains(zone.shape) for p in excl_p)
        if not covered:
            if excl_p:
                out_m2 = min(float(zone.shape.difference(p).area) for p in excl_p)
                detail = f" (the closest exclusion polygon leaves {out_m2:.2f} m² of it out)"
            else:
                detail = " (the plan has no exclusion polygon)"
            out.append(Finding("violation", f"{zone.name} is not inside an exclusion fence at "
                               f"least as large{detail}", None))
    # legs against the fences
    path = flight.path_xy_m
    if flight.legs and excl_c:
        fc = np.array([c for c, _ in excl_c])
        fr = np.array([r for _, r in excl_c])
        fclr = leg_clearances(path, fc, fr)
        for j in range(fc.shape[0]):
            bad = np.flatnonzero(fclr[:, j] < -tol)
            if bad.size:
                k = int(bad[0])
                out.append(Finding("violation", f"{_leg_name(flight, k)} enters exclusion fence "
                                   f"circle {j} by {-fclr[k, j]:.2f} m", flight.legs[k].item))
    segments = [shapely.LineString([a, b]) if np.hypot(*(b - a)) > 0 else shapely.Point(a)
                for a, b in zip(path[:-1], path[1:], strict=True)] if flight.legs else []
    for j, poly in enumerate(excl_p):
        inner = poly.buffer(-tol)
        for k, seg in enumerate(segments):
            if seg.intersects(inner):
                out.append(Finding("violation", f"{_leg_name(flight, k)} enters exclusion fence "
                                   f"polygon {j}", flight.legs[k].item))
                break
    all_inclusions = flight.firmware_type == Autopilot.ARDUPILOTMEGA
    if incl_c or incl_p:
        regions = [shapely.Point(c).buffer(r + tol, quad_segs=64) for c, r in incl_c]
        regions += [p.buffer(tol) for p in incl_p]
        for k, seg in enumerate(segments):
            inside = [reg.contains(seg) for reg in regions]
            if not (all(inside) if all_inclusions else any(inside)):
                rule = "every inclusion fence" if all_inclusions else "an inclusion fence"
                out.append(Finding("violation", f"{_leg_name(flight, k)} leaves {rule}",
                                   flight.legs[k].item))
                break
    storage = fence_storage_problem(plan, flight.is_ardupilot)
    if storage is not None:
        out.append(Finding("violation", storage, None))
    # home, rally and breach return
    points: list[tuple[str, NDArray[np.float64]]] = [("home", flight.home_xy_m)]
    points += [(f"rally point {i}", np.asarray(site.frame.to_local(lat, lon), dtype=float))
               for i, (lat, lon, _) in enumerate(plan.rally)]
    if plan.breach_return is not None:
        lat, lon, _ = plan.breach_return
        points.append(("breach return point", np.asarray(site.frame.to_local(lat, lon))))
    for label, xy in points:
        pt = shapely.Point(xy)
        for m, name in enumerate(site.nfz_names):
            if np.hypot(*(xy - site.nfz_xy_m[m])) < site.nfz_radius_m[m] - tol:
                out.append(Finding("violation", f"{label} lies inside {name}", None))
        for zone in site.polygon_zones:
            if float(point_clearance_m(zone, xy)) < -tol:
                out.append(Finding("violation", f"{label} lies inside {zone.name}", None))
        for j, (c, r) in enumerate(excl_c):
            if np.hypot(*(xy - c)) < r - tol:
                out.append(Finding("violation", f"{label} lies inside exclusion fence circle {j}",
                                   None))
        for j, poly in enumerate(excl_p):
            if poly.buffer(-tol).contains(pt):
                out.append(Finding("violation", f"{label} lies inside exclusion fence polygon "
                                   f"{j}", None))
        inside = [float(np.hypot(*(xy - c))) <= r + tol for c, r in incl_c]
        inside += [p.buffer(tol).contains(pt) for p in incl_p]
        if inside and not (all(inside) if all_inclusions else any(inside)):
            out.append(Finding("violation", f"{label} lies outside the inclusion fence", None))
    return out


def _check_items(plan: Plan, flight: Flight, site: Site) -> list[Finding]:
    out: list[Finding] = []
    v_max = site.max_speed_mps
    for i, it in enumerate(plan.items):
        if it.command == Cmd.DO_CHANGE_SPEED:
            kind, speed = it.params[0], it.params[1]
            if kind not in (2, 3) and not math.isnan(speed) and speed > v_max * (1 + 1e-6):
                out.append(Finding("violation", f"DO_CHANGE_SPEED to {speed:g} m/s exceeds the "
                                   f"site's V = {v_max:g} m/s", i))
        if (
            flight.is_ardupilot
            and it.command in (Cmd.NAV_WAYPOINT, Cmd.NAV_LOITER_TIME)
            and not math.isnan(it.params[0])
            and stored_hold_s(it.params[0], "ardupilot") != it.params[0]
        ):
            out.append(Finding("warning", f"hold {it.params[0]:g} s: ArduCopter truncates it to "
                               f"{stored_hold_s(it.params[0], 'ardupilot'):g} s", i))
    default_speed = [leg.item for leg in flight.legs
                     if leg.kind == "waypoint" and leg.length_m > 0 and leg.speed_mps is None]
    if default_speed:
        out.append(Finding("note", f"{len(default_speed)} leg(s) fly at the autopilot's default "
                           "speed (WPNAV_SPEED / MPC_XY_CRUISE): no DO_CHANGE_SPEED before them",
                           default_speed[0]))
    seen: set[int] = set()
    for leg in flight.legs:
        if leg.kind in ("waypoint", "loiter") and leg.item not in seen:
            seen.add(leg.item)
            if leg.end_alt_m <= 0:
                out.append(Finding("violation", f"flies at {leg.end_alt_m:g} m above home",
                                   leg.item))
            elif abs(leg.end_alt_m - site.altitude_m) > ALTITUDE_TOLERANCE_M:
                out.append(Finding("warning", f"altitude {leg.end_alt_m:g} m differs from the "
                                   f"site's H = {site.altitude_m:g} m (the rate model assumes H)",
                                   leg.item))
    gap = float(np.hypot(*(flight.home_xy_m - site.home_xy_m)))
    if gap > HOME_MISMATCH_M:
        out.append(Finding("note", f"the plan's home is {gap:.1f} m from the site's home", None))
    return out


def _closest(
    flight: Flight, site: Site, clr: NDArray[np.float64]
) -> tuple[NfzClosest, ...]:
    if not flight.legs or not site.zone_names:
        return ()
    start, reached, _ = ideal_leg_times(flight, make_profile("ideal", site_limits(site)))
    out = []
    for m, name in enumerate(site.zone_names):
        k = int(np.argmin(clr[:, m]))
        leg = flight.legs[k]
        if m < site.num_nfzs:
            f = float(segment_point_closest_fraction(leg.start_xy_m, leg.end_xy_m,
                                                     site.nfz_xy_m[m]))
        else:
            f, _ = leg_closest_m(site.polygon_zones[m - site.num_nfzs], leg.start_xy_m,
                                 leg.end_xy_m)
        xy = leg.start_xy_m + f * (leg.end_xy_m - leg.start_xy_m)
        t = float(start[k] + f * (reached[k] - start[k]))
        out.append(NfzClosest(name, float(clr[k, m]), k, _from_item(flight, k), leg.item, t,
                              (float(xy[0]), float(xy[1]))))
    return tuple(out)


def zone_leg_clearances(flight: Flight, site: Site) -> NDArray[np.float64]:
    """Signed clearance (m) of each leg of ``flight`` from each zone of ``site`` (legs, zones),
    in ``Site.zone_names`` order; a loiter leg counts its circle round the end point."""
    zones = len(site.zone_names)
    if not flight.legs or not zones:
        return np.zeros((len(flight.legs), zones))
    path = flight.path_xy_m
    clr = np.hstack([leg_clearances(path, site.nfz_xy_m, site.nfz_radius_m)
                     if site.num_nfzs else np.zeros((len(flight.legs), 0)),
                     path_clearances_m(site.polygon_zones, path)])
    loiter = np.array([leg.loiter_radius_m for leg in flight.legs])
    if np.any(loiter > 0):
        ends = path[1:]
        circle = np.hstack([
            np.linalg.norm(ends[:, None, :] - site.nfz_xy_m[None], axis=2)
            - site.nfz_radius_m[None, :],
            np.stack([point_clearance_m(z, ends) for z in site.polygon_zones], axis=1)
            if site.polygon_zones else np.zeros((len(ends), 0))]) - loiter[:, None]
        clr = np.minimum(clr, np.where(loiter[:, None] > 0, circle, np.inf))
    return clr


def _check_reach(flight: Flight, site: Site) -> list[Finding]:
    """A leg beyond the area the site's UAS zones were selected in could meet a zone nobody
    looked at."""
    reach = site.airspace.reach_m
    if reach is None:
        return []
    for leg in flight.legs:
        if not reach.covers(shapely.LineString([leg.start_xy_m, leg.end_xy_m])
                            if leg.length_m > 0 else shapely.Point(leg.start_xy_m)):
            return [Finding("violation", f"{leg.label} leaves the area the airspace's UAS zones "
                            "were looked for (round home and the nodes): zones beyond it were "
                            "not checked", leg.item)]
    return []


def audit(
    plan: Plan,
    site: Site,
    flight: Flight | None = None,
    *,
    tolerance_m: float = CLEARANCE_TOLERANCE_M,
    source: str = "plan",
    require_buffer: bool = False,
) -> AuditReport:
    """Check ``plan`` against ``site`` exactly (see the module docstring).

    ``flight`` is the resolved plan (resolved here when not given). ``require_buffer`` makes a
    leg inside an NFZ's safety buffer a violation instead of a warning. Raises
    :class:`~validator.errors.InputError` for missions that cannot be resolved.
    """
    if flight is None:
        flight = resolve_flight(plan, site, source)
    clr = zone_leg_clearances(flight, site)
    findings = list(flight.findings)
    findings += _check_legs(flight, site, clr, tolerance_m, require_buffer)
    findings += _check_fence(plan, flight, site, tolerance_m)
    findings += _check_items(plan, flight, site)
    findings += _check_reach(flight, site)
    order = {"violation": 0, "warning": 1, "note": 2}
    findings.sort(key=lambda f: (order[f.severity], -1 if f.item is None else f.item))
    return AuditReport(flight, site.zone_names, clr, _closest(flight, site, clr), tuple(findings))
