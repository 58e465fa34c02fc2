"""Flyable timing: re-time an optimised path the way a multicopter really flies it.

The paper's model lets the UAV jump between hovering and top speed. An autopilot flies each
leg between waypoints from rest to rest under its own rules, so a dash that the paper times at
V takes far longer, and the period T is overrun several times. This module keeps the optimised
path but flies it honestly, with the validator's own model of the autopilot
(:func:`validator.motion.speed_model.motion_profile`), so that the plan and its replay agree by
construction:

1. :func:`skeleton`: the path's corners and hover points become waypoints; straight stretches
   between them (Douglas-Peucker within ``tolerance_m``, chord by chord never closer to an
   NFZ than before) become single legs;
2. :func:`~validator.motion.speed_model.leg_profiles`: each leg is timed at the cruise speed
   (:func:`~validator.motion.speed_model.cruise_speed_mps`), never above the
   vehicle's real top speed: ArduCopter's jerk-limited S-curve (WPNAV_ACCEL capped by the lean
   angle, WPNAV_JERK with its jerk ramp), or PX4's braking rule and velocity smoothing, a leg
   ending when the vehicle is within NAV_ACC_RAD of the waypoint (PX4 starts the hold there);
3. ArduCopter flies through the corners that are not hover points where its blended turn keeps
   the buffer (:mod:`.corners`, the validator's corner model) and stops at the others;
   every ArduCopter stop costs its stop lag (:data:`validator.motion.arducopter.STOP_LAG_S`: it
   reaches the waypoint that long after the S-curve ends), counted as hover at the waypoint
   just reached (the exporter programs holds net of it); PX4 stops at every waypoint, and
   leaving one for a turn after a short hold it may crawl for seconds
   (:func:`px4_departures_s`), spent at the waypoint before the leg's motion; the time left
   in T goes to the hover points in proportion to the optimiser's holds;
4. :func:`resample`: N slots are laid on that timeline: boundaries at every arrival and
   departure, the rest spread over the moves, positions taken from the leg motion.

Schedule and power are then re-optimised on the re-timed trajectory by the caller. Positions
are metres east/north; times seconds.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from mission_planner.optimize.corners import (
    CycleMotion,
    blended_motion,
    path_clearance_m,
    px4_motion,
    stop_everywhere,
)
from mission_planner.optimize.simplify import douglas_peucker
from validator.autopilot.rules import STATIONARY_M, stored_hold_s
from validator.motion.arducopter import (
    STOP_LAG_S,
    scurve_limits,
)
from validator.motion.profile import Profile
from validator.motion.px4 import SampledLegs
from validator.motion.px4_mission import departure_lock_s, px4_top_speed_mps
from validator.motion.speed_model import (
    LegMotion,
    leg_profiles,
    motion_profile,
    scurve_speed_mps,
)
from validator.site import Site
from validator.zones import PolygonZone

HOVER_SLOT_DISCOUNT = 0.25
MIN_SLOT_MOVE_M = 0.1  # the first and last slot of a move travel at least this far
MIN_HOLD_S = 1.0  # every waypoint of a flyable plan holds this long at least (whole seconds)
SIMPLIFY_TOLERANCE_M = 50.0  # a bend smaller than this between hover points is flown straight
WHOLE_STRETCH_STEPS_M = (50.0, 25.0, 10.0, 5.0, 2.0, 1.0, 0.5, 0.2, 0.0)  # chordwise=False
# SIH's trajectory was 1.63-2.24 m short of a stop when PX4 counted it reached (ten stops, model
# 1.85 m): plans time the crawl for the long end (the replay keeps the model's, so may be early).
PX4_ARRIVAL_SPREAD = 1.2
PX4_CRAWL_ROUNDS = 8  # time_cycle's rounds to settle PX4's departure crawls with the holds


@dataclass(frozen=True)
class Skeleton:
    """Waypoints of a closed path: ``points_m`` (W, 2) and the hold at each (s).
    Leg w flies points[w] → points[w+1] (cyclic)."""

    points_m: NDArray[np.float64]
    hold_s: NDArray[np.float64]

    @property
    def leg_lengths_m(self) -> NDArray[np.float64]:
        """(W,) length of each leg, the last one back to the first waypoint."""
        nxt = np.roll(self.points_m, -1, axis=0)
        return np.asarray(np.linalg.norm(nxt - self.points_m, axis=1), dtype=float)

    @property
    def leg_units(self) -> NDArray[np.float64]:
        """(W, 2) each leg's direction (zeros for a leg of no length)."""
        d = np.roll(self.points_m, -1, axis=0) - self.points_m
        length = np.linalg.norm(d, axis=1)
        return np.divide(d, length[:, None], out=np.zeros_like(d, dtype=float),
                         where=length[:, None] > 0)


