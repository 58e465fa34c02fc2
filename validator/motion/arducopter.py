"""The ``arducopter`` profile: ArduCopter 4.x S-curve navigation with corner blending.

Every leg is planned from rest to rest as a jerk-limited profile (WPNAV_JERK, WPNAV_ACCEL,
speed = the DO_CHANGE_SPEED in force or WPNAV_SPEED, capped by ANGLE_MAX and the vehicle's top
speed), so a leg shorter than about v²/A + v·A/J never reaches v. When a waypoint has no hold,
the next leg starts while this one decelerates, as soon as the blended target stays within
WPNAV_RADIUS of the waypoint, slower than both legs' speeds and within the corner acceleration
(WPNAV_ACCEL_C, 0 = twice WPNAV_ACCEL): the two profiles add up, which rounds the corner on the
inside of the turn and passes collinear waypoints without stopping. The waypoint counts as
reached half-way through that overlap. Holds are truncated to whole seconds, as ArduCopter
stores them (:func:`validator.autopilot.rules.stored_hold_s`). Speed is capped by the
lean-limited top speed (:func:`~validator.motion.limits.top_speed_mps`: ANGLE_MAX or
PSC_ANGLE_MAX against a drag fitted to the SITL quad, VEHICLE_DRAG, at the air density of
ALT_AMSL). A takeoff from the
ground climbs after the lift-off delay; a landing descends at WPNAV_SPEED_DN to LAND_ALT_LOW,
then at LAND_SPEED, and ends when the land detector fires; every stop at a waypoint is counted
STOP_LAG_S after the S-curve ends (all three fitted to ArduCopter 4.5.6 SITL flights,
``../shared/data/arducopter-sitl-2``), and a corner flown through sharper than
CORNER_LAG_FREE_DEG lags its blend by :func:`corner_lag_s` (the target's clock slows through
it). In wind (WIND_SPEED, WIND_FROM) the top speed holds
in the air, less what the gusts take: each leg is capped at the ground speed its course leaves
the vehicle leaning at its limit, with the drag of ArduPilot's SITL quad, per body axis
(:func:`validator.motion.arducopter_speed.lean_caps_mps`); gusts do not move the modelled
track, and a plan commands no more than any multicopter of that airspeed holds on the course
(:func:`validator.motion.arducopter_speed.leg_speeds_mps`, so the replay flies its legs as
commanded). A leg entered through a corner flown through first runs
at the speed of the leg before, as ArduCopter builds its S-curve then, and changes to its own
after, as far as half the S-curve's constant part takes the change
(:mod:`validator.motion.corner_speed`); the S-curve is the firmware's whatever the vehicle
does, and the vehicle follows it no faster than its lean limit lets it fly the leg's course
(where it leans to that limit for a whole leg, :func:`lean_limited_findings` notes it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from validator.autopilot.rules import stored_hold_s
from validator.flight import Finding, Flight
from validator.item_numbers import item_label
from validator.motion.arducopter_speed import (
    arducopter_accel_mps2,
    arducopter_top_speed_mps,
    held_lean_top_speed_mps,
    held_top_speed_mps,
    lean_caps_mps,
)
from validator.motion.corner_speed import corner_changed_speeds_mps, corner_first_speeds_mps
from validator.motion.limits import GRAVITY_MPS2
from validator.motion.path import (
    FlownPath,
    LegGeometry,
    active_leg,
    kinematic_limit,
    leg_geometry,
    superpose,
    time_grid,
)
from validator.motion.profile import Profile
from validator.motion.scurve import (
    SEG_CHANGE_START,
    SEG_DECEL_START,
    Profiles1D,
    accel_phase_gain_mps,
    rest_to_rest_m,
    scurve_to_touchdown,
)

CORNER_SEARCH_STEP_S = 0.0025  # ArduCopter checks the corner condition at its 400 Hz loop rate
# Arming to the start of the climb: the arming delay, motor spool-up and throttle slew until
# the land detector lets go (TKOFF_SLEW_TIME); measured 3.1 s in every SITL flight (fitted with
# the climb below so that NAV_TAKEOFF completes when it did, 18.2 s after arming from 30 m).
LIFTOFF_DELAY_S = 3.1
# Touchdown to "land complete": ArduCopter's land detector needs a second of low throttle and
# no descent; measured 1.57 s in every SITL flight (disarm follows 0.5 s later).
LAND_DETECT_S = 1.57
# A stop at a waypoint comes later than the S-curve's own end: ArduCopter slows the S-curve's
# clock while the vehicle lags its target (AC_WPNav's track scaler). Measured 0.3-1.2 s per
# horizontal rest-to-rest leg in the SITL flights, median 0.6 s.
STOP_LAG_S = 0.6
# A sharp corner flown through costs more than the blend of its two S-curves, for the same
# reason: past about 72° of turn the vehicle falls behind the blended target and its clock
# slows. Measured on ArduCopter 4.5.6 SITL, corners of 20-178° flown through at 6 and 10 m/s
# (100 m legs): the extra grows with the turn and the speed, fitted as
# CORNER_LAG_S_PER_MPS_DEG x speed x (turn - CORNER_LAG_FREE_DEG), within 0.2 s of every corner
# (10 m/s: 0.3 s at 100°, 1.05 s at 172°; 6 m/s: 0.15 s and 0.8 s).
CORNER_LAG_FREE_DEG = 72.0
CORNER_LAG_S_PER_MPS_DEG = 0.00108
# A leg flown at the lean limit after a corner gets a note from this long (m) and this much
# (m/s) above what the lean limit flies: shorter legs pass in a corner's transient
LEAN_NOTE_MIN_M = 20.0
LEAN_NOTE_SLACK_MPS = 0.1


@dataclass(frozen=True)
class ScurveLimits:
    """What ArduCopter's horizontal S-curves are planned with: the speed of a leg without
    DO_CHANGE_SPEED (WPNAV_SPEED, m/s), the fastest any leg flies (the lean- and drag-limited
    top speed, m/s), the acceleration (WPNAV_ACCEL capped by the lean angle, m/s²) and the
    jerk (WPNAV_JERK, m/s³)."""

    default_speed_mps: float
    top_speed_mps: float
    accel_mps2: float
    jerk_mps3: float


def scurve_limits(profile: Profile) -> ScurveLimits:
    """The horizontal S-curve limits of an ``arducopter`` profile (the one derivation the
    replay and the planner's flyable timing share)."""
    return ScurveLimits(profile.si("WPNAV_SPEED"), arducopter_top_speed_mps(profile),
                        arducopter_accel_mps2(profile), profile.si("WPNAV_JERK"))


@dataclass(frozen=True)
class _LegSpeeds:
    """Per leg (m/s unless said): ``cmd`` the speed commanded (DO_CHANGE_SPEED or WPNAV_SPEED),
    ``speed`` its limit along the track, ``first`` and ``cruise`` the speeds ArduCopter's
    S-curve first runs at and then changes to (a leg entered through a corner flown through),
    ``lean_caps`` the ground speed the lean limit flies on the leg's course; ``accel`` (m/s²),
    ``jerk`` (m/s³) and ``ramp`` (s) its S-curve limits, ``touchdown`` the speed a final
    descent ends at below LAND_ALT_LOW (LAND_SPEED; 0 on every other leg)."""

    cmd: NDArray[np.float64]
    speed: NDArray[np.float64]
    first: NDArray[np.float64]
    cruise: NDArray[np.float64]
    lean_caps: NDArray[np.float64]
    accel: NDArray[np.float64]
    jerk: NDArray[np.float64]
    ramp: NDArray[np.float64]
    touchdown: NDArray[np.float64]


def _leg_speeds(flight: Flight, profile: Profile, geom: LegGeometry) -> _LegSpeeds:
    """Every leg's speeds and S-curve limits as ArduCopter builds them (:class:`_LegSpeeds`)."""
    legs = flight.legs
    lim = scurve_limits(profile)
    cmd = np.array(
        [lim.default_speed_mps if leg.kind == "rtl" or leg.speed_mps is None else leg.speed_mps
         for leg in legs],
        dtype=float,
    )
    unit = geom.unit
    # what the vehicle flies at its lean limit, held through the gusts (the plan's commands
    # are within it); capped by what the plan allows (VEHICLE_SPEED_MAX)
    caps = lean_caps_mps(profile, unit, held_top_speed_mps(profile),
                         [f"mission {item_label(leg.item)}" for leg in legs], held=True)
    speed = kinematic_limit(unit, np.minimum(cmd, caps),
                            profile.si("WPNAV_SPEED_UP"), profile.si("WPNAV_SPEED_DN"))
    a_z = profile.si("WPNAV_ACCEL_Z")
    accel = kinematic_limit(unit, np.full(len(legs), lim.accel_mps2), a_z, a_z)
    vertical = np.hypot(unit[:, 0], unit[:, 1]) < 1e-9
    jerk = np.where(vertical, profile.si("PSC_JERK_Z"), lim.jerk_mps3)
    # ArduCopter lands at WPNAV_SPEED_DN (never slower than LAND_SPEED) down to LAND_ALT_LOW,
    # then at LAND_SPEED until the ground stops it
    landing = np.array([leg.kind == "land" for leg in legs]) & vertical
    touchdown = np.where(landing, profile.si("LAND_SPEED"), 0.0)
    speed = np.maximum(speed, touchdown)
    ramp = jerk_ramp_s(profile, jerk)
    blend = np.array([False] + [leg.pass_through for leg in legs[:-1]])
    # the S-curve's own speeds: the firmware builds and changes it whatever the vehicle does
    first = corner_first_speeds_mps(speed, np.roll(cmd, 1),
                                    blend & ~vertical & ~np.roll(vertical, 1),
                                    accel_phase_gain_mps(accel, jerk, ramp))
    built_const_m = geom.length_m - rest_to_rest_m(first, accel, jerk, ramp)
    cruise = corner_changed_speeds_mps(first, speed, built_const_m, ramp, accel, jerk)
    # what the vehicle can fly, not what the plan allows (VEHICLE_SPEED_MAX): nothing but the
    # lean limit holds the vehicle back from the speed the S-curve runs at
    lean_caps = lean_caps_mps(profile, unit, held_lean_top_speed_mps(profile), held=True)
    return _LegSpeeds(cmd, speed, first, cruise, lean_caps, accel, jerk, ramp, touchdown)


def _ardu_limits(
    flight: Flight, profile: Profile, geom: LegGeometry
) -> tuple[Profiles1D, NDArray[np.float64]]:
    """Every leg's S-curve (rest to rest; a landing ends at LAND_SPEED below LAND_ALT_LOW), and
    each leg's speed limit along its track (m/s)."""
    v = _leg_speeds(flight, profile, geom)
    prof = scurve_to_touchdown(geom.length_m, np.minimum(v.cruise, v.lean_caps), v.accel,
                               v.jerk, v.ramp, v.touchdown,
                               np.where(v.touchdown > 0, profile.si("LAND_ALT_LOW"), 0.0),
                               np.minimum(v.first, v.lean_caps))
    return prof, v.speed


def lean_limited_findings(flight: Flight, profile: Profile) -> list[Finding]:
    """A note for each leg of at least :data:`LEAN_NOTE_MIN_M` whose S-curve, built at the
    faster speed of the leg before and entered through a corner flown through, never slows to
    what the vehicle's lean limit flies along the leg's course (in wind, less upwind) although
    the leg's own command is within it: the vehicle flies that leg leaning at its limit, with
    no authority left for gusts and at a speed its drag sets, so the replay's timing there is
    only as good as the drag model (:func:`validator.motion.arducopter_speed.lean_caps_mps`,
    fitted to SITL's quad)."""
    geom = leg_geometry(flight.legs)
    v = _leg_speeds(flight, profile, geom)
    out: list[Finding] = []
    for k in np.flatnonzero((v.cruise > v.lean_caps + LEAN_NOTE_SLACK_MPS) & (v.cmd <= v.lean_caps)
                            & (geom.length_m >= LEAN_NOTE_MIN_M)):
        leg = flight.legs[k]
        out.append(Finding(
            "note", f"the leg after the corner is flown leaning at the lean limit: "
            f"ArduCopter builds its S-curve at the leg before's {v.cmd[k - 1]:.1f} m/s and "
            f"has room to slow it only to {v.cruise[k]:.1f} m/s, more than the "
            f"{v.lean_caps[k]:.1f} m/s the lean limit flies on this course (commanded "
            f"{v.cmd[k]:.1f}): the replay's timing here rests on the drag model, and the "
            f"vehicle has no authority left for gusts", leg.item))
    return out


def jerk_ramp_s(profile: Profile, jerk_mps3: NDArray[np.float64]) -> NDArray[np.float64]:
    """Time (s) ArduCopter takes to ramp the jerk from 0 to its limit.

    A multicopter accelerates by leaning, so jerk cannot change instantly: ArduCopter limits
    snap to half of min(J·π/(2·ATC_INPUT_TC), ATC_ACCEL_R_MAX·g), i.e. a ramp of
    max(2·ATC_INPUT_TC, J·π/(ATC_ACCEL_R_MAX·g)) seconds.
    """
    tc = max(profile.si("ATC_INPUT_TC"), 0.1)
    by_rate = jerk_mps3 * math.pi / (profile.si("ATC_ACCEL_R_MAX") * GRAVITY_MPS2)
    return np.asarray(np.maximum(2.0 * tc, by_rate), dtype=float)


def corner_overlaps_s(
    geom: LegGeometry,
    prof: Profiles1D,
    corners: NDArray[np.int64],
    speed_max_mps: NDArray[np.float64],
    radius_m: float,
    corner_accel_mps2: float,
) -> NDArray[np.float64]:
    """How long (s) leg ``i+1`` overlaps the end of leg ``i``, for each ``i`` in ``corners``.

    ArduCopter's corner rule: the next leg may start once leg ``i`` decelerates and has no more
    time left than the next leg's acceleration phase; it starts at the first moment the blended
    target at mid-overlap lies within ``radius_m`` of the waypoint, is slower than both legs'
    speed limits ``speed_max_mps`` (per leg) and has a horizontal acceleration below
    ``corner_accel_mps2``. 0 when that moment never comes (the leg ends, then the next starts).
    Searched on a coarse grid, then refined to :data:`CORNER_SEARCH_STEP_S`.
    """
    i = np.asarray(corners, dtype=np.int64)
    out = np.zeros(i.size)
    if i.size == 0:
        return out
    T = prof.total_s[i]
    tau_max = np.minimum(T - prof.boundary_time_s(SEG_DECEL_START)[i],
                         prof.boundary_time_s(SEG_CHANGE_START)[i + 1])
    L = geom.length_m
    live = (tau_max > 0) & (L[i] > 0) & (L[i + 1] > 0)
    u1, u2 = geom.unit[i], geom.unit[i + 1]
    vmax = np.minimum(speed_max_mps[i], speed_max_mps[i + 1])

    def passes(tau: NDArray[np.float64]) -> NDArray[np.bool_]:
        """tau (c, K): does the corner rule hold with that much time left on leg i?"""
        c, k = tau.shape
        leg = np.repeat(i, k)
        half = (tau / 2.0).ravel()
        p1, v1, a1 = (x.reshape(c, k, 1) for x in prof.state(leg, np.repeat(T, k) - half))
        p2, v2, a2 = (x.reshape(c, k, 1) for x in prof.state(leg + 1, half))
        a, b = u1[:, None, :], u2[:, None, :]
        pos = -(L[i][:, None, None] - p1) * a + p2 * b
        vel = v1 * a + v2 * b
        acc = a1 * a + a2 * b
        return np.asarray(
            (np.linalg.norm(pos, axis=2) < radius_m)
            & (np.linalg.norm(vel, axis=2) < vmax[:, None])
            & (np.hypot(acc[..., 0], acc[..., 1]) < corner_accel_mps2)
        )

    coarse_n = 128
    frac = 1.0 - np.arange(coarse_n) / coarse_n  # from tau_max down, scanning forward in time
    tau = tau_max[:, None] * frac[None, :]
    ok = passes(tau) & live[:, None]
    first = np.argmax(ok, axis=1)
    found = ok[np.arange(i.size), first]
    # refine between the last failing coarse point and the first passing one
    hi = np.where(first > 0, tau[np.arange(i.size), np.maximum(first - 1, 0)], tau_max)
    lo = tau[np.arange(i.size), first]
    fine_n = int(np.ceil(np.max(np.where(found, hi - lo, 0.0), initial=0.0)
                         / CORNER_SEARCH_STEP_S)) + 1
    fine = hi[:, None] - (hi - lo)[:, None] * np.linspace(0.0, 1.0, max(fine_n, 2))[None, :]
    fine[:, 0] = np.where(first > 0, fine[:, 1], fine[:, 0])  # hi itself failed (or is tau_max)
    ok_f = passes(fine) & found[:, None]
    first_f = np.argmax(ok_f, axis=1)
    got = ok_f[np.arange(i.size), first_f]
    out = np.where(got, fine[np.arange(i.size), first_f], np.where(found, lo, 0.0))
    return np.asarray(out, dtype=float)


def corner_lag_s(turn_deg: ArrayLike, speed_mps: ArrayLike) -> NDArray[np.float64]:
    """How much later (s) than the blended S-curves ArduCopter leaves a corner flown through
    that turns ``turn_deg`` (degrees between the two legs' directions) at ``speed_mps`` (the
    slower leg's peak speed): 0 up to :data:`CORNER_LAG_FREE_DEG`, then growing with both."""
    turn = np.asarray(turn_deg, dtype=float)
    return np.asarray(CORNER_LAG_S_PER_MPS_DEG * np.asarray(speed_mps, dtype=float)
                      * np.maximum(turn - CORNER_LAG_FREE_DEG, 0.0), dtype=float)


def _turns_deg(geom: LegGeometry, corners: NDArray[np.int64]) -> NDArray[np.float64]:
    """The horizontal turn (degrees) at the end of each leg in ``corners`` into the next."""
    a, b = geom.unit[corners, :2], geom.unit[corners + 1, :2]
    na, nb = np.hypot(a[:, 0], a[:, 1]), np.hypot(b[:, 0], b[:, 1])
    cos = np.einsum("ij,ij->i", a, b) / np.maximum(na * nb, 1e-12)
    turn = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    return np.where((na > 0.5) & (nb > 0.5), turn, 0.0)  # a climb or descent: no turn


def fly(flight: Flight, profile: Profile, dt_s: float) -> FlownPath:
    """Fly ``flight`` with an ``arducopter`` profile, sampled every ``dt_s`` seconds."""
    legs = flight.legs
    geom = leg_geometry(legs)
    prof, speed = _ardu_limits(flight, profile, geom)
    total = prof.total_s
    radius = profile.si("WPNAV_RADIUS")
    corner_acc = profile.si("WPNAV_ACCEL_C") or 2.0 * profile.si("WPNAV_ACCEL")
    hold = np.array([stored_hold_s(leg.hold_s, "ardupilot") for leg in legs], dtype=float)
    hold += np.array([profile.si("RTL_LOIT_TIME") if leg.kind == "rtl" else 0.0 for leg in legs])
    n = len(legs)
    start = np.zeros(n)
    reached = np.zeros(n)
    done = np.zeros(n)
    blend = np.array([leg.pass_through for leg in legs[:-1]] + [False])
    corners = np.flatnonzero(blend)
    overlap = np.zeros(n)
    overlap[corners] = corner_overlaps_s(geom, prof, corners, speed, radius, corner_acc)
    cruise = prof.end_speed_mps()
    lag = corner_lag_s(_turns_deg(geom, corners), np.minimum(cruise[corners], cruise[corners + 1]))
    # on the ground the climb waits for spool-up and lift-off; a landing ends when the land
    # detector has seen the touchdown
    liftoff = np.array([LIFTOFF_DELAY_S if leg.kind == "takeoff" and leg.start_alt_m <= 0
                        else 0.0 for leg in legs])
    hold += np.array([LAND_DETECT_S if leg.kind == "land" else 0.0 for leg in legs])
    stop_lag = np.where((geom.length_m > 0) & (np.hypot(geom.unit[:, 0], geom.unit[:, 1]) > 0.5),
                        STOP_LAG_S, 0.0)
    start[0] = liftoff[0]
    for i in range(n):
        end = start[i] + total[i]
        if blend[i]:
            tau = overlap[i]
            start[i + 1] = end - tau
            reached[i] = done[i] = end - tau / 2.0
        else:
            reached[i] = end + stop_lag[i]
            done[i] = reached[i] + hold[i]
            if i + 1 < n:
                start[i + 1] = done[i] + liftoff[i + 1]
    # the target's clock runs slow through each sharp corner (the blend keeps its shape)
    clock = _SlowClock(start[corners + 1], start[corners] + total[corners], lag)
    t = time_grid(float(clock.real_s(done[-1:])[0]), dt_s)
    target_t, rate = clock.target_s(t)
    pos, vel = superpose(geom, prof, start, target_t)
    done = clock.real_s(done)
    return FlownPath(t, pos, vel * rate[:, None], active_leg(done, t), clock.real_s(start),
                     clock.real_s(reached), done, clock.real_s(start + total))


class _SlowClock:
    """The real clock against the target's. Corner k's overlap of target time, from
    ``from_s`` to ``to_s`` (empty: a pause at rest), lasts ``lag_s`` longer in real time: the
    target's clock slows and recovers smoothly (a raised-cosine dip in its rate, over a target
    window centred on the overlap and at least ``lag_s`` wide, so the rate stays >= 0 and the
    velocity continuous). Windows are in the order the legs are flown; one that would start
    inside the one before starts where it ends."""

    _SAMPLES = 257  # per window, to invert its warp

    def __init__(self, from_s: NDArray[np.float64], to_s: NDArray[np.float64],
                 lag_s: NDArray[np.float64]) -> None:
        keep = np.asarray(lag_s) > 0
        a, b = np.asarray(from_s, dtype=float)[keep], np.asarray(to_s, dtype=float)[keep]
        e = np.asarray(lag_s, dtype=float)[keep]
        width = np.maximum(b - a, e)
        lo = (a + b) / 2 - width / 2
        for k in range(1, lo.size):  # windows one after the other
            lo[k] = max(lo[k], lo[k - 1] + width[k - 1])
        self.lo, self.width = lo, width
        self.real_len = width + e
        self.depth = 2 * e / self.real_len  # the rate's dip, <= 1
        # all the lag before window k (and, at k + 1, with its own)
        self._lag_upto = np.concatenate([[0.0], np.cumsum(e)])
        self.real_lo = lo + self._lag_upto[:-1]

    def _advance(self, k: NDArray[np.int64], s: NDArray[np.float64]) -> NDArray[np.float64]:
        """Target time advanced ``s`` real seconds into window ``k``."""
        w, c = self.real_len[k], self.depth[k]
        return np.asarray(s - c / 2 * (s - w / (2 * np.pi) * np.sin(2 * np.pi * s / w)),
                          dtype=float)

    def target_s(self, real_s: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                             NDArray[np.float64]]:
        """Target times (s) of real times, and the target clock's rate there."""
        t = np.asarray(real_s, dtype=float)
        if not self.lo.size:
            return t, np.ones_like(t)
        k = np.clip(np.searchsorted(self.real_lo, t, side="right") - 1, 0, self.lo.size - 1)
        s = t - self.real_lo[k]
        inside = (s >= 0) & (s <= self.real_len[k])
        outside = t - np.where(s < 0, self._lag_upto[k], self._lag_upto[k + 1])
        ss = np.clip(s, 0.0, self.real_len[k])
        target = np.where(inside, self.lo[k] + self._advance(k, ss), outside)
        rate = np.where(inside, 1 - self.depth[k] * (1 - np.cos(2 * np.pi * ss
                                                                 / self.real_len[k])) / 2, 1.0)
        return np.asarray(target, dtype=float), np.asarray(rate, dtype=float)

    def real_s(self, target_s: NDArray[np.float64]) -> NDArray[np.float64]:
        """Real times (s) of target times."""
        tau = np.asarray(target_s, dtype=float)
        if not self.lo.size:
            return tau
        k = np.clip(np.searchsorted(self.lo, tau, side="right") - 1, 0, self.lo.size - 1)
        into = tau - self.lo[k]
        inside = (into >= 0) & (into <= self.width[k])
        out = tau + np.where(into < 0, self._lag_upto[k], self._lag_upto[k + 1])
        for i in np.flatnonzero(inside):  # invert the window's warp by its samples
            s = np.linspace(0.0, self.real_len[k[i]], self._SAMPLES)
            adv = self._advance(np.full(s.size, k[i]), s)
            out[i] = self.real_lo[k[i]] + np.interp(into[i], adv, s)
        return np.asarray(out, dtype=float)
