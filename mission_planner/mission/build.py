"""A planned service cycle laid out as a QGroundControl plan: takeoff, transits, the cycle,
jumps, landing, fence and rally (:func:`build_mission`; the steps are in the package doc)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from mission_planner.mission.clearance import nudge_clear, safe_transits
from mission_planner.mission.fence import Geofence
from mission_planner.mission.gate import plan_problems
from mission_planner.mission.options import (
    AUTOPILOTS,
    MissionOptions,
    check_options,
    fence_margin_for,
    leg_margin_m,
)
from mission_planner.mission.speeds import (
    assign_speeds,
    capped_steps,
    stop_lags,
    transit_speeds,
    wind_speeds,
)
from mission_planner.mission.steps import (
    CycleStep,
    merge_straight_steps,
    place_on_legs,
    scurve_legs,
    service_steps,
    waypoint_steps,
)
from mission_planner.optimize.solution import Solution
from validator.autopilot.rules import programmed_holds_s
from validator.autopilot.waypoint_radius import radius_params
from validator.errors import InputError
from validator.item_numbers import item_number
from validator.motion.px4_swing import swing_keeps_buffer
from validator.motion.speed_model import cruise_speed_mps
from validator.plan_format import Cmd, Frame, MissionItem, Plan
from validator.position_loss import Berth
from validator.site import Site

_NAN = math.nan


@dataclass(frozen=True)
class Mission:
    """An exported mission and what went into it.

    ``trajectory_m`` (N+1, 2) is the service trajectory as exported (after any clearance
    nudge); ``outbound_m`` and ``return_m`` are the transit polylines (home → q[0], last
    waypoint → home); ``cycle_items`` the 0-based first and last item of the service cycle.
    ``problems`` lists every reason the safety gate refuses the mission (empty: safe).
    ``merged_waypoints`` is how many per-slot waypoints long straight legs replaced, and
    ``merge_offset_m`` the largest distance (m) a merged slot's end point moved onto its leg.
    ``position_loss_berth`` says how far the planner widened the site's buffer so that a GPS
    loss coasts clear of every zone (None: not widened).
    """

    plan: Plan
    solution: Solution
    options: MissionOptions
    trajectory_m: NDArray[np.float64]
    steps: tuple[CycleStep, ...]
    outbound_m: NDArray[np.float64]
    return_m: NDArray[np.float64]
    cycle_items: tuple[int, int]
    fence_margin_m: float
    operating_area_m: NDArray[np.float64] | None
    max_nudge_m: float
    problems: tuple[str, ...] = field(default_factory=tuple)
    merged_waypoints: int = 0
    merge_offset_m: float = 0.0
    # set when the planner widened the buffer for a GPS loss's coast (mission_planner.pipeline)
    position_loss_berth: Berth | None = None

    @property
    def safe(self) -> bool:
        return not self.problems


# The outbound transit's last stretch (m) flown at the service cycle's first speed, where that
# is slower (_entry_speed_mps)
APPROACH_M = 20.0
# A PX4 transit point whose swing would reach a zone's buffer holds this long (s): a stop, as
# the cycle's corners stop where theirs would (mission_planner.optimize.corners)
TRANSIT_STOP_S = 1.0


def _entry_speed_mps(steps: list[CycleStep], autopilot: str) -> float | None:
    """The speed the outbound transit must reach the cycle's start at, or None: the first
    leg's, for ArduCopter when the cycle starts with a leg. ArduCopter builds a leg's S-curve
    while the leg before it runs, at that leg's speed, and a DO_CHANGE_SPEED after the corner
    only partly slows it (:func:`validator.motion.corner_speed.corner_first_speeds_mps`):
    entered from a faster transit, the first leg would start fast and the first cycle come
    early. Commanded from a waypoint short of the start, the first leg is built at its own
    speed, and the cycle still starts flying."""
    if autopilot != "ardupilot" or not steps or steps[0].leg_s <= 0:
        return None
    return steps[0].speed_mps


def _nav(cmd: Cmd, lat: float, lon: float, alt: float, p1: float = 0.0) -> MissionItem:
    # param4 NaN: keep the current yaw (QGroundControl's default).
    return MissionItem(int(cmd), [p1, 0.0, 0.0, _NAN, lat, lon, alt],
                       int(Frame.GLOBAL_RELATIVE_ALT))


def _speed(speed_mps: float) -> MissionItem:
    # param1 1 = ground speed; param3 −1 = leave the throttle alone.
    return MissionItem(int(Cmd.DO_CHANGE_SPEED), [1.0, float(speed_mps), -1.0, 0.0, 0.0, 0.0, 0.0],
                       int(Frame.MISSION))


def _jump(target_item: int, repeats: int) -> MissionItem:
    # param1 is the target's item number (ArduPilot's seq, home being 0); the .plan writes
    # each item's number as its doJumpId, so QGroundControl reads the same target.
    return MissionItem(int(Cmd.DO_JUMP),
                       [float(item_number(target_item)), float(repeats), 0, 0, 0, 0, 0],
                       int(Frame.MISSION))


@dataclass(frozen=True)
class _Cycle:
    """The service cycle as it will be exported: trajectory (after nudges and with merged
    slots placed on their legs), waypoints with speeds, holds as written, and what moved."""

    trajectory_m: NDArray[np.float64]
    steps: list[CycleStep]
    holds_s: NDArray[np.float64]
    max_nudge_m: float
    merge_offset_m: float
    merged_waypoints: int
    problems: list[str]


def _swing_stops(path: NDArray[np.float64], site: Site, acceptance_m: float
                 ) -> NDArray[np.float64]:
    """(P,) the hold (s) of each point of a PX4 transit ``path`` (P, 2): :data:`TRANSIT_STOP_S`
    at an inner point whose swing region, at NAV_ACC_RAD ``acceptance_m``, reaches into a
    zone's buffer (:func:`validator.motion.px4_swing.swing_keeps_buffer`), else 0, so PX4
    stops there rather than flying through. A transit hugs the buffer round a zone, and on
    SIH PX4 swung out of such corners: 2.60 m from NFZ3 with a 3 m buffer."""
    holds = np.zeros(len(path))
    for j in range(1, len(path) - 1):
        if not swing_keeps_buffer(path[j - 1], path[j], path[j + 1], acceptance_m, site):
            holds[j] = TRANSIT_STOP_S
    return holds


def timed_for(solution: Solution, opt: MissionOptions) -> tuple[str, dict[str, float]]:
    """The autopilot and timing parameters the service cycle is laid out with: the options'
    autopilot, which must be the one a dynamics-aware plan was timed for (its
    :class:`~mission_planner.optimize.solution.VehicleTiming`), else :class:`InputError`: a
    cycle timed by one autopilot's motion model is late on the other."""
    timing = solution.timing
    if timing is None:
        return opt.autopilot, {}
    if timing.autopilot != opt.autopilot:
        raise InputError(
            f"autopilot: the plan was timed for {timing.autopilot!r} but the mission is built "
            f"for {opt.autopilot!r}; plan it again with autopilot {opt.autopilot!r}")
    return timing.autopilot, dict(timing.timing_params)


