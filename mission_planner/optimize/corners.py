"""Pass-through corners: where the vehicle flies through a waypoint instead of stopping at it.

ArduCopter 4.x blends a waypoint that has no hold into the next leg: the next S-curve starts
while this one brakes, and the vehicle turns inside WPNAV_RADIUS without stopping. Each stop
costs the braking and re-acceleration of two S-curves and the stop lag; a path with many
corners (round a zone, or a winding tour) spends much of T stopping. A blended turn cuts the
corner on its inside, which is where the zone lies when the path bends round one, so a corner
is passed through only where the flown turn keeps the site's buffer from every zone; the
optimiser's hover points and the cycle's first waypoint always stop.

The turn is timed and placed by the validator's own ArduCopter model
(:func:`validator.motion.fly.fly`, the corner rule of :mod:`validator.motion.arducopter`), so the
plan and its replay agree by construction.

PX4 does not cut a corner it flies through: on SIH flights (``tests/data/px4-corners``) it
passed the waypoint within 0.1-0.6 m and swung 0.6-1.6 m *outside* the turn, the track
within about NAV_ACC_RAD of both legs near the corner, where the px4 model rounds it inside.
So a PX4 corner is judged on that bound, the validator's swing region
(:func:`validator.motion.px4_swing.swing_clearance_m`: both legs within 15 m of the waypoint,
widened by NAV_ACC_RAD plus 0.5 m), which the validator's px4 replay checks too; only turns
up to :data:`PX4_MAX_TURN_DEG` are flown through; the run between two
stops is timed by the px4 model, which timed such corners within 5 % (:func:`px4_motion`).

Positions are metres east/north; times seconds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from validator.flight import Flight, Leg
from validator.geometry import min_leg_clearance
from validator.motion.arducopter_speed import leg_speeds_mps
from validator.motion.fly import fly
from validator.motion.path import FlownPath
from validator.motion.profile import Profile
from validator.motion.px4_mission import px4_run_reached_s
from validator.motion.px4_swing import swing_clearance_m
from validator.plan_format import Autopilot
from validator.zones import PolygonZone, polyline_clearance_m

# PX4 corners flown through are timed by the px4 model, checked on SIH for turns of 12-60°
# (within 5 %); sharper ones (77-137° on samples/realistic.yaml) PX4 crawled round at 0.4-1.2
# m/s, each leg 2-3 s slower than modelled, and the cycle flew 1.05 T: those stop.
PX4_MAX_TURN_DEG = 60.0
CLEARANCE_TOL_M = 1e-3  # a blended turn may touch the buffer to this much (model precision)
TURN_SAMPLE_S = 0.02  # the turn is checked along its path sampled this often


@dataclass(frozen=True)
class CycleMotion:
    """How the vehicle flies a closed skeleton of W waypoints (leg k: waypoint k → k+1).

    ``stops`` (W,): the vehicle stops at waypoint k (else it passes through). Leg k is flown
    along its own rest-to-rest motion from ``offset_s[k]`` for ``duration_s[k]`` seconds: from
    0 when it starts at a stop (below 0: it waits there that long first, PX4's departure
    crawl), from the moment the previous corner counts as reached when it starts blended; to
    its end before a stop, to the moment its corner counts as reached before a pass-through.
    ``arrival_lag_s`` (W,): time between the end of the motion into waypoint k and the
    vehicle's arrival there (ArduCopter's stop lag at stops, 0 when passed through).
    ``flown``: where the model flew each moving leg, as (time from the start of its move (s),
    distance along it (m)) samples, when that is not its own rest-to-rest motion (ArduCopter:
    a leg entered through a corner first runs at the speed of the leg before); None to read
    the rest-to-rest motion.
    """

    stops: NDArray[np.bool_]
    offset_s: NDArray[np.float64]
    duration_s: NDArray[np.float64]
    arrival_lag_s: NDArray[np.float64]
    flown: tuple[tuple[NDArray[np.float64], NDArray[np.float64]] | None, ...] | None = None

    @property
    def move_s(self) -> float:
        """Time (s) the vehicle moves in one cycle, lags not counted."""
        return float(np.sum(self.duration_s))


def stop_everywhere(total_s: NDArray[np.float64], lengths_m: NDArray[np.float64],
                    arrival_lag_s: NDArray[np.float64]) -> CycleMotion:
    """Every waypoint a stop: each leg that moves flown whole from rest to rest (its motion
    lasting ``total_s``), waypoint k reached ``arrival_lag_s[k]`` after that motion ends."""
    moving = np.asarray(lengths_m) > 0
    return CycleMotion(np.ones(len(total_s), dtype=bool), np.zeros(len(total_s)),
                       np.where(moving, total_s, 0.0), np.asarray(arrival_lag_s, dtype=float))


def blended_motion(
    points_m: NDArray[np.float64],
    total_s: NDArray[np.float64],
    must_stop: NDArray[np.bool_],
    speed_mps: float,
    profile: Profile,
    centres_m: NDArray[np.float64],
    radii_m: NDArray[np.float64],
    polygons: tuple[PolygonZone, ...] = (),
    polygon_clear_m: float = 0.0,
) -> CycleMotion:
    """The cycle round ``points_m`` (W, 2) flown by an ``arducopter`` ``profile`` at
    ``speed_mps`` (each leg's rest-to-rest motion lasting ``total_s``), passing through every
    waypoint not in ``must_stop`` whose blended turn stays at least ``radii_m`` from the circle
    centres ``centres_m`` and ``polygon_clear_m`` from the ``polygons``; waypoint 0 always
    stops (the cycle starts and ends there at rest)."""
    w = len(points_m)
    stops = np.asarray(must_stop, dtype=bool).copy()
    stops[0] = True
    path = _fly_cycle(points_m, stops, speed_mps, profile)
    cut = [k for k in np.flatnonzero(~stops)
           if _turn_clearance(path, int(k), centres_m, radii_m, polygons, polygon_clear_m)
           < -CLEARANCE_TOL_M]
    if cut:  # a turn's overlap depends on its two legs alone: one more flight settles it
        stops[cut] = True
        path = _fly_cycle(points_m, stops, speed_mps, profile)
    end = (path.end_s if path.end_s is not None
           else path.start_s + np.asarray(total_s, dtype=float))
    offset = np.zeros(w)
    duration = np.zeros(w)
    lag = np.zeros(w)
    for k in range(w):
        nxt = (k + 1) % w
        begin = 0.0 if stops[k] else float(path.reached_s[k - 1] - path.start_s[k])
        finish = float(end[k] if stops[nxt] else path.reached_s[k]) - float(path.start_s[k])
        offset[k], duration[k] = begin, max(finish - begin, 0.0)
        if stops[nxt]:
            lag[nxt] = float(path.reached_s[k] - end[k])
    return CycleMotion(stops, offset, duration, lag,
                       tuple(_along_leg(path, points_m, k, float(path.start_s[k] + offset[k]),
                                        float(duration[k])) for k in range(w)))


def _along_leg(path: FlownPath, points_m: NDArray[np.float64], leg: int, begin_s: float,
               duration_s: float) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """(time from ``begin_s`` (s), distance along leg ``leg`` (m)) of the flown ``path`` over
    the leg's move, the vehicle's position projected onto the leg (never back: the slots
    laid along it run forward); None for a leg that does not move."""
    start, end = points_m[leg], points_m[(leg + 1) % len(points_m)]
    length = float(np.hypot(*(end - start)))
    if length <= 0 or duration_s <= 0:
        return None
    sel = (path.t_s >= begin_s - TURN_SAMPLE_S) & (path.t_s <= begin_s + duration_s + TURN_SAMPLE_S)
    along = (path.xyz_m[sel, :2] - start) @ ((end - start) / length)
    return (path.t_s[sel] - begin_s,
            np.maximum.accumulate(np.clip(along, 0.0, length)).astype(float))


def px4_motion(
    points_m: NDArray[np.float64],
    total_s: NDArray[np.float64],
    must_stop: NDArray[np.bool_],
    speed_mps: float,
    profile: Profile,
    centres_m: NDArray[np.float64],
    radii_m: NDArray[np.float64],
    polygons: tuple[PolygonZone, ...] = (),
    polygon_clear_m: float = 0.0,
) -> CycleMotion:
    """The cycle round ``points_m`` (W, 2) flown by a ``px4`` ``profile`` at ``speed_mps``
    (each leg's rest-to-rest motion lasting ``total_s``, the arrival included), passing
    through every waypoint not in ``must_stop`` that turns by :data:`PX4_MAX_TURN_DEG` at
    most and whose swing region
    (:func:`validator.motion.px4_swing.swing_clearance_m`, NAV_ACC_RAD either side of both
    legs) stays ``radii_m`` from the circle centres ``centres_m`` and ``polygon_clear_m`` from
    the ``polygons``; waypoint 0 always stops. Each run between two stops is flown by the
    validator's PX4 model (:func:`validator.motion.px4_mission.px4_run_reached_s`): its first
    leg from the start of its rest-to-rest motion, the others ending where theirs end."""
    w = len(points_m)
    stops = np.asarray(must_stop, dtype=bool).copy()
    stops[0] = True
    acceptance_m = profile.si("NAV_ACC_RAD")
    lengths = np.hypot(*(np.roll(points_m, -1, axis=0) - points_m).T)
    for k in np.flatnonzero(~stops):
        before, corner, after = points_m[k - 1], points_m[k], points_m[(k + 1) % w]
        if lengths[k - 1] <= 0 or lengths[k] <= 0 or _turn_deg(
                before, corner, after) > PX4_MAX_TURN_DEG or swing_clearance_m(
                before, corner, after, acceptance_m, centres_m, radii_m, polygons,
                polygon_clear_m) < -CLEARANCE_TOL_M:
            stops[k] = True
    total = np.asarray(total_s, dtype=float)
    offset, duration = np.zeros(w), np.where(lengths > 0, total, 0.0)
    starts = np.flatnonzero(stops)
    for i, first in enumerate(starts):
        end = int(starts[i + 1]) if i + 1 < len(starts) else w
        if end - first < 2:
            continue  # stop to stop: the rest-to-rest leg itself
        idx = np.arange(first, end + 1) % w
        reached = px4_run_reached_s(points_m[idx], speed_mps, profile)
        move = np.diff(np.r_[0.0, reached])
        legs = np.arange(first, end)
        duration[legs] = move
        offset[legs[1:]] = np.maximum(total[legs[1:]] - move[1:], 0.0)
    return CycleMotion(stops, offset, duration, np.zeros(w))


def _turn_deg(a: NDArray[np.float64], c: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    """How far (degrees) the path a → c → b turns at c (legs of non-zero length)."""
    u, v = c - a, b - c
    cos = float(np.dot(u, v) / (np.hypot(*u) * np.hypot(*v)))
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


def _fly_cycle(points_m: NDArray[np.float64], stops: NDArray[np.bool_], speed_mps: float,
               profile: Profile) -> FlownPath:
    """One cycle from rest at waypoint 0 back to it, without holds (a stop is a leg that does
    not pass through: :class:`~validator.flight.Leg`'s ``pass_through``), each leg commanded
    the speed the export will command it (:func:`validator.motion.arducopter_speed.leg_speeds_mps`:
    in wind, less where its course leaves less): the leg after a corner first runs at the
    speed commanded before it."""
    w = len(points_m)
    step = np.roll(points_m, -1, axis=0) - points_m
    length = np.hypot(step[:, 0], step[:, 1])
    unit = np.divide(step, length[:, None], out=np.zeros_like(step), where=length[:, None] > 0)
    speeds = leg_speeds_mps(profile, speed_mps, unit)
    legs = tuple(
        Leg(item=k, first_item=k, kind="waypoint", start_xy_m=points_m[k],
            end_xy_m=points_m[(k + 1) % w], start_alt_m=0.0, end_alt_m=0.0,
            speed_mps=float(speeds[k]), hold_s=0.0, pass_through=not stops[(k + 1) % w])
        for k in range(w)
    )
    flight = Flight(legs=legs, home_xy_m=points_m[0], firmware_type=int(Autopilot.ARDUPILOTMEGA),
                    findings=(), cycle=None, service=None)
    return fly(flight, profile, dt_s=TURN_SAMPLE_S)


def _turn_clearance(path: FlownPath, corner: int, centres_m: NDArray[np.float64],
                    radii_m: NDArray[np.float64], polygons: tuple[PolygonZone, ...],
                    polygon_clear_m: float) -> float:
    """Least clearance (m) of the flown turn through waypoint ``corner`` >= 1: while both legs
    move (leg ``corner`` starts before leg ``corner - 1`` ends; the corner counts as reached
    half-way), elsewhere the vehicle flies the straight legs themselves."""
    lo = float(path.start_s[corner])
    hi = 2.0 * float(path.reached_s[corner - 1]) - lo
    sel = (path.t_s >= lo - TURN_SAMPLE_S) & (path.t_s <= hi + TURN_SAMPLE_S)
    pts = path.xyz_m[sel, :2]
    if len(pts) < 2:
        return float("inf")
    return path_clearance_m(pts, centres_m, radii_m, polygons, polygon_clear_m)


def path_clearance_m(pts_m: NDArray[np.float64], centres_m: NDArray[np.float64],
                     radii_m: NDArray[np.float64], polygons: tuple[PolygonZone, ...] = (),
                     polygon_clear_m: float = 0.0) -> float:
    """Least signed clearance (m) of the polyline ``pts_m`` (P >= 2, 2) from the circles
    (beyond ``radii_m``) and the polygons (beyond ``polygon_clear_m``): negative inside, so a
    path into a zone without a buffer counts too; +inf with no zones."""
    c = min_leg_clearance(pts_m, centres_m, radii_m)
    if polygons:
        c = min(c, *(polyline_clearance_m(z, pts_m)[0] - polygon_clear_m for z in polygons))
    return c