def skeleton(
    trajectory_m: NDArray[np.float64],
    delta_s: NDArray[np.float64],
    centres_m: NDArray[np.float64],
    radii_m: NDArray[np.float64],
    tolerance_m: float = SIMPLIFY_TOLERANCE_M,
    polygons: tuple[PolygonZone, ...] = (),
    polygon_clear_m: float = 0.0,
    chordwise: bool = True,
) -> Skeleton:
    """Corners and hover points of a closed slot trajectory (N+1, 2) with slot lengths (N,).

    Runs of stationary slots become one waypoint holding their total time. Between hover
    points the path is simplified (:func:`douglas_peucker` within ``tolerance_m``), a chord
    replacing the points it skips only when it stays at least as clear of the circles
    (``centres_m``, ``radii_m``) as they were, or clear of them, and of the ``polygons`` by
    ``polygon_clear_m``: every corner costs the vehicle time, a short leg most of all.
    ``chordwise`` False judges each whole stretch instead, with the largest tolerance of
    :data:`WHOLE_STRETCH_STEPS_M` that keeps it as clear (PX4 plans, see the planner).
    """
    q = np.asarray(trajectory_m, dtype=float)
    n = len(delta_s)
    moving = np.linalg.norm(np.diff(q, axis=0), axis=1) >= STATIONARY_M
    # Begin where a hover begins, so that no hold wraps round the end of the list.
    starts = [i for i in range(n) if not moving[i] and moving[i - 1]]
    first = starts[0] if starts else 0
    verts = [first]  # trajectory indices of candidate waypoints, in flying order
    holds = [0.0]
    for i in ((first + k) % n for k in range(n)):
        if moving[i]:
            verts.append((i + 1) % n)
            holds.append(0.0)
        else:
            holds[-1] += float(delta_s[i])
    if len(verts) > 1:  # the last move returns to the first waypoint
        verts, holds = verts[:-1], holds[:-1]
    hover = {v for v, h in zip(verts, holds, strict=True) if h > 0}
    def clearance(pts: NDArray[np.float64]) -> float:
        return path_clearance_m(pts, centres_m, radii_m, polygons, polygon_clear_m)

    keep = _simplify(q[:n], verts, hover, clearance, tolerance_m, chordwise)
    hold_of = dict(zip(verts, holds, strict=True))
    # Waypoints closer than a hover's wobble are one waypoint (no zero-length legs).
    points: list[NDArray[np.float64]] = []
    hold: list[float] = []
    for v in keep:
        if points and np.hypot(*(q[v] - points[-1])) < STATIONARY_M:
            hold[-1] += hold_of[v]
            continue
        points.append(q[v])
        hold.append(hold_of[v])
    if len(points) > 1 and np.hypot(*(points[-1] - points[0])) < STATIONARY_M:
        hold[0] += hold.pop()
        points.pop()
    return Skeleton(np.array(points), np.array(hold))


