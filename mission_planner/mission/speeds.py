"""Leg speeds and holds as the autopilot takes them: speed limit, slow legs, stop lags.

- **Speed limit.** A leg speed never exceeds the site's V: float excess is clipped (the leg
  then takes a hair longer than δ); an excess above 1 % is reported as a problem. S-curve legs
  and transits fly at V or the vehicle's real top speed, whichever is lower
  (:func:`validator.motion.speed_model.cruise_speed_mps`).
- **Slow legs.** ArduCopter ignores a DO_CHANGE_SPEED below 0.2 m/s (WPNAV_WP_SPEED_MIN), so
  a leg that would need less is flown at ``min_speed_mps`` and the waypoint holds for the
  rest of its slot: the slot keeps its length and the UAV ends it at the same place.
- **Stop lag.** ArduCopter reaches a waypoint it stops at
  :data:`validator.motion.arducopter.STOP_LAG_S` after the S-curve ends. A dynamics-aware plan
  (one with a ``solution.timing``) counts that lag as the start of the waypoint's
  hover (:mod:`mission_planner.optimize.retime`), so on ArduPilot each stop's hold is written
  net of it (``CycleStep.stop_lag_s``) and the cycle still lasts T.
- **Wind.** A dynamics-aware plan made for a wind commands each leg the ground speed it was
  timed with: the cruise speed, or upwind the lower ground speed the vehicle's top airspeed
  leaves along the leg's course (:func:`wind_speeds`; ArduCopter's WPNAV_SPEED and
  DO_CHANGE_SPEED are ground speeds), never above the still-air cruise speed. Transit legs
  likewise (:func:`transit_speeds`).
- **Capped legs.** A leg of ``MissionOptions.leg_speed_caps`` is commanded no faster than its
  cap (:func:`leg_caps_mps`), wherever it is: cycle or transit. The cycle then lasts longer
  than T by what the slower leg takes, which the report's replay says.
- **Whole-second holds.** ArduCopter stores a waypoint hold as whole seconds (it truncates).
  The build writes holds as :func:`validator.autopilot.rules.programmed_holds_s` says (for
  ArduPilot rounded by error diffusion along the cycle; PX4 keeps fractional holds); the
  summary reports the difference.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from mission_planner.mission.options import LEG_MATCH_M, LegCap
from mission_planner.mission.steps import CycleStep
from validator.motion.arducopter import STOP_LAG_S
from validator.motion.arducopter_speed import leg_speeds_mps
from validator.motion.profile import Profile, profile_wind
from validator.motion.px4_mission import px4_top_speed_mps
from validator.motion.speed_model import motion_profile
from validator.site import Site
from validator.wind import ground_speed_mps

SPEED_EXCESS_ALLOWED = 0.01  # relative excess over V clipped silently (solver tolerance)


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


def wind_speeds(steps: list[CycleStep], trajectory_m: NDArray[np.float64], site: Site,
                autopilot: str, timing_params: Mapping[str, float],
                speed_mps: float) -> list[CycleStep]:
    """The steps of a dynamics-aware plan with each S-curve leg's speed set to the ground
    speed it was timed with in the site's wind: ``speed_mps`` (the cruise speed), or less
    where the leg's course leaves less of the vehicle's top airspeed (the planner's own rule,
    :func:`validator.motion.arducopter_speed.leg_speeds_mps`; PX4's likewise)."""
    profile = motion_profile(site, autopilot, dict(timing_params))
    out: list[CycleStep] = []
    prev = trajectory_m[0]
    for s in steps:
        here = trajectory_m[s.index]
        d = here - prev
        prev = here
        length = float(np.hypot(*d))
        if not s.scurve or s.speed_mps is None or length <= 0:
            out.append(s)
            continue
        speed = float(_wind_capped_mps(profile, speed_mps, (d / length)[None, :])[0])
        out.append(replace(s, speed_mps=speed))
    return out


def _wind_capped_mps(profile: Profile, speed_mps: float, unit: NDArray[np.float64]
                     ) -> NDArray[np.float64]:
    """``speed_mps``, or along each unit course ``unit`` (L, 2) the lower ground speed the
    vehicle's top airspeed leaves in the profile's wind: ArduCopter's rule
    (:func:`validator.motion.arducopter_speed.leg_speeds_mps`), PX4's likewise."""
    if profile.name != "px4":
        return np.asarray(leg_speeds_mps(profile, speed_mps, unit), dtype=float)
    wind = profile_wind(profile)
    if wind is None:
        return np.full(len(unit), float(speed_mps))
    g = ground_speed_mps(px4_top_speed_mps(profile), wind.vector_mps, unit)
    return np.minimum(float(speed_mps), g)


def transit_speeds(path_m: NDArray[np.float64], site: Site, autopilot: str,
                   timing_params: Mapping[str, float], speed_mps: float,
                   caps: tuple[LegCap, ...] = ()) -> NDArray[np.float64]:
    """The speed (m/s) to command on each leg of a transit polyline ``path_m`` (P, 2): the
    transit speed ``speed_mps``, or in the site's wind the ground speed the vehicle's top
    airspeed leaves along the leg's course, or the leg's cap in ``caps``
    (:func:`leg_caps_mps`), whichever is lowest (the rule of :func:`wind_speeds`; a
    zero-length leg keeps ``speed_mps``).

    Commanded more than that, ArduCopter leans to its limit and gives up the track: SITL in
    8 m/s from 45° flew a transit leg commanded at 10 m/s (2.3 m/s left by the wind) at 3 m/s
    ground speed, 0.8 m downwind of it all the way, 2.6 m from the breakwater it was planned
    3.44 m from."""
    d = np.diff(np.asarray(path_m, dtype=float), axis=0)
    lengths = np.hypot(d[:, 0], d[:, 1])
    out = np.minimum(float(speed_mps), leg_caps_mps(path_m, caps))
    if site.flight_wind is None or not len(d):
        return out
    moving = lengths > 0
    profile = motion_profile(site, autopilot, dict(timing_params))
    out[moving] = np.minimum(out[moving], _wind_capped_mps(profile, float(speed_mps),
                                                           d[moving] / lengths[moving, None]))
    return out


def leg_caps_mps(path_m: NDArray[np.float64], caps: tuple[LegCap, ...]) -> NDArray[np.float64]:
    """(P-1,) the cap (m/s) of each leg of the polyline ``path_m`` (P, 2), +inf where ``caps``
    names none: the least cap of those whose start and end lie within :data:`LEG_MATCH_M` of
    the leg's."""
    path = np.asarray(path_m, dtype=float)
    out = np.full(max(len(path) - 1, 0), np.inf)
    for start, end, cap in caps:
        near = ((np.hypot(*(path[:-1] - start).T) <= LEG_MATCH_M)
                & (np.hypot(*(path[1:] - end).T) <= LEG_MATCH_M))
        out[near] = np.minimum(out[near], cap)
    return out


def capped_steps(steps: list[CycleStep], trajectory_m: NDArray[np.float64],
                 caps: tuple[LegCap, ...], rest_to_rest_s: Callable[[float, float], float]
                 ) -> list[CycleStep]:
    """The steps with each moving leg that ``caps`` names commanded no faster than its cap
    (the leg from the cycle's start, ``trajectory_m[0]``, to each step's waypoint in turn);
    an S-curve leg's time grows by what ``rest_to_rest_s(length_m, speed_mps)`` says the
    slower speed adds."""
    if not caps:
        return steps
    ends = np.array([trajectory_m[0]] + [trajectory_m[s.index] for s in steps], dtype=float)
    lengths = np.hypot(*np.diff(ends, axis=0).T)
    out = []
    for s, cap, length in zip(steps, leg_caps_mps(ends, caps), lengths, strict=True):
        if s.speed_mps is None or not s.speed_mps > cap:
            out.append(s)
            continue
        leg_s = s.leg_s
        if s.scurve:
            leg_s += rest_to_rest_s(float(length), float(cap)) - rest_to_rest_s(
                float(length), s.speed_mps)
        out.append(replace(s, speed_mps=float(cap), leg_s=leg_s))
    return out


def stop_lags(steps: list[CycleStep]) -> list[CycleStep]:
    """The steps with ArduCopter's stop lag (:data:`validator.motion.arducopter.STOP_LAG_S`) taken
    out of the hold of every waypoint the vehicle stops at after a leg (one that holds longer
    than the lag); hold-only steps and pass-through waypoints arrive without it."""
    return [replace(s, stop_lag_s=STOP_LAG_S)
            if s.speed_mps is not None and s.leg_s > 0 and s.hold_s > STOP_LAG_S else s
            for s in steps]
