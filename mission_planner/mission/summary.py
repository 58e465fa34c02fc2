"""The mission part of the report: items, the cycle as laid out, transits, fence, expanded
radii and clearance."""

from __future__ import annotations

import numpy as np
import shapely

from mission_planner.mission.build import Mission, timed_for
from mission_planner.mission.readback import flown_legs
from mission_planner.mission.speeds import transit_speeds
from mission_planner.transit import path_length_m
from validator.geometry import expanded_radius, segment_point_distance
from validator.plan_format import Cmd
from validator.zones import leg_clearance_m


def cycle_duration_s(mission: Mission) -> float:
    """Duration (s) of one service cycle as laid out: each leg at its speed (an S-curve leg
    for its S-curve time) plus the holds as written in the plan and the stop lags they were
    written net of."""
    first, last = mission.cycle_items
    holds = [it.params[0] for it in mission.plan.items[first:last + 1]
             if it.command == Cmd.NAV_WAYPOINT]
    q = mission.trajectory_m
    prev = q[0]
    total = 0.0
    for s, hold in zip(mission.steps, holds, strict=True):
        here = q[s.index]
        if s.speed_mps is not None:
            total += s.leg_s if s.scurve else float(np.hypot(*(here - prev))) / s.speed_mps
        total += hold + s.stop_lag_s
        prev = here
    return total


def transit_s(mission: Mission, path_m: np.ndarray) -> float:
    """Duration (s) of a transit polyline ``path_m`` (P, 2), each leg at the speed the
    export commands it (:func:`.speeds.transit_speeds`: in wind, what the vehicle's top
    airspeed leaves along its course), without its accelerations."""
    d = np.diff(np.asarray(path_m, dtype=float), axis=0)
    if not len(d):
        return 0.0
    autopilot, timing_params = timed_for(mission.solution, mission.options)
    speeds = transit_speeds(path_m, mission.solution.site, autopilot, timing_params,
                            mission.plan.cruise_speed_mps, mission.options.leg_speed_caps)
    return float(np.sum(np.hypot(d[:, 0], d[:, 1]) / speeds))