def started_near(sk: Skeleton, home_xy_m: NDArray[np.float64]) -> Skeleton:
    """The same closed cycle started at its hover point nearest ``home_xy_m`` (m): a cycle
    serves alike from whichever stop it starts at, and the transits out to its start and back
    from it are the mission's only other flying. Unchanged without a hover point."""
    hovering = np.flatnonzero(sk.hold_s > 0)
    if hovering.size == 0:
        return sk
    gap = np.linalg.norm(sk.points_m[hovering] - np.asarray(home_xy_m, dtype=float), axis=1)
    k = int(hovering[int(np.argmin(gap))])
    return Skeleton(np.roll(sk.points_m, -k, axis=0), np.roll(sk.hold_s, -k))


def _simplify(
    q: NDArray[np.float64],
    verts: list[int],
    hover: set[int],
    clearance: Callable[[NDArray[np.float64]], float],
    tolerance_m: float,
    chordwise: bool,
) -> list[int]:
    """Vertices kept after simplifying each stretch between hover points (see
    :func:`skeleton`)."""
    anchors = [k for k, v in enumerate(verts) if v in hover] or [0]
    keep: list[int] = []
    for a, b in zip(anchors, [*anchors[1:], anchors[0] + len(verts)], strict=True):
        stretch = [verts[k % len(verts)] for k in range(a, b + 1)]
        pts = q[stretch]

        def keeps_clearance(i: int, j: int, pts: NDArray[np.float64] = pts) -> bool:
            return clearance(pts[[i, j]]) >= min(clearance(pts[i:j + 1]), 0.0) - 1e-9

        def tightest(i: int, j: int, pts: NDArray[np.float64] = pts) -> int:
            return i + 1 + int(np.argmin([clearance(pts[[k, k]]) for k in range(i + 1, j)]))

        if chordwise:
            chosen = douglas_peucker(pts, tolerance_m, keeps_clearance, tightest)
        else:  # the largest of the steps whose whole simplified stretch keeps its clearance
            before = min(clearance(pts), 0.0)
            chosen = list(range(len(pts)))
            for tol in (t for t in WHOLE_STRETCH_STEPS_M if t <= tolerance_m):
                idx = douglas_peucker(pts, tol, lambda i, j: True, tightest)
                if clearance(pts[idx]) >= before - 1e-9:
                    chosen = idx
                    break
        keep.extend(stretch[i] for i in chosen[:-1])
    return keep


def arrival_lag_s(profiles: LegMotion, autopilot: str = "ardupilot") -> NDArray[np.float64]:
    """(W,) time (s) the vehicle reaches each waypoint after the leg's timing ends (waypoint w
    is reached by leg w − 1): ArduCopter's stop lag after each S-curve; none for PX4, whose
    legs are timed to the moment its navigator counts the waypoint reached."""
    lag_s = 0.0 if autopilot == "px4" else STOP_LAG_S
    lag = np.where(profiles.length_m > 0, lag_s, 0.0)
    return np.asarray(np.roll(lag, 1), dtype=float)