def _service_cycle(solution: Solution, opt: MissionOptions) -> _Cycle:
    """Slots grouped and merged into waypoints (:mod:`.steps`), nudged clear (:mod:`.clearance`),
    with speeds and holds the autopilot takes (:mod:`.speeds`)."""
    site = solution.site
    q = np.array(solution.trajectory_m, dtype=float)
    delta = np.asarray(solution.delta_s, dtype=float)
    if q.ndim != 2 or q.shape[1] != 2 or len(q) != len(delta) + 1 or len(delta) == 0:
        raise ValueError("solution: trajectory_m must be (N+1, 2) and delta_s (N,)")
    if np.hypot(*(q[-1] - q[0])) > opt.stationary_tol_m:
        raise ValueError("solution: trajectory is not closed (q[N] != q[0])")
    q[-1] = q[0]

    steps = service_steps(q, delta, opt.stationary_tol_m)
    autopilot, timing_params = timed_for(solution, opt)
    timed_speed = cruise_speed_mps(site, autopilot)
    radii = site.planning_radius_m
    target_m = leg_margin_m(site, opt)
    per_slot = len(steps)
    timing = solution.timing
    if timing is not None:
        steps = waypoint_steps(steps, timing.waypoint_slots, timed_speed)
    elif opt.merge_legs:
        steps = merge_straight_steps(
            steps, q, angle_deg=opt.merge_angle_deg, speed_rel=opt.merge_speed_rel,
            offset_m=opt.merge_offset_m, min_speed_mps=opt.min_speed_mps,
            nfz_xy_m=site.nfz_xy_m, nfz_radius_m=radii, clearance_target_m=target_m,
            zones=site.polygon_zones, zone_clearance_m=site.buffer_m,
            scurve=lambda lengths: scurve_legs(site, lengths, timed_speed, autopilot,
                                                     timing_params),
            scurve_speed_mps=timed_speed)
    cyc_idx = [0] + [s.index for s in steps if s.index not in (0, len(q) - 1)]
    pts, moved = nudge_clear(q[cyc_idx], site.nfz_xy_m, radii, target_margin_m=target_m,
                             max_nudge_m=opt.max_nudge_m, closed=True,
                             zones=site.polygon_zones, zone_clearance_m=site.buffer_m)
    planned_q = q.copy()
    q[cyc_idx] = pts
    q[-1] = q[0]
    q = place_on_legs(q, delta, steps)
    inner = [n for s in steps for n in s.slots[:s.moving_slots - 1]]
    merge_offset = (float(np.max(np.hypot(*(q[inner] - planned_q[inner]).T))) if inner else 0.0)
    if timing is not None and site.flight_wind is not None:
        steps = wind_speeds(steps, q, site, autopilot, timing_params, timed_speed)
    steps, problems = assign_speeds(steps, q, site.max_speed_mps, opt.min_speed_mps)
    steps = capped_steps(steps, q, opt.leg_speed_caps, lambda length_m, speed_mps: float(
        scurve_legs(site, [length_m], speed_mps, autopilot, timing_params).total_s[0]))
    if autopilot == "ardupilot" and timing is not None:
        steps = stop_lags(steps)
    holds = programmed_holds_s([s.hold_s - s.stop_lag_s for s in steps], opt.autopilot)
    return _Cycle(q, steps, holds, moved, merge_offset, per_slot - len(steps), problems)


