"""A planned service cycle turned into an autopilot-ready mission.

:func:`build_mission` takes a :class:`~mission_planner.optimize.solution.Solution` and lays
out a QGroundControl :class:`~validator.plan_format.Plan`:

1. NAV_TAKEOFF at home to the site altitude (relative-altitude frame 3);
2. DO_CHANGE_SPEED to the transit speed and the outbound transit: the shortest path from home
   to q[0] whose straight legs keep out of every NFZ plus its buffer (:mod:`.transit`);
3. one service cycle: for each slot n a DO_CHANGE_SPEED (param1 = 1, param2 = leg length /
   δ[n] m/s) where the speed changes and a NAV_WAYPOINT at q[n]. Slots in which the UAV stays
   put (within ``stationary_tol_m``) merge into the waypoint before them, whose hold is their
   δ sum; slots at the start of the cycle in which it stays put become a hold at q[0];
   consecutive slots on one straight line at one speed become one waypoint
   (:func:`merge_straight_steps`), so waypoints stand only where the path turns or the speed
   changes: fewer corners for the autopilot to round off and fewer rest-to-rest legs;
4. DO_JUMP back to the cycle's first item ``cycles − 1`` times;
5. DO_CHANGE_SPEED to the transit speed, the return transit, NAV_LAND at home. Never RTL:
   it flies straight home whatever lies between.

The geofence holds one exclusion circle per NFZ (radius R + fence margin), optionally an
inclusion polygon or circle around everything the vehicle flies, the breach return point and
one rally point at home.

Decisions where autopilots and the plan disagree (all in :class:`MissionOptions`):

- **Clearance after rounding.** The optimiser keeps legs R + buffer away only up to solver
  tolerance, and MAVLink's int32 1e-7° coordinates move each point by up to ~0.8 cm. Each
  service leg closer than R + buffer + ``export_margin_m`` (1 cm) to a centre is pushed out
  by translating its two waypoints away from that centre by the shortfall, repeated until
  every leg clears; shortfalls above ``max_nudge_m`` (5 cm) are not solver noise and are left
  for the safety check to refuse. Transits are planned around R + buffer + the same margin.
  The plan is then re-read from rounded coordinates and every leg must stay at least
  R + buffer − 1 mm from each centre; :func:`validator.audit.audit` must find no violation
  either. What fails is listed in ``Mission.problems`` (plan-mission's safety gate).
- **Whole-second holds.** ArduCopter stores a waypoint hold as whole seconds (it truncates).
  For ArduPilot holds are rounded by error diffusion along the cycle (each hold is the
  rounded running sum minus the previous rounded running sum), so no hold is off by a second
  or more and the cycle's total hold differs from the plan by less than half a second; the
  summary reports the difference. PX4 keeps fractional holds.
- **Stop lag.** ArduCopter reaches a waypoint it stops at
  :data:`validator.dynamics.STOP_LAG_S` after the S-curve ends. A dynamics-aware plan
  (``solution.notes["dynamics"] == "vehicle"``) counts that lag as the start of the waypoint's
  hover (:mod:`mission_planner.optimize.retime`), so on ArduPilot each stop's hold is written
  net of it (``CycleStep.stop_lag_s``) and the cycle still lasts T.
- **Slow legs.** ArduCopter ignores a DO_CHANGE_SPEED below 0.2 m/s (WPNAV_WP_SPEED_MIN), so
  a leg that would need less is flown at ``min_speed_mps`` and the waypoint holds for the
  rest of its slot: the slot keeps its length and the UAV ends it at the same place.
- **Speed limit.** A leg speed never exceeds the site's V: float excess is clipped (the leg
  then takes a hair longer than δ); an excess above 1 % is reported as a problem. S-curve legs
  and transits fly at V or the vehicle's real top speed, whichever is lower
  (:func:`mission_planner.optimize.retime.cruise_speed_mps`).
- **Long legs.** Slots merge into one leg only when flying the merged leg at its constant
  speed puts the vehicle within ``merge_offset_m`` (5 cm) of the planned position at every
  instant (checked at every slot boundary; in between both are linear in time, so the gap is
  largest at a boundary), each slot's direction is within ``merge_angle_deg`` (1°) and its
  speed within ``merge_speed_rel`` (1 %) of the merged leg's, no slot in between holds, and the
  merged leg keeps at least the NFZ clearance its slots had (or the export target). Slots a
  dynamics-aware planner laid along the autopilot's own rest-to-rest S-curve
  (:func:`scurve_legs`: site V, ``uav.max_accel``, ``uav.max_jerk``) merge the same way, into
  one leg commanded at V: the autopilot's acceleration and braking reproduce their timing.
  The exported ``nfzMission`` trajectory puts the merged slots' end points on the merged leg
  where the vehicle is when they end, so the validator's throughput scoring maps the flown
  track to the same slots.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from mission_planner.optimize.retime import LegMotion, cruise_speed_mps, leg_profiles
from mission_planner.optimize.solution import Solution
from mission_planner.transit import DEFAULT_ARC_STEP_DEG, path_length_m, shortest_safe_path
from validator.audit import audit
from validator.dynamics import STOP_LAG_S
from validator.errors import InputError
from validator.geodesy import LocalFrame, round_e7
from validator.geometry import (
    expanded_radius,
    segment_point_closest_fraction,
    segment_point_distance,
)
from validator.plan_format import (
    EXTRA_KEY,
    Autopilot,
    Cmd,
    FenceCircle,
    FencePolygon,
    Frame,
    MissionItem,
    Plan,
)
from validator.site import Site

AUTOPILOTS = {"ardupilot": Autopilot.ARDUPILOTMEGA, "px4": Autopilot.PX4}
OPERATING_AREAS = ("polygon", "circle")
CLEARANCE_TOLERANCE_M = 1e-3  # a leg may come this much closer than R + buffer (issue item 4)
SPEED_EXCESS_ALLOWED = 0.01  # relative excess over V clipped silently (solver tolerance)
NAV_POSITION_COMMANDS = (Cmd.NAV_TAKEOFF, Cmd.NAV_WAYPOINT, Cmd.NAV_LAND)
_NAN = math.nan


@dataclass(frozen=True)
class MissionOptions:
    """How to lay out the mission; every length in metres, speed in m/s, time in seconds.

    ``fence_margin_m`` None means half the site's safety buffer. ``operating_area`` None, or
    "polygon" (buffered convex hull) / "circle" (bounding circle) around everything flown,
    ``operating_area_margin_m`` outside it. ``transit_speed_mps`` None means the site's V.
    ``merge_legs`` False keeps one waypoint per moving slot (the paper's layout); otherwise
    straight runs merge within ``merge_angle_deg`` (degrees), ``merge_speed_rel`` (fraction)
    and ``merge_offset_m`` (see :func:`merge_straight_steps`).
    """

    autopilot: str = "ardupilot"
    cycles: int = 1
    fence_margin_m: float | None = None
    operating_area: str | None = None
    operating_area_margin_m: float = 20.0
    transit_speed_mps: float | None = None
    export_margin_m: float = 0.01
    max_nudge_m: float = 0.05
    stationary_tol_m: float = 0.05
    min_speed_mps: float = 0.2
    speed_tol_mps: float = 1e-3
    arc_step_deg: float = DEFAULT_ARC_STEP_DEG
    merge_legs: bool = True
    merge_angle_deg: float = 1.0
    merge_speed_rel: float = 0.01
    merge_offset_m: float = 0.05


@dataclass(frozen=True)
class CycleStep:
    """One NAV_WAYPOINT of the service cycle.

    ``index`` is the trajectory index of its position, ``slots`` the 1-based slots it covers,
    ``leg_s`` the planned time of the leg into it (δ of its moving slot, 0 for a hold at q[0]),
    ``hold_s`` the planned hold (δ of the stationary slots after it, plus any time a slow leg
    saves). ``speed_mps`` is filled in once the geometry is final; None for a hold at q[0].
    The first ``moving_slots`` of ``slots`` are flown along the leg (more than one when
    straight slots were merged; 0 for a hold at q[0]); the rest are the hold. ``scurve``: the
    leg is timed as the autopilot's rest-to-rest S-curve at ``speed_mps`` (its top speed), not
    flown at ``speed_mps`` throughout. ``stop_lag_s``: the part of ``hold_s`` the autopilot
    spends arriving (see the module doc), not written into the hold.
    """

    index: int
    slots: tuple[int, ...]
    leg_s: float
    hold_s: float
    speed_mps: float | None = None
    moving_slots: int = 1
    scurve: bool = False
    stop_lag_s: float = 0.0


@dataclass(frozen=True)
class Mission:
    """An exported mission and what went into it.

    ``trajectory_m`` (N+1, 2) is the service trajectory as exported (after any clearance
    nudge); ``outbound_m`` and ``return_m`` are the transit polylines (home → q[0], last
    waypoint → home); ``cycle_items`` the 0-based first and last item of the service cycle.
    ``problems`` lists every reason the safety gate refuses the mission (empty: safe).
    ``merged_waypoints`` is how many per-slot waypoints long straight legs replaced, and
    ``merge_offset_m`` the largest distance (m) a merged slot's end point moved onto its leg.
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

    @property
    def safe(self) -> bool:
        return not self.problems


def check_options(site: Site, options: MissionOptions) -> None:
    """Refuse option values that cannot give a sensible mission (:class:`InputError`)."""
    if options.autopilot not in AUTOPILOTS:
        raise InputError(
            f"autopilot: expected one of {', '.join(AUTOPILOTS)}, got {options.autopilot!r}")
    if options.cycles < 1:
        raise InputError(f"cycles: must be >= 1, got {options.cycles}")
    margin = fence_margin_for(site, options)
    if margin < 0:
        raise InputError(f"fence_margin_m: must be >= 0, got {margin:g}")
    if margin > site.buffer_m:
        raise InputError(
            f"fence_margin_m: {margin:g} m is larger than the planned clearance (safety buffer "
            f"{site.buffer_m:g} m): the planned legs would breach the fence"
        )
    if options.operating_area not in (None, *OPERATING_AREAS):
        raise InputError(
            f"operating_area: expected one of {', '.join(OPERATING_AREAS)}, "
            f"got {options.operating_area!r}")
    if not options.operating_area_margin_m > 0:
        raise InputError(
            f"operating_area_margin_m: must be > 0, got {options.operating_area_margin_m:g}")
    if options.transit_speed_mps is not None and not (
        0 < options.transit_speed_mps <= site.max_speed_mps
    ):
        raise InputError(
            f"transit_speed_mps: must be in (0, {site.max_speed_mps:g}], "
            f"got {options.transit_speed_mps:g}")
    if not 0 <= options.min_speed_mps < site.max_speed_mps:
        raise InputError(f"min_speed_mps: must be in [0, V), got {options.min_speed_mps:g}")
    for name in ("export_margin_m", "max_nudge_m", "stationary_tol_m", "speed_tol_mps",
                 "arc_step_deg", "merge_angle_deg", "merge_speed_rel", "merge_offset_m"):
        if not getattr(options, name) >= 0:
            raise InputError(f"{name}: must be >= 0, got {getattr(options, name)}")


def fence_margin_for(site: Site, options: MissionOptions) -> float:
    """The fence margin (m) outside each NFZ radius: the option, else half the buffer."""
    return site.buffer_m / 2.0 if options.fence_margin_m is None else float(options.fence_margin_m)


# ---------------------------------------------------------------------------- service cycle


def service_steps(trajectory_m: ArrayLike, delta_s: ArrayLike,
                  stationary_tol_m: float) -> list[CycleStep]:
    """Group the slots of a closed trajectory into the waypoints of one service cycle.

    A slot whose end point lies within ``stationary_tol_m`` of the position its group started
    from adds its δ to the group's hold; any other slot starts a new waypoint at its end point.
    Groups end at their last slot's end point, so the last waypoint is q[N] = q[0]. Slots at
    the start of the cycle in which the UAV stays put become a hold-only waypoint at q[0].
    """
    q = np.asarray(trajectory_m, dtype=float)
    delta = np.asarray(delta_s, dtype=float)
    steps: list[CycleStep] = []
    start = q[0]  # where the current group started
    lead: list[int] = []
    for n in range(1, len(q)):
        d = float(delta[n - 1])
        if np.hypot(*(q[n] - start)) <= stationary_tol_m:
            if steps:
                s = steps[-1]
                steps[-1] = replace(s, index=n, slots=(*s.slots, n), hold_s=s.hold_s + d)
            else:
                lead.append(n)
            continue
        steps.append(CycleStep(n, (n,), d, 0.0))
        start = q[n]
    if lead:
        steps.insert(0, CycleStep(0, tuple(lead), 0.0, float(np.sum(delta[[n - 1 for n in lead]])),
                                  moving_slots=0))
    return steps


def scurve_legs(site: Site, lengths_m: ArrayLike, speed_mps: float,
                notes: Mapping[str, object] | None = None) -> LegMotion:
    """Rest-to-rest motion of straight legs flown at ``speed_mps`` within the site's limits,
    by the autopilot model and parameters a dynamics-aware plan was timed with (its solution's
    ``notes``: "autopilot", "timing_params"; default ArduCopter's S-curves)."""
    autopilot, params = _timing_of(notes)
    return leg_profiles(site, lengths_m, speed_mps, autopilot, params)


def _timing_of(notes: Mapping[str, object] | None) -> tuple[str, dict[str, float]]:
    """The autopilot and timing parameters a solution was re-timed with (its notes)."""
    notes = notes or {}
    autopilot = str(notes.get("autopilot", "ardupilot"))
    raw = notes.get("timing_params")
    params = {str(k): float(v) for k, v in raw.items()} if isinstance(raw, Mapping) else {}
    return autopilot, params


@dataclass(frozen=True)
class _Run:
    """Consecutive moving steps leaving ``start``: their end points, slot legs and times."""

    start: NDArray[np.float64]
    ends: NDArray[np.float64]
    leg_s: NDArray[np.float64]

    @classmethod
    def of(cls, q: NDArray[np.float64], start: NDArray[np.float64],
           run: list[CycleStep]) -> _Run | None:
        if any(s.leg_s <= 0 for s in run) or any(s.hold_s > 0 for s in run[:-1]):
            return None  # a hold-only step, or the vehicle stops inside the run
        return cls(start, q[[s.index for s in run]], np.array([s.leg_s for s in run]))

    @property
    def chord(self) -> NDArray[np.float64]:
        return np.asarray(self.ends[-1] - self.start, dtype=float)

    @property
    def length_m(self) -> float:
        return float(np.hypot(*self.chord))

    def slot_speeds(self) -> NDArray[np.float64]:
        legs = np.diff(np.vstack([self.start, self.ends]), axis=0)
        return np.asarray(np.hypot(legs[:, 0], legs[:, 1]) / self.leg_s, dtype=float)

    def is_straight(self, angle_deg: float, offset_m: float) -> bool:
        """Every slot within ``angle_deg`` of the chord's direction, every end point within
        ``offset_m`` of the chord."""
        length = self.length_m
        if length <= 0:
            return False
        legs = np.diff(np.vstack([self.start, self.ends]), axis=0)
        lengths = np.hypot(legs[:, 0], legs[:, 1])
        cos = (legs @ self.chord) / np.maximum(lengths * length, 1e-300)
        off = segment_point_distance(self.start, self.ends[-1], self.ends)
        return bool(np.all(cos >= math.cos(math.radians(angle_deg)))
                    and np.all(off <= offset_m))

    def flown_gap_m(self, along_m: NDArray[np.float64]) -> float:
        """Largest distance between the planned slot end points and where a vehicle is at the
        same times, ``along_m`` metres along the chord."""
        u = self.chord / self.length_m
        flown = self.start + along_m[:, None] * u[None, :]
        return float(np.max(np.hypot(*(flown - self.ends).T)))

    def keeps_clearance(self, centres: NDArray[np.float64], radii: NDArray[np.float64],
                        target_m: float) -> bool:
        """The chord at least as clear of each circle as its slots were (or ``target_m``)."""
        if not centres.size:
            return True
        starts = np.vstack([self.start, self.ends[:-1]])
        before = segment_point_distance(starts[:, None, :], self.ends[:, None, :], centres[None])
        after = segment_point_distance(self.start, self.ends[-1], centres) - radii
        need = np.minimum(np.min(before - radii[None, :], axis=0), target_m)
        return bool(np.all(after >= need - 1e-12))


def merge_straight_steps(
    steps: list[CycleStep], trajectory_m: ArrayLike, *, angle_deg: float = 1.0,
    speed_rel: float = 0.01, offset_m: float = 0.05, min_speed_mps: float = 0.0,
    nfz_xy_m: ArrayLike = (), nfz_radius_m: ArrayLike = (), clearance_target_m: float = 0.0,
    scurve: Callable[[NDArray[np.float64]], LegMotion] | None = None,
    scurve_speed_mps: float | None = None, scurve_time_tol_s: float = 0.02,
) -> list[CycleStep]:
    """Merge consecutive slots on one straight line into one waypoint when one leg flies them.

    A run of slots (no hold before its end, every slot within ``angle_deg`` degrees of the
    run's chord and every end point within ``offset_m`` of it, the chord at least as clear of
    each NFZ as its slots, or ``clearance_target_m`` beyond the planning radius
    ``nfz_radius_m``) becomes one leg when a vehicle flying it is within ``offset_m`` (m) of
    the planned position at every slot boundary:

    - **at one speed**: greedily from each waypoint, while every slot's speed is within
      ``speed_rel`` (fraction) of the chord's constant speed and at least ``min_speed_mps``;
      between boundaries both move linearly in time, so the boundaries bound the gap;
    - **as the autopilot's own S-curve**: the longest straight run from each waypoint, when
      ``scurve`` (lengths -> leg motion, e.g. :func:`scurve_legs`)
      flown at ``scurve_speed_mps`` from rest to rest matches the slots and arrives within
      ``scurve_time_tol_s`` of the plan: the planner timed the leg that way (dynamics-aware
      plans), so one waypoint with that speed replaces the speed changes between its slots.

    Timing is unchanged: a merged step's leg time is the sum of its slots' δ and its hold the
    last slot's. Never merges across q[0].
    """
    q = np.asarray(trajectory_m, dtype=float)
    centres = np.asarray(nfz_xy_m, dtype=float).reshape(-1, 2)
    radii = np.asarray(nfz_radius_m, dtype=float).reshape(-1)

    def clear(run: _Run) -> bool:
        return run.keeps_clearance(centres, radii, clearance_target_m)

    def one_speed(run: _Run) -> bool:
        speeds = run.slot_speeds()
        speed = run.length_m / float(np.sum(run.leg_s))
        return bool(
            np.all(speeds >= max(min_speed_mps, 1e-9))
            and np.all(np.abs(speeds - speed) <= speed_rel * speed)
            and run.is_straight(angle_deg, offset_m)
            and run.flown_gap_m(speed * np.cumsum(run.leg_s)) <= offset_m
            and clear(run)
        )

    def as_scurve(run: _Run) -> bool:
        if scurve is None or scurve_speed_mps is None:
            return False
        prof = scurve(np.array([run.length_m]))
        t = np.cumsum(run.leg_s)
        along, _, _ = prof.state(np.zeros(t.size, dtype=np.int64), t)
        return bool(abs(float(prof.total_s[0]) - t[-1]) <= scurve_time_tol_s
                    and run.flown_gap_m(along) <= offset_m and clear(run))

    def run_at(i: int, j: int) -> _Run | None:
        start = q[steps[i - 1].index] if i > 0 else q[0]
        return _Run.of(q, start, steps[i:j])

    def from_rest(i: int) -> bool:
        """Whether the plan may be at rest when step i starts: at q[0], after a hold or a
        corner (an S-curve leg cannot start inside a straight stretch)."""
        if i == 0 or steps[i - 1].hold_s > 0 or steps[i - 1].leg_s <= 0:
            return True
        before = run_at(i - 1, i + 1)
        return before is None or not before.is_straight(angle_deg, offset_m)

    out: list[CycleStep] = []
    i = 0
    while i < len(steps):
        j = i + 1
        longest = i + 1  # the longest straight run from i, for the S-curve test
        while scurve is not None and from_rest(i) and longest < len(steps):
            r = run_at(i, longest + 1)
            if r is None or not r.is_straight(angle_deg, offset_m):
                break
            longest += 1
        is_scurve = False
        if longest > i and (r := run_at(i, longest)) is not None and as_scurve(r):
            j, is_scurve = longest, True
        else:
            while j < len(steps) and (r := run_at(i, j + 1)) is not None and one_speed(r):
                j += 1
        run = steps[i:j]
        if len(run) == 1:
            # A single slot timed as a rest-to-rest S-curve is still flown at V, not at L/δ.
            out.append(replace(run[0], speed_mps=scurve_speed_mps, scurve=True) if is_scurve
                       else run[0])
        else:
            moving = tuple(s.slots[0] for s in run)
            out.append(CycleStep(run[-1].index, (*moving, *run[-1].slots[1:]),
                                 float(sum(s.leg_s for s in run)), run[-1].hold_s,
                                 speed_mps=scurve_speed_mps if is_scurve else None,
                                 moving_slots=len(moving), scurve=is_scurve))
        i = j
    return out


def place_on_legs(trajectory_m: ArrayLike, delta_s: ArrayLike,
                  steps: list[CycleStep]) -> NDArray[np.float64]:
    """The trajectory with each merged leg's inner slot end points on the leg where the
    vehicle is when the slot ends: at the leg's constant speed, start + (elapsed δ / leg
    time)·leg; on an S-curve leg, the point's own projection onto the leg."""
    q = np.array(trajectory_m, dtype=float)
    delta = np.asarray(delta_s, dtype=float)
    for s in steps:
        if s.moving_slots < 2:
            continue
        slots = np.array(s.slots[:s.moving_slots])
        start, end = q[slots[0] - 1], q[slots[-1]]
        if s.scurve:
            frac = segment_point_closest_fraction(start, end, q[slots[:-1]])
        else:
            frac = np.cumsum(delta[slots - 1])[:-1] / s.leg_s
        q[slots[:-1]] = start + np.asarray(frac)[:, None] * (end - start)
    return q


def nudge_clear(points_m: ArrayLike, centres_m: ArrayLike, radii_m: ArrayLike, *,
                target_margin_m: float, max_nudge_m: float,
                closed: bool = True) -> tuple[NDArray[np.float64], float]:
    """Push a polyline's points out so every leg keeps ``radii + target_margin_m`` from each centre.

    Only legs short of that by at most ``target_margin_m + max_nudge_m`` are moved: both their
    end points are translated away from the centre (along the normal through the leg's closest
    point) by the shortfall, which raises the leg's distance by at least as much; repeated
    until no leg is short. ``closed`` adds the leg from the last point back to the first.
    Returns the points and the largest distance any point moved (m).
    """
    pts = np.array(points_m, dtype=float)
    original = pts.copy()
    centres = np.asarray(centres_m, dtype=float).reshape(-1, 2)
    target = np.asarray(radii_m, dtype=float).reshape(-1) + target_margin_m
    if centres.size == 0 or len(pts) < 2:
        return pts, 0.0
    limit = target_margin_m + max_nudge_m
    for _ in range(100):
        a = pts
        b = np.roll(pts, -1, axis=0) if closed else pts[1:]
        a = a if closed else pts[:-1]
        d = segment_point_distance(a[:, None, :], b[:, None, :], centres[None, :, :])
        short = target[None, :] - d
        fix = (short > 1e-9) & (short <= limit)
        if not np.any(fix):
            break
        move = np.zeros_like(pts)
        for k, m in zip(*np.nonzero(fix), strict=True):
            t = float(segment_point_closest_fraction(a[k], b[k], centres[m]))
            closest = a[k] + t * (b[k] - a[k])
            u = closest - centres[m]
            norm = float(np.hypot(*u))
            u = u / norm if norm > 0 else np.array([1.0, 0.0])
            push = (short[k, m] + 1e-6) * u
            j = (k + 1) % len(pts) if closed else k + 1
            for idx in (k, j):
                if np.dot(move[idx], u) < np.dot(push, u):
                    move[idx] += push - np.dot(move[idx], u) * u
        pts = pts + move
    moved = float(np.max(np.linalg.norm(pts - original, axis=1)))
    return pts, moved


def assign_speeds(steps: list[CycleStep], trajectory_m: NDArray[np.float64], max_speed_mps: float,
                  min_speed_mps: float) -> tuple[list[CycleStep], list[str]]:
    """Fill in each step's leg speed (m/s) from the final geometry.

    speed = leg length / leg time, clipped to ``max_speed_mps``; a leg slower than
    ``min_speed_mps`` is flown at that speed and the step holds for the time saved; an
    S-curve leg keeps its top speed. Returns the steps and a problem for each leg whose speed
    exceeds V by more than 1 %.
    """
    out: list[CycleStep] = []
    problems: list[str] = []
    prev = trajectory_m[0]
    for s in steps:
        here = trajectory_m[s.index]
        length = float(np.hypot(*(here - prev)))
        prev = here
        if s.leg_s <= 0:
            out.append(replace(s, leg_s=0.0, speed_mps=None))
            continue
        speed = s.speed_mps if s.scurve and s.speed_mps is not None else length / s.leg_s
        hold = s.hold_s
        if speed > max_speed_mps:
            if speed > max_speed_mps * (1 + SPEED_EXCESS_ALLOWED):
                problems.append(
                    f"slot {s.slots[0]}: leg of {length:.2f} m in {s.leg_s:.3f} s needs "
                    f"{speed:.2f} m/s, above the vehicle's {max_speed_mps:g} m/s")
            speed = max_speed_mps
        elif speed < min_speed_mps:
            hold += s.leg_s - length / min_speed_mps
            speed = min_speed_mps
        out.append(replace(s, hold_s=hold, speed_mps=speed))
    return out, problems


def stop_lags(steps: list[CycleStep]) -> list[CycleStep]:
    """The steps with ArduCopter's stop lag (:data:`validator.dynamics.STOP_LAG_S`) taken
    out of the hold of every waypoint the vehicle stops at after a leg (one that holds longer
    than the lag); hold-only steps and pass-through waypoints arrive without it."""
    return [replace(s, stop_lag_s=STOP_LAG_S)
            if s.speed_mps is not None and s.leg_s > 0 and s.hold_s > STOP_LAG_S else s
            for s in steps]


def whole_second_holds(holds_s: ArrayLike) -> NDArray[np.float64]:
    """Holds (s) rounded to whole seconds by error diffusion along the sequence.

    Hold k becomes round(Σ_{i≤k} h_i) − round(Σ_{i<k} h_i): never negative, zero where the
    planned hold is zero, and the total stays within half a second of the planned total.
    """
    cum = np.cumsum(np.asarray(holds_s, dtype=float))
    rounded = np.floor(cum + 0.5)
    return np.diff(np.concatenate([[0.0], rounded]))


# ---------------------------------------------------------------------------- items


def _nav(cmd: Cmd, lat: float, lon: float, alt: float, p1: float = 0.0) -> MissionItem:
    # param4 NaN: keep the current yaw (QGroundControl's default).
    return MissionItem(int(cmd), [p1, 0.0, 0.0, _NAN, lat, lon, alt],
                       int(Frame.GLOBAL_RELATIVE_ALT))


def _speed(speed_mps: float) -> MissionItem:
    # param1 1 = ground speed; param3 −1 = leave the throttle alone.
    return MissionItem(int(Cmd.DO_CHANGE_SPEED), [1.0, float(speed_mps), -1.0, 0.0, 0.0, 0.0, 0.0],
                       int(Frame.MISSION))


def _jump(target_item: int, repeats: int) -> MissionItem:
    # param1 is the target's doJumpId (1-based item number; ArduPilot's seq, home being 0).
    return MissionItem(int(Cmd.DO_JUMP), [float(target_item + 1), float(repeats), 0, 0, 0, 0, 0],
                       int(Frame.MISSION))


def operating_area(points_m: ArrayLike, kind: str, margin_m: float) -> NDArray[np.float64]:
    """Vertices (V, 2), not closed, of an inclusion zone ``margin_m`` around the points.

    "polygon": the convex hull grown by the margin (mitred corners, bevelled when sharp), so
    the zone stays convex and every leg between points inside it stays inside. "circle": the
    smallest enclosing circle grown by the margin, returned as [[cx, cy], [radius, 0]].
    """
    hull = shapely.MultiPoint(np.asarray(points_m, dtype=float)).convex_hull
    if kind == "circle":
        radius = float(shapely.minimum_bounding_radius(hull))
        centre = shapely.minimum_bounding_circle(hull).centroid
        if radius == 0.0:
            centre = hull.centroid
        return np.array([[centre.x, centre.y], [radius + margin_m, 0.0]])
    # Simplifying a convex polygon keeps a subset of its vertices: still convex, and inside the
    # buffered hull by at most a quarter of the margin, so far fewer fence points suffice.
    area = hull.buffer(margin_m, join_style="mitre", mitre_limit=2.0).simplify(margin_m / 4.0)
    ring = shapely.get_coordinates(shapely.normalize(area).exterior)[:-1]
    return np.asarray(ring, dtype=float)


def build_mission(solution: Solution, options: MissionOptions | None = None) -> Mission:
    """Lay out the mission of ``solution`` (see the module doc). Raises :class:`InputError`
    for bad options; unsafe geometry is not an exception but listed in ``Mission.problems``."""
    opt = options or MissionOptions()
    site = solution.site
    check_options(site, opt)
    frame = site.frame
    alt = site.altitude_m
    transit_speed = opt.transit_speed_mps or cruise_speed_mps(site)
    problems: list[str] = []

    q = np.array(solution.trajectory_m, dtype=float)
    delta = np.asarray(solution.delta_s, dtype=float)
    if q.ndim != 2 or q.shape[1] != 2 or len(q) != len(delta) + 1 or len(delta) == 0:
        raise ValueError("solution: trajectory_m must be (N+1, 2) and delta_s (N,)")
    if np.hypot(*(q[-1] - q[0])) > opt.stationary_tol_m:
        raise ValueError("solution: trajectory is not closed (q[N] != q[0])")
    q[-1] = q[0]

    steps = service_steps(q, delta, opt.stationary_tol_m)
    timed_speed = cruise_speed_mps(site, _timing_of(solution.notes)[0])
    radii = site.planning_radius_m
    per_slot = len(steps)
    if opt.merge_legs:
        steps = merge_straight_steps(
            steps, q, angle_deg=opt.merge_angle_deg, speed_rel=opt.merge_speed_rel,
            offset_m=opt.merge_offset_m, min_speed_mps=opt.min_speed_mps,
            nfz_xy_m=site.nfz_xy_m, nfz_radius_m=radii, clearance_target_m=opt.export_margin_m,
            scurve=lambda lengths: scurve_legs(site, lengths, timed_speed, solution.notes),
            scurve_speed_mps=timed_speed)
    cyc_idx = [0] + [s.index for s in steps if s.index not in (0, len(q) - 1)]
    pts, moved = nudge_clear(q[cyc_idx], site.nfz_xy_m, radii, target_margin_m=opt.export_margin_m,
                             max_nudge_m=opt.max_nudge_m, closed=True)
    planned_q = q.copy()
    q[cyc_idx] = pts
    q[-1] = q[0]
    q = place_on_legs(q, delta, steps)
    inner = [n for s in steps for n in s.slots[:s.moving_slots - 1]]
    merge_offset = (float(np.max(np.hypot(*(q[inner] - planned_q[inner]).T))) if inner else 0.0)
    steps, speed_problems = assign_speeds(steps, q, site.max_speed_mps, opt.min_speed_mps)
    problems += speed_problems
    if opt.autopilot == "ardupilot":
        if solution.notes.get("dynamics") == "vehicle":
            steps = stop_lags(steps)
        holds = whole_second_holds([s.hold_s - s.stop_lag_s for s in steps])
    else:
        holds = np.array([s.hold_s for s in steps])

    home = site.home_xy_m
    last = q[steps[-1].index] if steps else q[0]
    outbound, back = _transits(site, home, q[0], last, opt, problems)

    def latlon(xy: NDArray[np.float64]) -> tuple[float, float]:
        lat, lon = frame.to_geodetic(xy)
        return float(lat), float(lon)

    items: list[MissionItem] = []
    items.append(_nav(Cmd.NAV_TAKEOFF, *latlon(home), alt))
    items.append(_speed(transit_speed))
    for p in outbound[1:]:
        items.append(_nav(Cmd.NAV_WAYPOINT, *latlon(p), alt))
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
    items.append(_speed(transit_speed))
    for p in back[1:-1]:
        items.append(_nav(Cmd.NAV_WAYPOINT, *latlon(p), alt))
    items.append(_nav(Cmd.NAV_LAND, *latlon(home), 0.0))

    margin = fence_margin_for(site, opt)
    circles = [
        FenceCircle(*latlon(c), float(r + margin), inclusion=False)
        for c, r in zip(site.nfz_xy_m, site.nfz_radius_m, strict=True)
    ]
    polygons: list[FencePolygon] = []
    area: NDArray[np.float64] | None = None
    if opt.operating_area is not None:
        flown = np.vstack([outbound, q, back])
        area = operating_area(flown, opt.operating_area, opt.operating_area_margin_m)
        if opt.operating_area == "circle":
            circles.append(FenceCircle(*latlon(area[0]), float(area[1, 0]), inclusion=True))
        else:
            lat, lon = frame.to_geodetic(area)
            vertices = [(float(a), float(b)) for a, b in zip(lat, lon, strict=True)]
            polygons.append(FencePolygon(vertices, inclusion=True))
    home_ll = latlon(home)
    plan = Plan(
        items=items,
        home_lat_deg=home_ll[0],
        home_lon_deg=home_ll[1],
        home_alt_m=frame.alt0_m,
        firmware_type=int(AUTOPILOTS[opt.autopilot]),
        cruise_speed_mps=float(transit_speed),
        hover_speed_mps=float(transit_speed),
        circles=circles,
        polygons=polygons,
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
        },
    )
    problems += plan_problems(plan, site, (first, closing))
    # The validator's own verdict too: never emit what validate-mission would reject.
    problems += [f"validator: {f.message}" for f in audit(plan, site).violations]
    return Mission(
        plan=plan, solution=solution, options=opt, trajectory_m=q, steps=tuple(steps),
        outbound_m=outbound, return_m=back, cycle_items=(first, closing), fence_margin_m=margin,
        operating_area_m=area, max_nudge_m=moved, problems=tuple(problems),
        merged_waypoints=per_slot - len(steps), merge_offset_m=merge_offset,
    )