def time_cycle(
    site: Site, sk: Skeleton, period_s: float, slots: int, autopilot: str = "ardupilot",
    params: Mapping[str, float] | None = None, pass_through: bool = True,
) -> tuple[float, tuple[NDArray[np.float64], NDArray[np.float64]] | None]:
    """The vehicle's total move time (s) round ``sk``, and its timeline of ``slots`` slots
    filling ``period_s`` (trajectory (N+1, 2), slot lengths (N,)); None when it cannot.

    With ``pass_through`` the vehicle flies through every corner that is not a hover point
    where its turn (PX4: its swing region) keeps the buffer (:mod:`.corners`); it stops at
    the rest. On
    the timeline each stop's hover begins with the stop lag (:func:`arrival_lag_s`) and then
    holds as :func:`fit_holds` says (as the autopilot stores them, at least a second). A PX4
    leg begins with its departure crawl (:func:`px4_departures_s`), settled with the holds."""
    profiles = leg_profiles(site, sk.leg_lengths_m, autopilot=autopilot, params=params,
                            unit_xy=sk.leg_units if site.flight_wind is not None else None)
    motion = cycle_motion(site, sk, profiles, autopilot, params, pass_through)
    lag = motion.arrival_lag_s
    holds = fit_holds(sk.hold_s, motion.move_s + float(np.sum(lag)), period_s,
                      stops=motion.stops, autopilot=autopilot)
    if autopilot == "px4" and isinstance(profiles, SampledLegs):
        # PX4's departure crawls shorten as the holds before them lengthen, and the holds
        # shorten as the crawls take up the period: from the longest holds, each round
        # lengthens the crawls and shortens the holds until they agree.
        base, crawl = motion, np.zeros(len(sk.points_m))
        px4_profile = motion_profile(site, autopilot, params)
        for _ in range(PX4_CRAWL_ROUNDS):
            if holds is None:
                break
            before = crawl  # (no crawl out of a waypoint flown through)
            crawl = np.where(base.stops, px4_departures_s(sk, profiles, holds, px4_profile), 0.0)
            motion = replace(base, offset_s=base.offset_s - crawl,
                             duration_s=base.duration_s + crawl)
            holds = fit_holds(sk.hold_s, motion.move_s + float(np.sum(lag)), period_s,
                              stops=motion.stops, autopilot=autopilot)
            if float(np.max(np.abs(crawl - before))) < 0.01:
                break
    if holds is None:
        return motion.move_s, None
    return motion.move_s, resample(sk, holds + lag, profiles, slots, motion)


def px4_departures_s(sk: Skeleton, legs: SampledLegs, hold_s: NDArray[np.float64],
                     profile: Profile) -> NDArray[np.float64]:
    """(W,) how long (s) PX4 crawls away from each waypoint of the closed skeleton ``sk``
    before leg k speeds up (:func:`validator.motion.px4_mission.departure_lock_s`): its
    trajectory arrives as the last leg before it with any length left it (``legs.arrival``,
    taken :data:`PX4_ARRIVAL_SPREAD` times further out), closes in over the holds since
    (``hold_s``), and turns onto leg k."""
    lengths = legs.length_m
    w = len(lengths)
    out = np.zeros(w)
    if not np.any(lengths > 0):
        return out
    pts = np.asarray(sk.points_m, dtype=float)
    heading = np.roll(pts, -1, axis=0) - pts
    for k in range(w):
        if lengths[k] <= 0:
            continue
        held, j = float(hold_s[k]), (k - 1) % w
        while lengths[j] <= 0:
            held += float(hold_s[j])
            j = (j - 1) % w
        togo, speed, accel = (float(x) * PX4_ARRIVAL_SPREAD for x in legs.arrival[j])
        out[k] = departure_lock_s(profile, (togo, speed, accel), held, heading[j], heading[k])
    return out


def cycle_motion(site: Site, sk: Skeleton, profiles: LegMotion, autopilot: str = "ardupilot",
                 params: Mapping[str, float] | None = None,
                 pass_through: bool = True) -> CycleMotion:
    """Which waypoints of ``sk`` the vehicle stops at and how long each leg moves
    (:class:`~.corners.CycleMotion`): every one a stop without ``pass_through``, else the
    hover points, waypoint 0 and the corners whose blended turn (ArduCopter,
    :func:`~.corners.blended_motion`) or swing region (PX4, :func:`~.corners.px4_motion`)
    would reach into a zone's buffer. ``profiles``: the legs' rest-to-rest
    motion (:func:`leg_profiles`)."""
    lengths = sk.leg_lengths_m
    if not pass_through or len(sk.points_m) < 2:
        return stop_everywhere(profiles.total_s, lengths, arrival_lag_s(profiles, autopilot))
    profile = motion_profile(site, autopilot, params)
    if profile.name == "px4":
        return px4_motion(sk.points_m, profiles.total_s, sk.hold_s > 0,
                          px4_top_speed_mps(profile), profile, site.nfz_xy_m,
                          site.planning_radius_m, site.polygon_zones, site.buffer_m)
    speed = scurve_speed_mps(scurve_limits(profile))
    return blended_motion(sk.points_m, profiles.total_s, sk.hold_s > 0, speed, profile,
                          site.nfz_xy_m, site.planning_radius_m, site.polygon_zones,
                          site.buffer_m)