def build_mission(solution: Solution, options: MissionOptions | None = None) -> Mission:
    """Lay out the mission of ``solution`` (see the package doc). Raises :class:`InputError`
    for bad options; unsafe geometry is not an exception but listed in ``Mission.problems``."""
    opt = options or MissionOptions()
    site = solution.site
    check_options(site, opt)
    frame = site.frame
    alt = site.altitude_m
    transit_speed = opt.transit_speed_mps or cruise_speed_mps(site, opt.autopilot)
    cycle = _service_cycle(solution, opt)
    q, steps, holds = cycle.trajectory_m, cycle.steps, cycle.holds_s
    delta = np.asarray(solution.delta_s, dtype=float)
    problems = list(cycle.problems)

    home = site.home_xy_m
    last = q[steps[-1].index] if steps else q[0]
    outbound, back = safe_transits(site, home, q[0], last, opt, problems)

    def latlon(xy: NDArray[np.float64]) -> tuple[float, float]:
        lat, lon = frame.to_geodetic(xy)
        return float(lat), float(lon)

    autopilot, timing_params = timed_for(solution, opt)
    margin = fence_margin_for(site, opt)
    # the NAV_ACC_RAD the parameter file sets (autopilot_params), which PX4 swings by
    acceptance_m = (radius_params(site, "px4", margin)["NAV_ACC_RAD"] if autopilot == "px4"
                    else None)

    def transit(path: NDArray[np.float64], to_land: bool,
                approach_mps: float | None = None) -> None:
        """The transit's speeds and waypoints, each leg at the speed it can hold in the wind
        (:func:`.speeds.transit_speeds`); with ``to_land`` the last leg's end is the LAND
        that follows, not a waypoint. ``approach_mps``: the speed the last leg ends at, where
        it is slower, over its last :data:`APPROACH_M` (at most half of it)."""
        current = None
        speeds = transit_speeds(path, site, autopilot, timing_params, transit_speed,
                                opt.leg_speed_caps)
        if approach_mps is not None and len(speeds) and (
                approach_mps < speeds[-1] - opt.speed_tol_mps):
            last = path[-1] - path[-2]
            length = float(np.hypot(*last))
            if length > opt.stationary_tol_m:  # else it reaches the start at rest
                cut = path[-1] - last / length * min(APPROACH_M, length / 2.0)
                path = np.vstack([path[:-1], cut, path[-1:]])
                speeds = np.append(speeds, approach_mps)
        stops = (np.zeros(len(path)) if acceptance_m is None
                 else _swing_stops(path, site, acceptance_m))
        for k, v in enumerate(speeds):
            if current is None or abs(v - current) > opt.speed_tol_mps:
                items.append(_speed(float(v)))
                current = float(v)
            if not (to_land and k == len(path) - 2):
                items.append(_nav(Cmd.NAV_WAYPOINT, *latlon(path[k + 1]), alt,
                                  p1=float(stops[k + 1])))
        if current is None:  # no leg at all (home is the cycle's end point)
            items.append(_speed(transit_speed))

    items: list[MissionItem] = []
    items.append(_nav(Cmd.NAV_TAKEOFF, *latlon(home), alt))
    transit(outbound, False, _entry_speed_mps(steps, autopilot))
    first = len(items)
    current: float | None = None
    for s, hold in zip(steps, holds, strict=True):
        if s.speed_mps is not None and (current is None or
                                        abs(s.speed_mps - current) > opt.speed_tol_mps):
            items.append(_speed(s.speed_mps))
            current = s.speed_mps
        items.append(_nav(Cmd.NAV_WAYPOINT, *latlon(q[s.index]), alt, p1=float(hold)))
    closing = len(items) - 1
    if opt.cycles > 1:
        items.append(_jump(first, opt.cycles - 1))
    transit(back, True)
    items.append(_nav(Cmd.NAV_LAND, *latlon(home), 0.0))

    fence = Geofence.around(site, margin, np.vstack([outbound, q, back]), opt.operating_area,
                            opt.operating_area_margin_m, ardupilot=opt.autopilot == "ardupilot")
    home_ll = latlon(home)
    plan = Plan(
        items=items,
        home_lat_deg=home_ll[0],
        home_lon_deg=home_ll[1],
        home_alt_m=frame.alt0_m,
        firmware_type=int(AUTOPILOTS[opt.autopilot]),
        cruise_speed_mps=float(transit_speed),
        hover_speed_mps=float(transit_speed),
        circles=fence.circles,
        polygons=fence.polygons,
        rally=[(home_ll[0], home_ll[1], alt)],
        breach_return=(home_ll[0], home_ll[1], alt),
        extra={
            "format": 1,
            "site": site.name,
            "scheme": solution.scheme,
            "trajectory_m": q.tolist(),
            "delta_s": [float(d) for d in delta],
            "power_w": [float(p) for p in solution.power_w],
            "schedule": [site.gn_names[k] if k >= 0 else None for k in solution.schedule],
            "cycle_items": [first, closing],
            "cycles": opt.cycles,
            **({"wind": site.wind.to_dict()} if site.wind is not None else {}),
        },
    )
    problems += plan_problems(plan, site)
    return Mission(
        plan=plan, solution=solution, options=opt, trajectory_m=q, steps=tuple(steps),
        outbound_m=outbound, return_m=back, cycle_items=(first, closing), fence_margin_m=margin,
        operating_area_m=fence.area_m, max_nudge_m=cycle.max_nudge_m, problems=tuple(problems),
        merged_waypoints=cycle.merged_waypoints, merge_offset_m=cycle.merge_offset_m,
    )
