"""The ``px4`` profile: PX4 v1.15 mission following, a rounded path flown by PX4's own rules.

Its rules are ported in :mod:`validator.motion.px4`: toward each waypoint the fastest speed from
which it can still arrive, with PX4's conservative 2·A/J reaction delay (MPC_ACC_HOR,
MPC_JERK_AUTO), smoothed by its jerk-limited velocity smoother; corners rounded by an arc
inside NAV_ACC_RAD at PX4's corner speed (MPC_XY_TRAJ_P); a waypoint with a hold stops the
vehicle, and the hold starts when the vehicle is within NAV_ACC_RAD (NAV_MC_ALT_RAD
vertically). Leaving a stop for a leg that turns, the vehicle may crawl for seconds before it
speeds up (:func:`validator.motion.px4.departure_lock_s`); the model waits at the waypoint that
long. The vehicle follows that trajectory through PX4's position and velocity loops
against a linear drag (VEHICLE_LIN_DRAG, SIH's quad by default) within MPC_TILTMAX_AIR, which
also sets its top speed. Takeoff climbs after PX4_LIFTOFF_DELAY_S; a landing descends at
MPC_Z_V_AUTO_DN, slowing to MPC_LAND_SPEED between MPC_LAND_ALT1 and MPC_LAND_ALT2, and ends
PX4_LAND_DETECT_S after touchdown. Holds keep fractional seconds. Checked on PX4 v1.15.4 SIH
flights of our plans (``tests/data/px4-sih``). In wind (WIND_SPEED, WIND_FROM) the drag acts
on the speed through the air, each run's along and cross parts taken along its chord
(:class:`validator.motion.px4.Tracking`); PX4's SIH itself has no wind, so this part is
not calibrated on flights.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from validator.flight import Flight
from validator.item_numbers import item_label
from validator.motion import px4
from validator.motion.limits import GRAVITY_MPS2
from validator.motion.path import FlownPath, active_leg, leg_geometry, time_grid
from validator.motion.profile import Profile, profile_wind
from validator.wind import course_speeds_mps

# PX4 v1.15 SIH (quad x), measured on flights of our plans: arming to the start of the climb
# (spool-up and the MPC_TKO_RAMP_T takeoff ramp), and touchdown to disarm (land detector, then
# COM_DISARM_LAND).
PX4_LIFTOFF_DELAY_S = 3.0
PX4_LAND_DETECT_S = 2.5
# PX4 counts a stop waypoint reached this long after the straight-line model does: closing in,
# the vehicle also converges on the planned line (PositionSmoothing's L1 crossing point),
# which slows its last metre. Median over the stops of the SIH flights in tests/data/px4-sih.
PX4_ARRIVAL_LAG_S = 0.9


def _runs(flight: Flight) -> list[list[int]]:
    """Legs grouped into runs the vehicle flies without stopping."""
    runs: list[list[int]] = [[]]
    for k, leg in enumerate(flight.legs):
        runs[-1].append(k)
        if not leg.pass_through:
            runs.append([])
    return [r for r in runs if r]


@dataclass(frozen=True)
class _RunPath:
    """One run's path: arc-length samples ``s_m`` and ``points_m`` (3-D), the speed cap on
    the corners' arcs (``cap_mps``, inf on straights), each waypoint's arc length (mid-corner;
    the run's end last) and the speed PX4 flies through it (0 at the end)."""

    s_m: NDArray[np.float64]
    points_m: NDArray[np.float64]
    cap_mps: NDArray[np.float64]
    waypoint_s_m: NDArray[np.float64]
    through_mps: NDArray[np.float64]


def _run_path(
    start_m: NDArray[np.float64], ends_m: NDArray[np.float64], cruise_mps: NDArray[np.float64],
    profile: Profile, ds_m: float = 0.05,
) -> _RunPath:
    """The path of a run from ``start_m`` through the legs' end points ``ends_m`` (k, 3):
    corners rounded by an arc tangent to both legs at NAV_ACC_RAD (or half a leg) from the
    waypoint, flown at :func:`~validator.motion.px4.corner_speed_mps` at most."""
    acc_rad = profile.si("NAV_ACC_RAD")
    accel, jerk = profile.si("MPC_ACC_HOR"), profile.si("MPC_JERK_AUTO")
    pts = np.vstack([start_m[None, :], ends_m])
    delta = np.diff(pts, axis=0)
    length = np.linalg.norm(delta, axis=1)
    unit = np.divide(delta, length[:, None], out=np.zeros_like(delta), where=length[:, None] > 0)
    k = len(ends_m)
    d_out = np.zeros(k)
    radius = np.full(k, np.inf)
    through = np.zeros(k)
    for j in range(k - 1):
        if length[j] <= 0 or length[j + 1] <= 0:
            continue
        theta = math.acos(float(np.clip(np.dot(unit[j], unit[j + 1]), -1.0, 1.0)))
        exit_mps = px4.max_speed_from_distance(float(length[j + 1]), 0.0, accel, jerk)
        through[j] = min(px4.corner_speed_mps(theta, accel, acc_rad, profile.si("MPC_XY_TRAJ_P")),
                         exit_mps, cruise_mps[j], cruise_mps[j + 1])
        if theta < 1e-3:
            continue  # straight on: no corner
        if theta > math.pi - 1e-3:
            radius[j] = 0.0  # reversal: stop at the waypoint
            through[j] = 0.0
            continue
        d_out[j] = min(acc_rad, length[j] / 2.0, length[j + 1] / 2.0)
        radius[j] = d_out[j] / math.tan(theta / 2.0)
    s_parts, p_parts, c_parts = [], [], []
    wp_s = np.zeros(k)
    s0 = 0.0
    for j in range(k):
        d_in = d_out[j - 1] if j > 0 else 0.0
        straight = max(length[j] - d_in - d_out[j], 0.0)
        m = max(int(math.ceil(straight / ds_m)), 1)
        f = np.linspace(0.0, straight, m + 1)
        begin = pts[j] + unit[j] * d_in
        s_parts.append(s0 + f)
        p_parts.append(begin + np.outer(f, unit[j]))
        c_parts.append(np.full(f.size, np.inf))
        s0 += straight
        wp_s[j] = s0
        if j + 1 < k and d_out[j] > 0 and radius[j] > 0:
            r = radius[j]
            theta = 2.0 * math.atan2(d_out[j], r)
            u1, u2 = unit[j], unit[j + 1]
            normal = u2 - np.dot(u1, u2) * u1
            normal /= np.linalg.norm(normal)
            centre = begin + u1 * straight + normal * r
            m = max(int(math.ceil(r * theta / ds_m)), 2)
            phi = np.linspace(0.0, theta, m + 1)[1:-1]
            s_parts.append(s0 + phi * r)
            p_parts.append(centre - np.outer(np.cos(phi), normal) * r
                           + np.outer(np.sin(phi), u1) * r)
            c_parts.append(np.full(phi.size, through[j]))
            wp_s[j] = s0 + r * theta / 2.0
            s0 += r * theta
    s = np.concatenate(s_parts)
    xyz = np.concatenate(p_parts)
    cap = np.concatenate(c_parts)
    keep = np.concatenate([[True], np.diff(s) > 1e-9])  # drop repeated joints
    return _RunPath(s[keep], xyz[keep], cap[keep], wp_s, through)


def fly(flight: Flight, profile: Profile, dt_s: float) -> FlownPath:
    """Fly ``flight`` with a ``px4`` profile, sampled every ``dt_s`` seconds."""
    legs = flight.legs
    n = len(legs)
    geom = leg_geometry(legs)
    px4_check_wind(profile, geom.unit[:, :2], [f"mission {item_label(leg.item)}" for leg in legs])
    vcap = min(profile.si("MPC_XY_VEL_MAX"), profile.si("VEHICLE_SPEED_MAX"))
    cruise = np.minimum([leg.speed_mps or profile.si("MPC_XY_CRUISE") for leg in legs], vcap)
    jerk = profile.si("MPC_JERK_AUTO")
    start, reached, done = np.zeros(n), np.zeros(n), np.zeros(n)
    t_parts, p_parts = [], []
    clock = 0.0
    here = geom.start[0].copy()
    # the trajectory as the last horizontal run left it (distance still to go, speed,
    # acceleration), its heading, and the holds in place since
    left: tuple[tuple[float, float, float], NDArray[np.float64], float] | None = None
    for run in _runs(flight):
        ends = geom.start[run] + geom.delta[run]
        first = legs[run[0]]
        item_start = clock
        # a climb or descent in place (the vehicle may still be closing in on its last
        # waypoint horizontally, as PX4 does while it lands)
        vertical = len(run) == 1 and (legs[run[0]].kind in ("takeoff", "land")
                                      or float(np.hypot(*geom.delta[run[0], :2])) < 1e-6)
        if first.kind == "takeoff" and first.start_alt_m <= 0:
            clock += PX4_LIFTOFF_DELAY_S
        if vertical:
            climb = ends[-1, 2] >= here[2]
            path = _run_path(here, ends, np.full(len(run), np.inf), profile)
            accel = profile.si("MPC_ACC_UP_MAX" if climb else "MPC_ACC_DOWN_MAX")
            limit = profile.si("MPC_Z_V_AUTO_UP" if climb else "MPC_Z_V_AUTO_DN")
            landing = legs[run[-1]].kind == "land"
            schedule = _land_schedule(profile, float(here[2])) if landing else None
            flown = px4.fly_run(path.waypoint_s_m, [0.0], [limit], accel, jerk,
                                0.0 if landing else profile.si("NAV_MC_ALT_RAD"),
                                PX4_LAND_DETECT_S if landing else legs[run[-1]].hold_s,
                                speed_profile=schedule)
        else:
            if left is not None:
                clock += departure_lock_s(profile, left[0], left[2], left[1],
                                          geom.delta[run[0], :2])
            path = _run_path(here, ends, cruise[run], profile)
            flown = px4.fly_run(path.waypoint_s_m, path.through_mps, cruise[run],
                                profile.si("MPC_ACC_HOR"), jerk, profile.si("NAV_ACC_RAD"),
                                legs[run[-1]].hold_s, cap_s_m=path.s_m, cap_mps=path.cap_mps,
                                tracking=_tracking(profile, ends[-1] - here),
                                arrival_lag_s=PX4_ARRIVAL_LAG_S)
        t_run = flown.t_s + clock
        xyz = np.stack([np.interp(flown.s_m, path.s_m, path.points_m[:, c]) for c in range(3)],
                       axis=1)
        t_parts.append(t_run)
        p_parts.append(xyz)
        heading = geom.delta[run[-1], :2]
        in_place = vertical and legs[run[-1]].kind not in ("takeoff", "land") and float(
            np.max(np.abs(geom.delta[run]))) < 1e-6
        if not vertical and float(np.hypot(*heading)) >= 1e-6:
            left = ((flown.end_togo_m, flown.end_speed_mps, flown.end_accel_mps2), heading, 0.0)
        elif left is not None and in_place:  # a second hold where the last run stopped
            left = (left[0], left[1], left[2] + flown.end_s)
        else:
            left = None
        for j, k in enumerate(run):
            start[k] = item_start if j == 0 else reached[run[j - 1]]
            reached[k] = done[k] = clock + flown.reached_s[j]
        done[run[-1]] = clock + flown.end_s
        clock = done[run[-1]]
        here = xyz[-1]
    t_abs = np.concatenate(t_parts)
    xyz_all = np.concatenate(p_parts)
    t = time_grid(float(done[-1]), dt_s)
    pos = np.stack([np.interp(t, t_abs, xyz_all[:, c]) for c in range(3)], axis=1)
    vel = np.gradient(pos, t, axis=0) if t.size > 1 else np.zeros_like(pos)
    return FlownPath(t, pos, vel, active_leg(done, t), start, reached, done)


def px4_run_reached_s(points_m: ArrayLike, speed_mps: float, profile: Profile
                      ) -> NDArray[np.float64]:
    """A ``px4`` profile's vehicle flying from rest at ``points_m[0]`` through the waypoints
    ``points_m[1:]`` (k + 1, 2) without a hold, stopping at the last, each leg at
    ``speed_mps`` at most (capped as :func:`px4_rest_to_rest` caps it, in the profile's wind
    too): (k,) the time (s) its navigator counts each waypoint reached (the last one's arrival
    lag included; no departure crawl, no hold). The corners are those :func:`fly` flies."""
    xy = np.asarray(points_m, dtype=float)[:, :2]
    pts = np.hstack([xy, np.zeros((len(xy), 1))])
    cruise = _leg_speeds_mps(profile, speed_mps, np.diff(xy, axis=0))
    path = _run_path(pts[0], pts[1:], cruise, profile)
    flown = px4.fly_run(path.waypoint_s_m, path.through_mps, cruise,
                        profile.si("MPC_ACC_HOR"), profile.si("MPC_JERK_AUTO"),
                        profile.si("NAV_ACC_RAD"), 0.0, cap_s_m=path.s_m, cap_mps=path.cap_mps,
                        tracking=_tracking(profile, pts[-1] - pts[0]),
                        arrival_lag_s=PX4_ARRIVAL_LAG_S)
    return np.asarray(flown.reached_s, dtype=float)


def departure_lock_s(profile: Profile, state: tuple[float, float, float], hold_s: float,
                     arriving: ArrayLike, leaving: ArrayLike) -> float:
    """How long (s) a ``px4`` profile's vehicle crawls away from a stop
    (:func:`validator.motion.px4.departure_lock_s`). ``state``: its trajectory still short of
    the waypoint (distance m, speed m/s, acceleration m/s²), which closes in for ``hold_s``
    more seconds; then it leaves along ``leaving`` after arriving along ``arriving``
    (horizontal direction vectors)."""
    accel, jerk = profile.si("MPC_ACC_HOR"), profile.si("MPC_JERK_AUTO")
    togo, speed = px4.creep_on(*state, hold_s, accel, jerk)
    a, b = np.asarray(arriving, dtype=float), np.asarray(leaving, dtype=float)
    na, nb = float(np.hypot(*a)), float(np.hypot(*b))
    if na < 1e-9 or nb < 1e-9:
        return 0.0
    turn = math.acos(float(np.clip(np.dot(a, b) / (na * nb), -1.0, 1.0)))
    return px4.departure_lock_s(togo, speed, turn, profile.si("NAV_ACC_RAD"))


def px4_top_speed_mps(profile: Profile) -> float:
    """The fastest a ``px4`` profile's vehicle flies (m/s): where its drag (VEHICLE_LIN_DRAG)
    uses up the tilt limit (g·tan MPC_TILTMAX_AIR), capped by MPC_XY_VEL_MAX and
    VEHICLE_SPEED_MAX."""
    drag = profile.si("VEHICLE_LIN_DRAG")
    tilt = math.radians(profile.si("MPC_TILTMAX_AIR"))
    top = GRAVITY_MPS2 * math.tan(tilt) / drag if drag > 0 else math.inf
    return min(top, profile.si("MPC_XY_VEL_MAX"), profile.si("VEHICLE_SPEED_MAX"))


def px4_rest_to_rest(profile: Profile, lengths_m: NDArray[np.float64],
                     speed_mps: float, unit_xy: ArrayLike | None = None) -> px4.SampledLegs:
    """Straight horizontal legs flown alone from rest to a hold by a ``px4`` profile at
    ``speed_mps`` (capped by :func:`px4_top_speed_mps`); see
    :func:`validator.motion.px4.rest_to_rest`. In the profile's wind each leg, along its
    direction ``unit_xy`` (n, 2), is flown at most at the ground speed its course leaves
    (:func:`validator.wind.ground_speed_mps`), against the drag of the air it moves through."""
    speed = min(speed_mps, px4_top_speed_mps(profile))
    args = (profile.si("MPC_ACC_HOR"), profile.si("MPC_JERK_AUTO"), profile.si("NAV_ACC_RAD"))
    if profile_wind(profile) is None or unit_xy is None:
        return px4.rest_to_rest(lengths_m, speed, *args, _tracking(profile), PX4_ARRIVAL_LAG_S)
    unit = np.atleast_2d(np.asarray(unit_xy, dtype=float))
    ground = _leg_speeds_mps(profile, speed, unit)
    parts = [px4.rest_to_rest(np.atleast_1d(float(length)), float(g), *args,
                              _tracking(profile, u), PX4_ARRIVAL_LAG_S)
             for length, g, u in zip(np.atleast_1d(lengths_m), ground, unit, strict=True)]
    return px4.SampledLegs(
        np.asarray(lengths_m, dtype=float), np.concatenate([p.total_s for p in parts]),
        tuple(t for p in parts for t in p.t_s), tuple(x for p in parts for x in p.s_m),
        np.concatenate([p.arrival for p in parts]).reshape(-1, 3))


def _leg_speeds_mps(profile: Profile, speed_mps: float, heading: NDArray[np.float64]
                    ) -> NDArray[np.float64]:
    """(n,) the speed (m/s) each leg along ``heading`` (n, 2) is flown at: ``speed_mps``
    capped by :func:`px4_top_speed_mps` and, in the profile's wind, by the ground speed the
    leg's course leaves (:func:`validator.wind.course_speeds_mps`; a wind too strong refused)."""
    top = px4_top_speed_mps(profile)
    h = np.atleast_2d(np.asarray(heading, dtype=float))
    cap = min(speed_mps, top)
    wind = profile_wind(profile)
    if wind is None:
        return np.full(len(h), cap)
    return np.minimum(course_speeds_mps(top, wind, h), cap)


def _tracking(profile: Profile, heading: ArrayLike | None = None) -> px4.Tracking:
    """PX4's tracking of a path along the horizontal direction ``heading`` (in the profile's
    wind: WIND_SPEED, WIND_FROM; none, or no heading: still air)."""
    along = cross = 0.0
    wind = profile_wind(profile)
    if wind is not None and heading is not None:
        h = np.asarray(heading, dtype=float)[:2]
        norm = float(np.hypot(*h))
        if norm > 1e-9:
            w = wind.vector_mps
            along = float(w @ h) / norm
            cross = abs(float(w[0] * h[1] - w[1] * h[0])) / norm
    return px4.Tracking(profile.si("MPC_XY_P"), profile.si("MPC_XY_VEL_P_ACC"),
                        profile.si("MPC_XY_VEL_I_ACC"), profile.si("MPC_TILTMAX_AIR"),
                        profile.si("VEHICLE_LIN_DRAG"), profile.si("MPC_XY_ERR_MAX"),
                        along, cross)


def px4_check_wind(profile: Profile, headings: NDArray[np.float64],
                   names: list[str] | None = None) -> None:
    """Refuse a wind at or above the ``px4`` profile's top airspeed
    (:func:`validator.wind.course_speeds_mps`; ``headings`` (n, 2) of the legs, ``names``)."""
    wind = profile_wind(profile)
    if wind is not None:
        course_speeds_mps(px4_top_speed_mps(profile), wind, headings, names)


def _land_schedule(profile: Profile, alt_m: float) -> tuple[NDArray[np.float64],
                                                                  NDArray[np.float64]]:
    """PX4's landing descent speed against the height still to go (m): MPC_Z_V_AUTO_DN down
    to MPC_LAND_ALT1, blending to MPC_LAND_SPEED at MPC_LAND_ALT2 and below."""
    alt1, alt2 = profile.si("MPC_LAND_ALT1"), profile.si("MPC_LAND_ALT2")
    fast, slow = profile.si("MPC_Z_V_AUTO_DN"), profile.si("MPC_LAND_SPEED")
    h = np.array([0.0, alt2, max(alt1, alt2 + 1e-3), max(alt_m, alt1) + 1.0])
    return h, np.array([slow, slow, fast, fast])