def fit_holds(
    hold_s: NDArray[np.float64], move_s: float, period_s: float, min_hold_s: float = MIN_HOLD_S,
    stops: NDArray[np.bool_] | None = None, autopilot: str = "ardupilot",
) -> NDArray[np.float64] | None:
    """Holds so that moves plus holds last exactly the period; None if they cannot.

    Every waypoint in ``stops`` (default: all) holds at least ``min_hold_s`` (the first, where
    the cycle starts and ends, twice that): a hold makes ArduCopter stop there, so its legs are
    the rest-to-rest S-curves this module times (with no hold it blends the corner, as the
    others do, see :mod:`.corners`). The spare time goes to the optimiser's hover points in
    proportion to their holds (to the stops alike when there are none). All holds but the
    longest are as ``autopilot`` stores them (:func:`validator.autopilot.rules.stored_hold_s`:
    ArduCopter whole seconds, PX4 as planned), so that exporting the plan does not shift its
    timing.
    """
    hold = np.asarray(hold_s, dtype=float)
    stop = np.ones(len(hold), dtype=bool) if stops is None else np.asarray(stops, dtype=bool)
    # The first waypoint both starts and ends the cycle (see resample): it stops twice.
    least = np.where(stop, min_hold_s, 0.0)
    if len(hold) > 1:
        least[0] = 2 * min_hold_s
    spare = period_s - move_s - float(np.sum(least))
    if spare < 0:
        return None
    total = float(np.sum(hold))
    share = (hold * (spare / total) if total > 0
             else np.where(stop, spare / max(int(np.count_nonzero(stop)), 1), 0.0))
    out = least + share
    longest = int(np.argmax(out))
    whole = np.array([stored_hold_s(h, autopilot) for h in out])
    whole[longest] = out[longest]
    whole[longest] += float(np.sum(out - whole))
    return np.asarray(whole, dtype=float)