def mission_summary(mission: Mission) -> dict[str, object]:
    """The mission part of the report: items, cycle duration, transits, fence, expanded radii."""
    plan = mission.plan
    site = mission.solution.site
    sol = mission.solution
    first, last = mission.cycle_items
    cycle_s = cycle_duration_s(mission)
    speeds = [it.params[1] for it in plan.items if it.command == Cmd.DO_CHANGE_SPEED]
    service_speeds = [s.speed_mps for s in mission.steps if s.speed_mps is not None]
    planned_hold = float(sum(s.hold_s for s in mission.steps))
    holds = [it.params[0] if it.command == Cmd.NAV_WAYPOINT else 0.0 for it in plan.items]
    written_hold = float(sum(holds[first:last + 1]))
    # the transits' holds as written: PX4's stops where a swing would reach a buffer
    transit_hold = float(sum(holds[:first]) + sum(holds[last + 1:]))
    exp = (expanded_radius(site.planning_radius_m[None, :],
                           (site.max_speed_mps * sol.delta_s)[:, None])
           if site.num_nfzs else np.zeros((0, 0)))
    legs = flown_legs(plan, site)
    clearance = (segment_point_distance(legs[:, None, 0, :], legs[:, None, 1, :],
                                        site.nfz_xy_m[None]) - site.nfz_radius_m[None, :]
                 if site.num_nfzs and len(legs) else np.zeros((0, 0)))
    if site.polygon_zones and len(legs):
        poly_clr = np.array([[leg_clearance_m(z, a, b) for z in site.polygon_zones]
                             for a, b in legs])
        clearance = np.hstack([clearance.reshape(len(legs), -1), poly_clr])
    out_len = path_length_m(mission.outbound_m)
    ret_len = path_length_m(mission.return_m)
    out = {
        "autopilot": mission.options.autopilot,
        "items": len(plan.items),
        "service_waypoints": len(mission.steps),
        "service_waypoints_merged": mission.merged_waypoints,
        "scurve_legs": sum(s.scurve for s in mission.steps),
        # no hold, so the autopilot blends the corner (ArduPilot) instead of stopping there
        "waypoints_flown_through": sum(s.leg_s > 0 and s.hold_s <= 0 for s in mission.steps),
        "merge_offset_max_m": mission.merge_offset_m,
        "speed_changes": len(speeds),
        "cycle_items": [first, last],
        "cycles": mission.options.cycles,
        "period_s": site.period_s,
        "cycle_duration_s": cycle_s,
        "hold_planned_s": planned_hold,
        "hold_written_s": written_hold,
        "stop_lag_s": float(sum(s.stop_lag_s for s in mission.steps)),
        "max_service_speed_mps": max(service_speeds) if service_speeds else 0.0,
        "transit_speed_mps": plan.cruise_speed_mps,
        "transit_out_m": out_len,
        "transit_out_waypoints": len(mission.outbound_m) - 1,
        "transit_return_m": ret_len,
        "transit_return_waypoints": len(mission.return_m) - 1,
        "transit_hold_s": transit_hold,
        # nominal: no take-off, landing or accelerations (the replay's replayed_mission_s has)
        "mission_duration_s": (mission.options.cycles * cycle_s
                               + transit_s(mission, mission.outbound_m)
                               + transit_s(mission, mission.return_m) + transit_hold),
        "fence_margin_m": mission.fence_margin_m,
        "fence_radii_m": {n: float(r + mission.fence_margin_m)
                          for n, r in zip(site.nfz_names, site.nfz_radius_m, strict=True)},
        "operating_area": mission.options.operating_area,
        "expanded_radius_max_m": float(np.max(exp)) if exp.size else None,
        "expanded_radius_by_nfz_m": {n: float(np.max(exp[:, m]))
                                     for m, n in enumerate(site.nfz_names)} if exp.size else {},
        "nfz_clearance_min_m": float(np.min(clearance)) if clearance.size else None,
        "clearance_nudge_max_m": mission.max_nudge_m,
        "rally_points": len(plan.rally),
        "problems": list(mission.problems),
    }
    if site.polygon_zones:
        out |= _polygon_summary(mission, clearance)
    return out


def _polygon_summary(mission: Mission, clearance: np.ndarray) -> dict[str, object]:
    """Per polygon zone: its exclusion fence (vertices, area against the zone plus fence
    margin) and, for every zone, the least clearance of the flown legs (m)."""
    site = mission.solution.site
    frame = site.frame
    fences = {}
    for zone, fence in zip(site.polygon_zones, mission.plan.polygons, strict=False):
        lat = np.array([v[0] for v in fence.vertices_deg])
        lon = np.array([v[1] for v in fence.vertices_deg])
        held = shapely.Polygon(frame.to_local(lat, lon))
        fences[zone.name] = {
            "vertices": len(fence.vertices_deg),
            "area_m2": float(held.area),
            "zone_plus_margin_area_m2": float(zone.shape.buffer(mission.fence_margin_m,
                                                                quad_segs=64).area),
            "standoff_max_m": _standoff_m(held, zone.shape),
        }
    by_zone = ({n: float(np.min(clearance[:, m])) for m, n in enumerate(site.zone_names)}
               if clearance.size else {})
    return {"fence_polygons": fences, "nfz_clearance_by_zone_m": by_zone}


def _standoff_m(fence: shapely.Polygon, zone: shapely.Polygon) -> float:
    """How far (m) the fence's outline stands off the zone at most (sampled every 1 cm)."""
    ring = shapely.segmentize(fence.exterior, 0.01)
    pts = shapely.points(shapely.get_coordinates(ring))
    return float(np.max(shapely.distance(zone, pts)))
