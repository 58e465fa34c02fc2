"""PX4's mission motion, ported from v1.15 and checked on SIH flights of our plans.

A multicopter in a PX4 mission does not fly a precomputed S-curve. Every control cycle
(:data:`LOOP_S`) ``FlightTaskAuto`` asks ``PositionSmoothing`` for a velocity target toward
the current waypoint, and ``VelocitySmoothing`` moves the trajectory toward that target with
bounded jerk and acceleration:

- the target speed is the fastest from which the vehicle can still arrive at the waypoint's
  speed (:func:`max_speed_from_distance`, ``TrajMath.hpp``): v² = v_f² + 2·A·(d − v·2A/J).
  The 2A/J term is a deliberately conservative reaction delay; with a small jerk it dominates,
  and the last tens of metres to a stop are crawled (at d ≪ 8A³/J² the speed is about
  d·J/(2A), an exponential approach with time constant 2A/J);
- the speed at a waypoint the vehicle flies through is :func:`corner_speed_mps`
  (``computeMaxSpeedInWaypoint`` with MPC_XY_TRAJ_P), capped by what the following leg allows;
  a waypoint with a hold has no next setpoint, so the vehicle stops there;
- the navigator counts a waypoint reached when the vehicle is within NAV_ACC_RAD of it
  (NAV_MC_ALT_RAD vertically) and starts the hold then, while the vehicle is still creeping
  in; when the hold is over the next leg starts from wherever the vehicle is;
- leaving a stop for a leg that turns, the trajectory may crawl on at its creeping speed for
  seconds (:func:`departure_lock_s`, ``PositionSmoothing::_isTurning``).

Lengths are metres, speeds m/s, accelerations m/s², jerks m/s³, times seconds.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

LOOP_S = 0.02  # the position controller's cycle: FlightTaskAuto runs at 50 Hz in SIH
STOPPED_MPS = 0.02  # a run has settled when it is this slow, this close (STOPPED_M) to its end
STOPPED_M = 0.01
# PositionSmoothing: the trajectory is turning while it moves faster than TURNING_MIN_MPS and
# its velocity is more than acos(TURNING_COS) off the direction to the target; it heads for the
# crossing point max(NAV_ACC_RAD, L1_MIN_M) ahead on the line (_getL1Point).
TURNING_MIN_MPS = 0.2
TURNING_COS = 0.98
L1_MIN_M = 5.0


def max_speed_from_distance(
    distance_m: float, final_speed_mps: float, accel_mps2: float, jerk_mps3: float
) -> float:
    """PX4's ``computeMaxSpeedFromDistance``: the speed (m/s) from which a vehicle still
    arrives ``distance_m`` ahead at ``final_speed_mps``, braking at ``accel_mps2`` after a
    reaction delay of 2·A/J: the positive root of v² + (4A²/J)·v − (2·A·d + v_f²) = 0, and
    never below the final speed."""
    b = 4.0 * accel_mps2 * accel_mps2 / jerk_mps3
    c = -2.0 * accel_mps2 * max(distance_m, 0.0) - final_speed_mps * final_speed_mps
    return max(0.5 * (-b + math.sqrt(b * b - 4.0 * c)), final_speed_mps)


def corner_speed_mps(turn_rad: float, accel_mps2: float, acceptance_m: float,
                     traj_p: float = 0.5) -> float:
    """PX4's speed (m/s) through a waypoint where the track turns by ``turn_rad``: a circle
    tangent to both legs at the acceptance radius, at MPC_XY_TRAJ_P·MPC_ACC_HOR of centripetal
    acceleration: sqrt(P·A·r·tan(α/2)) with α = π − turn the angle between the legs."""
    if turn_rad <= 1e-6:
        return math.inf
    alpha = min(max(math.pi - turn_rad, 0.0), math.pi - 1e-6)
    return math.sqrt(traj_p * accel_mps2 * acceptance_m * math.tan(alpha / 2.0))


class VelocitySmoothing:
    """``VelocitySmoothing`` of one axis: a trajectory (position, speed, acceleration) driven
    to a velocity target in minimum time with |jerk| ≤ J and |acceleration| ≤ A; the target
    is replaced every cycle (:meth:`update_durations`), the state advanced by :meth:`step`."""

    def __init__(self, accel_mps2: float, jerk_mps3: float) -> None:
        self.accel, self.jerk = accel_mps2, jerk_mps3
        self.a = self.v = self.x = 0.0
        self._init = (0.0, 0.0, 0.0)
        self._t = 0.0
        self._dir = 0
        self._T = (0.0, 0.0, 0.0)

    def update_durations(self, vel_sp_mps: float) -> None:
        """Plan the jerk phases (T1 up, T2 constant, T3 down) from the state to the target."""
        a0, v0, J = self.a, self.v, self.jerk
        self._t, self._init = 0.0, (a0, v0, self.x)
        vel_zero_acc = v0
        if abs(a0) > 1e-9:  # where the speed ends if the acceleration is cancelled now
            j0 = -math.copysign(J, a0)
            t0 = -a0 / j0
            vel_zero_acc = v0 + a0 * t0 + 0.5 * j0 * t0 * t0
        d = (vel_sp_mps > vel_zero_acc) - (vel_sp_mps < vel_zero_acc)
        if d == 0:
            d = (a0 > 0) - (a0 < 0)
        self._dir = d
        if d == 0:
            self._T = (0.0, 0.0, 0.0)
            return
        j = d * J
        dv = vel_sp_mps - v0
        t1 = 0.0
        delta = 2.0 * a0 * a0 + 4.0 * j * dv
        if delta >= 0:
            root = math.sqrt(delta)
            plus, minus = (-a0 + 0.5 * root) / j, (-a0 - 0.5 * root) / j
            if plus >= 0 and a0 / j + plus >= 0:
                t1 = plus
            elif minus >= 0 and a0 / j + minus >= 0:
                t1 = minus
        a_t1 = a0 + j * t1
        if a_t1 > self.accel:
            t1 = (self.accel - a0) / j
        elif a_t1 < -self.accel:
            t1 = (-self.accel - a0) / j
        t1 = max(t1, 0.0)
        t3 = max(a0 / j + t1, 0.0)
        den = a0 + j * t1
        t2 = 0.0
        if abs(den) > 1e-9:
            t2 = (-0.5 * t1 * t1 * j - t1 * t3 * j - t1 * a0 + 0.5 * t3 * t3 * j - t3 * a0
                  + dv) / den
        self._T = (t1, max(t2, 0.0), t3)

    def step(self, dt_s: float) -> None:
        """Advance the trajectory by ``dt_s`` along the planned phases."""
        self._t += dt_s
        a, v, x = self._init
        rest = self._t
        for jerk, dur in ((self._dir * self.jerk, self._T[0]), (0.0, self._T[1]),
                          (-self._dir * self.jerk, self._T[2])):
            t = min(rest, dur)
            x += v * t + 0.5 * a * t * t + jerk * t * t * t / 6.0
            v += a * t + 0.5 * jerk * t * t
            a += jerk * t
            rest -= t
            if rest <= 0:
                break
        if rest > 0:
            x += v * rest
            a = 0.0
        self.a, self.v, self.x = a, v, x


@dataclass(frozen=True)
class Tracking:
    """How the vehicle follows the trajectory: PX4's position and velocity loops (MPC_XY_P,
    MPC_XY_VEL_P_ACC, MPC_XY_VEL_I_ACC; acceleration limited by the tilt limit
    MPC_TILTMAX_AIR) against the air's drag, ``drag_per_s`` times the speed (SIH: SIH_KDV /
    SIH_MASS = 1/s; it caps the speed at g·tan(tilt)/drag, 9.8 m/s for SIH). The trajectory
    waits for a vehicle that falls behind it by up to MPC_XY_ERR_MAX (PositionSmoothing's
    time stretch). In wind the drag acts on the speed through the air: ``wind_along_mps``
    (m/s, the wind's part along the path) is taken off the speed, and holding the path against
    ``wind_cross_mps`` across it takes drag·w_cross of the tilt's acceleration, so the
    fastest ground speed along the path is w_along + sqrt(V² − w_cross²), V = g·tan(tilt)/drag
    (:func:`validator.wind.ground_speed_mps`)."""

    pos_p: float = 0.95
    vel_p: float = 1.8
    vel_i: float = 0.4
    tilt_max_deg: float = 45.0
    drag_per_s: float = 1.0
    err_max_m: float = 2.0
    wind_along_mps: float = 0.0
    wind_cross_mps: float = 0.0


@dataclass(frozen=True)
class Run1D:
    """A run of legs flown along a path without stopping, sampled every cycle.

    ``t_s`` (m,) from the run's start, ``s_m`` (m,) arc length flown, ``reached_s`` per
    waypoint of the run the time the navigator counted it reached, ``end_s`` when the run's
    item completed (the last waypoint's hold over). ``end_togo_m``, ``end_speed_mps``,
    ``end_accel_mps2``: the trajectory then, still short of the end and creeping in; the next
    leg leaves from there (:func:`departure_lock_s`)."""

    t_s: NDArray[np.float64]
    s_m: NDArray[np.float64]
    reached_s: NDArray[np.float64]
    end_s: float
    end_togo_m: float = 0.0
    end_speed_mps: float = 0.0
    end_accel_mps2: float = 0.0


def fly_run(
    waypoint_s_m: ArrayLike,
    through_speed_mps: ArrayLike,
    cruise_mps: ArrayLike,
    accel_mps2: float,
    jerk_mps3: float,
    acceptance_m: float,
    hold_s: float,
    *,
    cap_s_m: NDArray[np.float64] | None = None,
    cap_mps: NDArray[np.float64] | None = None,
    speed_profile: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
    tracking: Tracking | None = None,
    arrival_lag_s: float = 0.0,
    dt_s: float = LOOP_S,
) -> Run1D:
    """Fly from rest along a path through waypoints at arc lengths ``waypoint_s_m`` (the last
    one the run's end) as PX4 does: toward waypoint j at most ``cruise_mps[j]``, arriving at
    ``through_speed_mps[j]`` (0 for the last), braking by :func:`max_speed_from_distance`,
    smoothed by :class:`VelocitySmoothing`. A waypoint counts as reached within
    ``acceptance_m``; the next becomes the target then. After the last is reached the vehicle
    goes on closing in for ``hold_s`` (the item's hold). ``cap_s_m``/``cap_mps`` add a speed
    cap along the path (the corners' arcs); ``speed_profile`` (distance to go (m, increasing),
    speed (m/s)) replaces the braking law by a fixed speed schedule (a landing's descent)."""
    ends = np.asarray(waypoint_s_m, dtype=float).tolist()
    through = np.asarray(through_speed_mps, dtype=float).tolist()
    cruise = np.asarray(cruise_mps, dtype=float).tolist()
    last = len(ends) - 1
    vs = VelocitySmoothing(accel_mps2, jerk_mps3)
    reached = np.full(len(ends), np.nan)
    ts, ss = [0.0], [0.0]
    t, j = 0.0, 0
    cap_grid = cap_s_m.tolist() if cap_s_m is not None else None
    cap_val = cap_mps.tolist() if cap_mps is not None else None
    ci = 0
    done_at = math.inf
    x = v = integral = 0.0  # the vehicle: on the trajectory, or following it with tracking
    a_tilt = 9.80665 * math.tan(math.radians(tracking.tilt_max_deg)) if tracking else 0.0
    if tracking is not None and tracking.wind_along_mps:  # hovering, it already leans into it
        integral = -tracking.drag_per_s * tracking.wind_along_mps
    if tracking is not None and tracking.wind_cross_mps:  # the tilt left after the crosswind
        a_tilt = math.sqrt(max(a_tilt**2 - (tracking.drag_per_s * tracking.wind_cross_mps)**2,
                               0.0))
    while t < done_at and t < 1e5:
        while j < last and ends[j] - x <= acceptance_m:
            reached[j] = t
            j += 1
        if j == last and math.isnan(reached[last]) and ends[last] - x <= acceptance_m:
            reached[last] = t + arrival_lag_s
            done_at = reached[last] + hold_s
        togo = ends[j] - vs.x
        if speed_profile is not None and j == last:
            target = float(np.interp(ends[last] - vs.x, speed_profile[0], speed_profile[1]))
            target = min(target, max(togo, 0.0) / dt_s)  # never overshoot the end
        else:
            target = min(cruise[j], max_speed_from_distance(togo, through[j], accel_mps2,
                                                            jerk_mps3))
        if cap_grid is not None and cap_val is not None:
            while ci + 1 < len(cap_grid) and cap_grid[ci + 1] <= vs.x:
                ci += 1
            target = min(target, cap_val[ci])
        vs.update_durations(target)
        stretch = 1.0
        if tracking is not None:
            lag = vs.x - x
            if lag * vs.v >= 0:
                stretch = 1.0 - min(max(lag / tracking.err_max_m, 0.0), 1.0)
        vs.step(dt_s * stretch)
        if vs.x > ends[last]:  # the trajectory stops at the end, it does not pass it
            vs.x, vs.v, vs.a = ends[last], 0.0, 0.0
        if tracking is not None:
            e_v = vs.v + tracking.pos_p * (vs.x - x) - v
            want = vs.a + tracking.vel_p * e_v + integral
            acc = max(-a_tilt, min(a_tilt, want))
            if acc == want:  # anti-windup: no integration while the tilt limit holds
                integral += tracking.vel_i * e_v * dt_s
            v += (acc - tracking.drag_per_s * (v - tracking.wind_along_mps)) * dt_s
            x += v * dt_s
        else:
            x, v = vs.x, vs.v
        t += dt_s
        ts.append(t)
        ss.append(x)
        settled = ends[last] - x <= STOPPED_M and abs(v) < STOPPED_MPS
        if settled and not math.isnan(reached[last]) and t >= reached[last]:
            break  # at rest on the waypoint: the rest of the hold changes nothing
    end = max(t, done_at) if math.isfinite(done_at) else t
    return Run1D(np.asarray(ts), np.asarray(ss), reached, float(end), ends[last] - vs.x, vs.v,
                 vs.a)


def creep_on(togo_m: float, speed_mps: float, accel_mps2: float, hold_s: float,
             max_accel_mps2: float, jerk_mps3: float, dt_s: float = LOOP_S,
             ) -> tuple[float, float]:
    """The trajectory closing in on a stop ``togo_m`` ahead at ``speed_mps`` (and
    ``accel_mps2``) by PX4's braking law (:func:`max_speed_from_distance`) for ``hold_s``
    more seconds: (distance still to go (m), speed (m/s)). It stops early once too slow for
    :func:`departure_lock_s` to matter."""
    vs = VelocitySmoothing(max_accel_mps2, jerk_mps3)
    vs.x, vs.v, vs.a = -togo_m, speed_mps, accel_mps2
    t = 0.0
    while t < hold_s - 1e-9 and vs.v > TURNING_MIN_MPS:
        vs.update_durations(max_speed_from_distance(-vs.x, 0.0, max_accel_mps2, jerk_mps3))
        vs.step(min(dt_s, hold_s - t))
        vs.x = min(vs.x, 0.0)
        t += dt_s
    return -vs.x, vs.v


def departure_lock_s(togo_m: float, speed_mps: float, turn_rad: float,
                     acceptance_m: float) -> float:
    """How long (s) PX4 crawls away from a stop before it speeds up along the next leg.

    When the hold ends the trajectory is still creeping in, ``togo_m`` short of the waypoint at
    ``speed_mps`` (:func:`max_speed_from_distance` crawls the last metres). The next leg turns
    by ``turn_rad``, so the trajectory starts c = togo·|sin turn| off the new line and heads for
    the L1 crossing point: sin φ = c/L1 off the line, L1 = max(NAV_ACC_RAD, 5 m). While φ >
    acos(0.98) and the speed is above 0.2 m/s, ``PositionSmoothing::_isTurning`` holds the speed
    it had when the turn began; c shrinks as c·exp(−v·t/L1), so the crawl lasts
    L1/v · ln(c / (L1·sin acos 0.98)). On a PX4 v1.15.4 SIH flight of ours (1.55 m short at 0.31
    m/s, a 77° turn) it lasted 6.8 s; this gives 6.95 s. Zero when the crawl is too slow or
    the turn too slight."""
    l1 = max(acceptance_m, L1_MIN_M)
    c0 = togo_m * abs(math.sin(turn_rad))
    c_end = l1 * math.sqrt(1.0 - TURNING_COS * TURNING_COS)
    if speed_mps <= TURNING_MIN_MPS or c0 <= c_end:
        return 0.0
    return l1 / speed_mps * math.log(c0 / c_end)


@dataclass(frozen=True)
class SampledLegs:
    """Straight legs flown from rest, each sampled in time: ``length_m`` (n,), ``total_s``
    (n,) the time each leg's waypoint counts as reached, and per leg the samples ``t_s[k]``,
    ``s_m[k]`` of the distance flown. :meth:`state` answers like
    :class:`validator.motion.scurve.Profiles1D`, with the distance scaled so that a leg ends on
    its waypoint exactly when it counts as reached (the last ``acceptance_m`` is closed during
    the hold). ``arrival`` (n, 3): the trajectory when each leg counts as reached: distance
    still to go (m), speed (m/s) and acceleration (m/s²), zeros for a leg of no length."""

    length_m: NDArray[np.float64]
    total_s: NDArray[np.float64]
    t_s: tuple[NDArray[np.float64], ...]
    s_m: tuple[NDArray[np.float64], ...]
    arrival: NDArray[np.float64]

    def state(self, leg: NDArray[np.int64], t: NDArray[np.float64]
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Position (m along the leg), speed and acceleration of leg ``leg[i]`` at ``t[i]``
        (s from the leg's start)."""
        leg = np.asarray(leg, dtype=np.int64)
        t = np.asarray(t, dtype=float)
        pos, vel, acc = np.zeros(t.shape), np.zeros(t.shape), np.zeros(t.shape)
        for k in np.unique(leg):
            sel = leg == k
            ts, ss = self.t_s[k], self.s_m[k]
            end = float(np.interp(self.total_s[k], ts, ss))
            scale = self.length_m[k] / end if end > 0 else 0.0
            tt = np.clip(t[sel], 0.0, self.total_s[k])
            pos[sel] = np.interp(tt, ts, ss) * scale
            v = np.gradient(ss, ts) * scale if ts.size > 1 else np.zeros(1)
            a = np.gradient(v, ts) if ts.size > 1 else np.zeros(1)
            vel[sel] = np.interp(tt, ts, v)
            acc[sel] = np.interp(tt, ts, a)
        return pos, vel, acc


def rest_to_rest(
    lengths_m: NDArray[np.float64], cruise_mps: float, accel_mps2: float, jerk_mps3: float,
    acceptance_m: float, tracking: Tracking | None = None, arrival_lag_s: float = 0.0,
) -> SampledLegs:
    """Each straight leg of ``lengths_m`` flown alone, from rest to a stop (:func:`fly_run`):
    how a PX4 mission times legs that end in a hold."""
    ts, ss, total, arrival = [], [], [], []
    for length in np.asarray(lengths_m, dtype=float):
        if length <= 0:
            ts.append(np.zeros(1))
            ss.append(np.zeros(1))
            total.append(0.0)
            arrival.append((0.0, 0.0, 0.0))
            continue
        run = _rest_to_rest(float(length), cruise_mps, accel_mps2, jerk_mps3, acceptance_m,
                            tracking, arrival_lag_s)
        ts.append(run.t_s)
        ss.append(run.s_m)
        total.append(float(run.reached_s[-1]))
        arrival.append((run.end_togo_m, run.end_speed_mps, run.end_accel_mps2))
    return SampledLegs(np.asarray(lengths_m, dtype=float), np.asarray(total), tuple(ts),
                       tuple(ss), np.asarray(arrival, dtype=float).reshape(-1, 3))


@functools.lru_cache(maxsize=4096)
def _rest_to_rest(length_m: float, cruise_mps: float, accel_mps2: float, jerk_mps3: float,
                  acceptance_m: float, tracking: Tracking | None,
                  arrival_lag_s: float) -> Run1D:
    return fly_run([length_m], [0.0], [cruise_mps], accel_mps2, jerk_mps3, acceptance_m, 0.0,
                   tracking=tracking, arrival_lag_s=arrival_lag_s)


__all__ = [
    "LOOP_S",
    "Run1D",
    "SampledLegs",
    "Tracking",
    "VelocitySmoothing",
    "corner_speed_mps",
    "creep_on",
    "departure_lock_s",
    "fly_run",
    "max_speed_from_distance",
    "rest_to_rest",
]