def resample(
    sk: Skeleton,
    hold_s: NDArray[np.float64],
    profiles: LegMotion,
    slots: int,
    motion: CycleMotion | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """N slots over the re-timed cycle: (trajectory (N+1, 2), slot lengths (N,)); None when
    the waypoints need more slots than there are. ``hold_s`` is each waypoint's time there
    (0: passed through), ``motion`` how each leg moves and the part of each hold spent
    arriving (default: every leg whole from rest to rest, no lag; see :func:`time_cycle`).

    A leg's slots end where its own motion puts the vehicle along the leg, the last one at
    its waypoint (inside a blended turn the vehicle is off the legs by the corner cut)."""
    w = len(sk.points_m)
    if motion is None:
        motion = stop_everywhere(profiles.total_s, profiles.length_m, np.zeros(w))
    lag0 = float(motion.arrival_lag_s[0])
    move = motion.duration_s
    # Intervals in time order: hold at waypoint k (if any), then the move of leg k.
    kinds: list[tuple[str, int, float]] = []
    for k in range(w):
        if hold_s[k] > 1e-9:
            kinds.append(("hold", k, float(hold_s[k])))
        if move[k] > 1e-9:
            kinds.append(("move", k, float(move[k])))
    # The cycle also ends with a stop at its first waypoint: a whole second of that hold (and
    # the lag of arriving there) moves to the end, so that the last leg is flown rest-to-rest
    # even when the mission goes on to its return transit instead of repeating the cycle.
    end_hold = MIN_HOLD_S + lag0
    if len(kinds) > 1 and kinds[0][0] == "hold" and kinds[0][2] >= MIN_HOLD_S + end_hold:
        kind, k, d = kinds[0]
        kinds[0] = (kind, k, d - end_hold)
        kinds.append((kind, k, end_hold))
    if not kinds or len(kinds) > slots:
        return None
    dur = np.array([d for _, _, d in kinds])
    # Every interval gets one slot, the rest go by duration (largest remainder). A slot's rate
    # is taken at its end point, exact while hovering but biased while moving, so a second of
    # move earns HOVER_SLOT_DISCOUNT⁻¹ times the slots of a second of hover.
    weight = dur * np.array(
        [HOVER_SLOT_DISCOUNT if kind == "hold" else 1.0 for kind, _, _ in kinds]
    )
    extra = slots - len(kinds)
    share = weight / weight.sum() * extra
    count = 1 + np.floor(share).astype(int)
    rest = slots - int(count.sum())
    count[np.argsort(-(share - np.floor(share)), kind="stable")[:rest]] += 1
    points = [sk.points_m[0]]
    deltas: list[float] = []
    nxt = np.roll(sk.points_m, -1, axis=0)
    for (kind, k, d), c in zip(kinds, count, strict=True):
        if kind == "hold":
            deltas.extend([d / c] * c)
            points.extend([sk.points_m[k]] * c)
            continue
        length = float(profiles.length_m[k])
        pos = _along(motion, profiles, k)
        tau = _move_boundaries(pos, length, d, c)
        deltas.extend(np.diff(np.r_[0.0, tau]))
        along = pos(tau)
        along[-1] = length  # the waypoint itself, reached or passed through
        unit = (nxt[k] - sk.points_m[k]) / length
        points.extend(sk.points_m[k] + along[:, None] * unit[None, :])
    traj = np.array(points)
    traj[-1] = traj[0]  # exactly closed (the last move ends at waypoint 0)
    return traj, np.array(deltas)


def _along(motion: CycleMotion, profiles: LegMotion, leg: int
           ) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """Distance (m) along ``leg`` at times (s) from the start of its move: where the cycle's
    flight put the vehicle (``motion.flown``), else its own rest-to-rest motion from
    ``motion.offset_s``."""
    flown = motion.flown[leg] if motion.flown is not None else None
    if flown is not None:
        t, s = flown
        return lambda tau: np.asarray(np.interp(tau, t, s), dtype=float)
    offset = float(motion.offset_s[leg])

    def own(tau: NDArray[np.float64]) -> NDArray[np.float64]:
        along, _, _ = profiles.state(np.full(len(tau), leg), offset + tau)
        return np.asarray(along, dtype=float)

    return own


def _move_boundaries(
    pos_at: Callable[[NDArray[np.float64]], NDArray[np.float64]], length: float,
    duration_s: float, count: int
) -> NDArray[np.float64]:
    """End times (s, from the move's start) of ``count`` slots over a leg's move of
    ``length`` m lasting ``duration_s`` (``pos_at``: the distance along it at a time): equal
    in time, except that every slot moves at least :data:`MIN_SLOT_MOVE_M` (an S-curve starts
    and ends so slowly that an equal share of time may move less than a hover's wobble, and
    the exporter would read the slot as a hold)."""
    tau = duration_s * np.arange(1, count + 1) / count
    if count < 2 or length < (count + 1) * MIN_SLOT_MOVE_M:
        return np.asarray(tau, dtype=float)
    grid = np.linspace(0.0, duration_s, 4096)
    pos = np.maximum.accumulate(pos_at(grid))
    step = MIN_SLOT_MOVE_M * 1.01  # a little over, against the grid's interpolation
    ahead = np.interp(step * np.arange(1, count + 1), pos, grid)  # i+1 steps from the start
    behind = np.interp(length - step * np.arange(count - 1, -1, -1), pos, grid)
    out = np.minimum(np.maximum(tau, ahead), behind)
    out[-1] = duration_s
    return np.asarray(out, dtype=float)
