"""The exporter's safety gate: why a laid-out plan must not be written."""

from __future__ import annotations

import numpy as np
import shapely

from mission_planner.mission.readback import flown_legs, nav_positions
from validator.geometry import segment_point_distance
from validator.plan_format import Cmd, Plan
from validator.site import Site

CLEARANCE_TOLERANCE_M = 1e-3  # a leg may come this much closer than R + buffer (issue item 4)


def plan_problems(plan: Plan, site: Site, cycle_items: tuple[int, int] | None = None) -> list[str]:
    """Why the safety gate should refuse ``plan`` (empty if it is safe to fly).

    Every leg, re-read from int32-rounded coordinates, must keep R + buffer − 1 mm from each
    NFZ centre; the rally and breach return points must lie outside every exclusion circle
    and inside any inclusion zone; no leg speed may exceed the site's V.
    """
    problems: list[str] = []
    frame = site.frame
    pairs, legs = flown_legs(plan, frame, cycle_items, rounded=True)
    if site.num_nfzs and len(legs):
        d = segment_point_distance(legs[:, None, 0, :], legs[:, None, 1, :], site.nfz_xy_m[None])
        short = d - site.planning_radius_m[None, :]
        for k, m in zip(*np.nonzero(short < -CLEARANCE_TOLERANCE_M), strict=True):
            inside = d[k, m] < site.nfz_radius_m[m]
            problems.append(
                f"leg from item {pairs[k][0]} to item {pairs[k][1]} passes {d[k, m]:.3f} m from "
                f"the centre of {site.nfz_names[m]}: "
                + (f"inside the zone itself (radius {site.nfz_radius_m[m]:g} m)" if inside else
                   f"{-short[k, m]:.3f} m inside its {site.buffer_m:g} m safety buffer")
            )
    for it_index, it in enumerate(plan.items):
        if it.command == Cmd.DO_CHANGE_SPEED and it.params[1] > site.max_speed_mps:
            problems.append(f"item {it_index}: speed {it.params[1]:g} m/s above the vehicle's "
                            f"{site.max_speed_mps:g} m/s")
    points = list(plan.rally) + ([plan.breach_return] if plan.breach_return else [])
    for lat, lon, _ in points:
        p = frame.to_local(lat, lon)
        for c in plan.circles:
            centre = frame.to_local(c.lat_deg, c.lon_deg)
            dist = float(np.hypot(*(p - centre)))
            if not c.inclusion and dist <= c.radius_m:
                problems.append(f"rally/return point ({lat:.7f}, {lon:.7f}) lies inside an "
                                f"exclusion circle")
            if c.inclusion and dist >= c.radius_m:
                problems.append(f"rally/return point ({lat:.7f}, {lon:.7f}) lies outside the "
                                f"inclusion circle")
        for poly in plan.polygons:
            lat_v, lon_v = zip(*poly.vertices_deg, strict=True)
            zone = shapely.Polygon(frame.to_local(np.array(lat_v), np.array(lon_v)))
            if zone.contains(shapely.Point(p)) != poly.inclusion:
                problems.append(f"rally/return point ({lat:.7f}, {lon:.7f}) is on the wrong "
                                "side of a fence polygon")
    if len(legs):
        _, xy = nav_positions(plan, frame, rounded=True)
        for c in plan.circles:
            if c.inclusion:
                centre = frame.to_local(c.lat_deg, c.lon_deg)
                if np.any(np.linalg.norm(xy - centre, axis=1) >= c.radius_m):
                    problems.append("a waypoint lies outside the inclusion circle")
        for poly in plan.polygons:
            if poly.inclusion:
                lat_v, lon_v = zip(*poly.vertices_deg, strict=True)
                zone = shapely.Polygon(frame.to_local(np.array(lat_v), np.array(lon_v)))
                if not bool(np.all(shapely.contains_xy(zone, xy[:, 0], xy[:, 1]))):
                    problems.append("a waypoint lies outside the inclusion polygon")
    return problems
