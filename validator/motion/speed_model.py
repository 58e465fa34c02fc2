"""The vehicle's speed model: how fast a multicopter really flies and how long it takes for
straight legs from rest to rest, by the validator's own model of each autopilot
(:mod:`validator.motion.arducopter`, :mod:`validator.motion.px4_mission`).

One model for everyone who times a leg: the planner's re-timing
(:mod:`mission_planner.optimize.retime`), the exporter's leg speeds, the parameter writer's
speed limits and the commands' speed warnings. Speeds m/s, lengths m, times s; autopilot
parameters in the autopilot's own units.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from validator.autopilot.waypoint_radius import radius_params
from validator.motion.arducopter import ScurveLimits, jerk_ramp_s, scurve_limits
from validator.motion.arducopter_speed import (
    arducopter_top_speed_mps,
    held_top_speed_mps,
    leg_speeds_mps,
)
from validator.motion.limits import site_limits
from validator.motion.profile import Profile, flown_params, make_profile
from validator.motion.px4_mission import px4_rest_to_rest, px4_top_speed_mps
from validator.motion.scurve import scurve_rest_to_rest
from validator.site import Site
from validator.wind import check_flyable


class LegMotion(Protocol):
    """Straight legs flown from rest, as a model times them: each leg's length (m), the time
    (s) its waypoint counts as reached, and the motion along it
    (:class:`validator.motion.scurve.Profiles1D`, :class:`validator.motion.px4.SampledLegs`)."""

    @property
    def length_m(self) -> NDArray[np.float64]: ...

    @property
    def total_s(self) -> NDArray[np.float64]: ...

    def state(self, leg: NDArray[np.int64], t: NDArray[np.float64]
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]: ...


def motion_profile(site: Site, autopilot: str = "ardupilot",
                   params: Mapping[str, float] | None = None) -> Profile:
    """The validator's model of ``autopilot`` ("ardupilot": ``arducopter``, "px4": ``px4``)
    at the site's defaults and the parameters ``params`` (autopilot units) the plan will set
    (the waypoint radius, when not among them, as the exporter sets it by default:
    :func:`validator.autopilot.waypoint_radius.radius_params`): the one model legs are timed
    with."""
    name = "px4" if autopilot == "px4" else "arducopter"
    chosen = {**radius_params(site, "px4" if autopilot == "px4" else "ardupilot"),
              **(params or {})}
    return make_profile(name, site_limits(site), flown_params(name, chosen))


def top_speed_mps(site: Site, autopilot: str = "ardupilot") -> float:
    """The fastest the site's vehicle really flies (m/s): the replay's own cap, for ArduCopter
    lean-limited against quadratic drag, for PX4 tilt-limited against linear drag."""
    profile = motion_profile(site, autopilot)
    if profile.name == "px4":
        return px4_top_speed_mps(profile)
    return arducopter_top_speed_mps(profile)


def cruise_speed_mps(site: Site, autopilot: str = "ardupilot") -> float:
    """The top speed (m/s) flyable plans are made and timed at: the site's V, or the vehicle's
    real top speed (:func:`top_speed_mps`) when that is lower."""
    return min(site.max_speed_mps, top_speed_mps(site, autopilot))


def commanded_top_speed_mps(site: Site, autopilot: str = "ardupilot") -> float:
    """The top airspeed (m/s) plans command in the site's wind: :func:`cruise_speed_mps`, or
    for ArduCopter in gusts the lower airspeed its lean limit holds through them
    (:func:`validator.motion.arducopter_speed.held_top_speed_mps`). A wind at or above it is
    refused."""
    cruise = cruise_speed_mps(site, autopilot)
    profile = motion_profile(site, autopilot)
    if profile.name == "px4":
        return cruise
    return min(cruise, held_top_speed_mps(profile))


def check_wind_flyable(site: Site, autopilot: str = "ardupilot", where: str = "wind") -> None:
    """Refuse (:class:`InputError`, one line naming ``where``) the site's wind at the flight
    altitude when it is at or above the top airspeed plans command
    (:func:`commanded_top_speed_mps`; in gusts the airspeed held through them): the vehicle
    planner's rule, which the wind study asks before it runs a trial."""
    wind = site.flight_wind
    if wind is None:
        return
    air = commanded_top_speed_mps(site, autopilot)
    check_flyable(air, wind, where, gusts=air < cruise_speed_mps(site, autopilot))


def leg_profiles(site: Site, lengths_m: ArrayLike, speed_mps: float | None = None,
                 autopilot: str = "ardupilot",
                 params: Mapping[str, float] | None = None,
                 unit_xy: ArrayLike | None = None) -> LegMotion:
    """Straight legs flown from rest to rest as the autopilot flies them (the validator's
    model, :func:`motion_profile`) at ``speed_mps`` (default: :func:`cruise_speed_mps`), never
    above the vehicle's top speed. ArduCopter: S-curves with acceleration ``uav.max_accel``
    capped by the lean angle and jerk ``uav.max_jerk`` with ArduCopter's jerk ramp. PX4: its
    own braking rule and velocity smoothing, a leg ending when the vehicle is within
    NAV_ACC_RAD of its waypoint (:func:`validator.motion.px4.rest_to_rest`). In the site's
    wind each leg, along its direction ``unit_xy`` (n, 2), is timed at most at the ground
    speed its course leaves (:func:`leg_speeds_mps`)."""
    profile = motion_profile(site, autopilot, params)
    lengths = np.atleast_1d(np.asarray(lengths_m, dtype=float))
    if profile.name == "px4":
        top = px4_top_speed_mps(profile)
        speed = top if speed_mps is None else min(speed_mps, top)
        return px4_rest_to_rest(profile, lengths, speed, unit_xy)
    lim = scurve_limits(profile)
    jerk = np.full(lengths.shape, lim.jerk_mps3)
    speed = scurve_speed_mps(lim, speed_mps)
    speeds = (np.full(lengths.shape, float(speed)) if unit_xy is None
              else leg_speeds_mps(profile, speed, unit_xy))
    return scurve_rest_to_rest(
        lengths,
        speeds,
        np.full(lengths.shape, lim.accel_mps2),
        jerk,
        jerk_ramp_s(profile, jerk),
    )


def scurve_speed_mps(lim: ScurveLimits, speed_mps: float | None = None) -> float:
    """The speed (m/s) ArduCopter's S-curve legs are timed at: ``speed_mps`` (default
    WPNAV_SPEED), never above WPNAV_SPEED or the vehicle's top speed."""
    top = min(lim.default_speed_mps, lim.top_speed_mps)
    return top if speed_mps is None else min(speed_mps, top)