def _transits(site: Site, home: NDArray[np.float64], start: NDArray[np.float64],
              end: NDArray[np.float64], opt: MissionOptions,
              problems: list[str]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Outbound (home → start) and return (end → home) transits around R + buffer + margin.

    A zone's radius is shrunk to the distance of an end point that lies closer than that, so
    the search can start there; the safety check judges whether that is still clear enough.
    """
    centres = site.nfz_xy_m
    ends = np.array([home, start, end])

    def radii_for(pair: NDArray[np.float64]) -> NDArray[np.float64]:
        r = site.planning_radius_m + opt.export_margin_m
        if centres.size == 0:
            return r
        d = np.min(np.linalg.norm(pair[:, None, :] - centres[None, :, :], axis=2), axis=0)
        return np.minimum(r, d * (1 - 1e-12))

    out = []
    for a, b, name in ((ends[0], ends[1], "outbound"), (ends[2], ends[0], "return")):
        try:
            out.append(shortest_safe_path(a, b, centres, radii_for(np.array([a, b])),
                                          arc_step_deg=opt.arc_step_deg))
        except ValueError as err:
            problems.append(f"{name} transit: {err}; flying straight instead")
            out.append(np.array([a, b]))
    return out[0], out[1]


# ---------------------------------------------------------------------------- checks


def nav_positions(plan: Plan, frame: LocalFrame, *, rounded: bool = True
                  ) -> tuple[list[int], NDArray[np.float64]]:
    """Item indices and local positions (m) of every positional mission item, in item order.

    ``rounded`` first puts the coordinates through MAVLink's int32 1e-7° representation.
    """
    idx = [i for i, it in enumerate(plan.items) if it.command in NAV_POSITION_COMMANDS]
    lat = np.array([plan.items[i].lat_deg for i in idx])
    lon = np.array([plan.items[i].lon_deg for i in idx])
    if rounded:
        lat, lon = round_e7(lat), round_e7(lon)
    return idx, frame.to_local(lat, lon).reshape(-1, 2)


def flown_legs(plan: Plan, frame: LocalFrame, cycle_items: tuple[int, int] | None = None, *,
               rounded: bool = True) -> tuple[list[tuple[int, int]], NDArray[np.float64]]:
    """Every straight leg the vehicle flies: consecutive positional items, plus, when the plan
    repeats its cycle with DO_JUMP, the leg from the cycle's last waypoint back to its first
    position. Returns (from item, to item) pairs and the legs as an (L, 2, 2) array in metres.
    """
    idx, xy = nav_positions(plan, frame, rounded=rounded)
    pairs = list(zip(idx[:-1], idx[1:], strict=True))
    legs = [np.array([xy[k], xy[k + 1]]) for k in range(len(idx) - 1)]
    has_jump = any(it.command == Cmd.DO_JUMP for it in plan.items)
    if cycle_items is not None and has_jump:
        first, last = cycle_items
        targets = [k for k, i in enumerate(idx) if i >= first]
        if targets and last in idx:
            k0, k1 = targets[0], idx.index(last)
            pairs.append((last, idx[k0]))
            legs.append(np.array([xy[k1], xy[k0]]))
    return pairs, np.array(legs).reshape(-1, 2, 2)


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


def planned_cycle_s(plan: Plan, frame: LocalFrame, cycle_items: tuple[int, int]) -> float:
    """Duration (s) of one service cycle at the plan's own speeds and holds, every leg at its
    commanded speed throughout (an S-curve leg takes longer: see :func:`cycle_duration_s`).

    Walks items ``first..last``: each positional item adds the leg from the previous position
    at the speed in force (the last DO_CHANGE_SPEED before it) plus its hold (param1). The
    cycle starts at the position before its first item (the end of the outbound transit).
    """
    first, last = cycle_items
    speed = math.nan
    pos: NDArray[np.float64] | None = None
    for it in plan.items[:first]:
        if it.command == Cmd.DO_CHANGE_SPEED:
            speed = it.params[1]
        elif it.command in NAV_POSITION_COMMANDS:
            pos = frame.to_local(it.lat_deg, it.lon_deg)
    total = 0.0
    for it in plan.items[first:last + 1]:
        if it.command == Cmd.DO_CHANGE_SPEED:
            speed = it.params[1]
        elif it.command in NAV_POSITION_COMMANDS:
            here = frame.to_local(it.lat_deg, it.lon_deg)
            length = float(np.hypot(*(here - pos))) if pos is not None else 0.0
            if length > 0:
                total += length / speed
            total += it.params[0] if it.command == Cmd.NAV_WAYPOINT else 0.0
            pos = here
    return total


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


def mission_summary(mission: Mission) -> dict[str, Any]:
    """The mission part of the report: items, cycle duration, transits, fence, expanded radii."""
    plan = mission.plan
    site = mission.solution.site
    sol = mission.solution
    first, last = mission.cycle_items
    cycle_s = cycle_duration_s(mission)
    speeds = [it.params[1] for it in plan.items if it.command == Cmd.DO_CHANGE_SPEED]
    service_speeds = [s.speed_mps for s in mission.steps if s.speed_mps is not None]
    planned_hold = float(sum(s.hold_s for s in mission.steps))
    written_hold = float(sum(plan.items[i].params[0] for i in range(first, last + 1)
                             if plan.items[i].command == Cmd.NAV_WAYPOINT))
    exp = (expanded_radius(site.planning_radius_m[None, :],
                           (site.max_speed_mps * sol.delta_s)[:, None])
           if site.num_nfzs else np.zeros((0, 0)))
    _, legs = flown_legs(plan, site.frame, mission.cycle_items, rounded=True)
    clearance = (segment_point_distance(legs[:, None, 0, :], legs[:, None, 1, :],
                                        site.nfz_xy_m[None]) - site.nfz_radius_m[None, :]
                 if site.num_nfzs and len(legs) else np.zeros((0, 0)))
    out_len = path_length_m(mission.outbound_m)
    ret_len = path_length_m(mission.return_m)
    return {
        "autopilot": mission.options.autopilot,
        "items": len(plan.items),
        "service_waypoints": len(mission.steps),
        "service_waypoints_merged": mission.merged_waypoints,
        "scurve_legs": sum(s.scurve for s in mission.steps),
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
        "mission_duration_s": (mission.options.cycles * cycle_s
                               + (out_len + ret_len) / plan.cruise_speed_mps),
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


__all__ = [
    "AUTOPILOTS",
    "EXTRA_KEY",
    "Mission",
    "MissionOptions",
    "CycleStep",
    "build_mission",
    "check_options",
    "cycle_duration_s",
    "flown_legs",
    "merge_straight_steps",
    "mission_summary",
    "nav_positions",
    "place_on_legs",
    "plan_problems",
    "planned_cycle_s",
    "scurve_legs",
    "service_steps",
    "stop_lags",
    "whole_second_holds",
]
