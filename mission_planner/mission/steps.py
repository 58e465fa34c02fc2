"""The service cycle's waypoints: slots grouped into holds, straight runs merged into long legs.

**Long legs.** Slots merge into one leg only when flying the merged leg at its constant speed
puts the vehicle within ``merge_offset_m`` (5 cm) of the planned position at every instant
(checked at every slot boundary; in between both are linear in time, so the gap is largest at
a boundary), each slot's direction is within ``merge_angle_deg`` (1°) and its speed within
``merge_speed_rel`` (1 %) of the merged leg's, no slot in between holds, and the merged leg
keeps at least the NFZ clearance its slots had (or the export target). Slots a dynamics-aware
planner laid along the autopilot's own rest-to-rest S-curve (:func:`scurve_legs`: site V,
``uav.max_accel``, ``uav.max_jerk``) merge the same way, into one leg commanded at V: the
autopilot's acceleration and braking reproduce their timing. The exported ``nfzMission``
trajectory puts the merged slots' end points on the merged leg where the vehicle is when they
end (:func:`place_on_legs`), so the validator's throughput scoring maps the flown track to the
same slots.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from validator.geometry import segment_point_closest_fraction, segment_point_distance
from validator.motion.speed_model import LegMotion, leg_profiles
from validator.site import Site
from validator.zones import PolygonZone, path_clearances_m


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


def scurve_legs(site: Site, lengths_m: ArrayLike, speed_mps: float, autopilot: str,
                timing_params: Mapping[str, float]) -> LegMotion:
    """Rest-to-rest motion of straight legs flown at ``speed_mps`` within the site's limits,
    by ``autopilot``'s motion model with the parameters a dynamics-aware plan was timed with
    (:class:`~mission_planner.optimize.solution.VehicleTiming`; none: the model's defaults)."""
    return leg_profiles(site, lengths_m, speed_mps, autopilot, dict(timing_params))


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
                        target_m: float, zones: tuple[PolygonZone, ...] = (),
                        zone_clearance_m: float = 0.0) -> bool:
        """The chord at least as clear of each circle (beyond ``radii``) and each polygon zone
        (beyond ``zone_clearance_m``) as its slots were (or ``target_m``)."""
        if zones:
            slots = path_clearances_m(zones, np.vstack([self.start, self.ends]))
            chord = path_clearances_m(zones, np.array([self.start, self.ends[-1]]))[0]
            need = np.minimum(np.min(slots, axis=0) - zone_clearance_m, target_m)
            if np.any(chord - zone_clearance_m < need - 1e-12):
                return False
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
    zones: tuple[PolygonZone, ...] = (), zone_clearance_m: float = 0.0,
    scurve: Callable[[NDArray[np.float64]], LegMotion] | None = None,
    scurve_speed_mps: float | None = None, scurve_time_tol_s: float = 0.02,
) -> list[CycleStep]:
    """Merge consecutive slots on one straight line into one waypoint when one leg flies them.

    A run of slots (no hold before its end, every slot within ``angle_deg`` degrees of the
    run's chord and every end point within ``offset_m`` of it, the chord at least as clear of
    each NFZ as its slots, or ``clearance_target_m`` beyond the planning radius
    ``nfz_radius_m``, or beyond ``zone_clearance_m`` from each polygon of ``zones``) becomes
    one leg when a vehicle flying it is within ``offset_m`` (m) of the planned position at
    every slot boundary:

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
        return run.keeps_clearance(centres, radii, clearance_target_m, zones, zone_clearance_m)

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
        if len(run) == 1 and not is_scurve:
            out.append(run[0])
        else:
            # (a single slot timed as a rest-to-rest S-curve is still flown at V, not at L/δ)
            out.append(_one_leg(run, scurve_speed_mps if is_scurve else None, is_scurve))
        i = j
    return out


def waypoint_steps(steps: list[CycleStep], waypoint_slots: Sequence[int],
                   speed_mps: float) -> list[CycleStep]:
    """The steps merged into the waypoints a dynamics-aware plan was timed with.

    ``waypoint_slots`` are the trajectory indices at which the planner's cycle reaches each of
    its waypoints (``solution.timing.waypoint_slots``); the moving slots up to one of them
    become one leg flown at ``speed_mps`` (the autopilot's own motion, which the planner laid
    the slots along: ``scurve``). A waypoint the plan passes through has no hold, so the
    autopilot blends it as the planner timed it (:mod:`mission_planner.optimize.corners`).
    Timing is unchanged, as in :func:`merge_straight_steps`.
    """
    marks = set(int(i) for i in waypoint_slots)
    out: list[CycleStep] = []
    run: list[CycleStep] = []

    def flush() -> None:
        if not run:
            return
        if len(run) == 1 and run[0].leg_s <= 0:
            out.append(run[0])
        else:
            out.append(_one_leg(run, speed_mps, True))
        run.clear()

    for s in steps:
        if s.leg_s <= 0:  # a hold at q[0] before the first move
            flush()
            run.append(s)
            flush()
            continue
        run.append(s)
        if s.slots[0] in marks or s.hold_s > 0:
            flush()
    flush()
    return out


def _one_leg(run: list[CycleStep], speed_mps: float | None, scurve: bool) -> CycleStep:
    """Consecutive moving steps as one leg to the last one's waypoint: their slots flown along
    it, its hold after, their leg times summed (timing unchanged)."""
    moving = tuple(s.slots[0] for s in run)
    return CycleStep(run[-1].index, (*moving, *run[-1].slots[1:]),
                     float(sum(s.leg_s for s in run)), run[-1].hold_s, speed_mps=speed_mps,
                     moving_slots=len(run), scurve=scurve)


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
