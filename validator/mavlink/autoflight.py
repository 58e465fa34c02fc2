"""What the SITL vehicle flies in AUTO: the validator's replay of its mission, played back.

:func:`build_auto_track` resolves the mission the vehicle holds
(:func:`validator.flight.resolve_flight`), starts it where the vehicle is, flies it with the
validator's multicopter model (:func:`validator.replay.replay`, the same profiles and
parameters) and returns an :class:`AutoTrack`: position, velocity and mission progress as
functions of the time since AUTO began. So a mission flown by the SITL vehicle and the
validator's replay of it agree, up to the vehicle's sampling.

Positions are metres east/north of the vehicle's first home, altitudes metres above it; item
indices are 0-based plan indices (ArduPilot's mission seq is one more). A DO_SET_HOME moves the
home the vehicle holds where the resolved flight says (:mod:`validator.flight.home`), as the
leg after it becomes current (:attr:`AutoTrack.homes`); one at the current position takes where
the flown track is then (on the corner it cut), not the waypoint the resolved flight stands in.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from validator.flight import Flight, Home, resolve_flight
from validator.flight.home import set_home_source
from validator.geodesy import LocalFrame
from validator.motion.limits import VehicleLimits
from validator.motion.profile import Profile, flown_params, make_profile
from validator.plan_format import Autopilot, Cmd, Plan
from validator.replay import replay
from validator.site import DEFAULT_MAX_ACCEL_MPS2, DEFAULT_MAX_JERK_MPS3, Site

TAKEOFF_DONE_M = 0.5  # a takeoff item is complete at once within this of its altitude


def vehicle_site(frame: LocalFrame, max_speed_mps: float) -> Site:
    """A site holding only what resolving the vehicle's mission needs (:func:`resolve_flight`:
    the home frame, and the speed of legs without DO_CHANGE_SPEED): no ground nodes or zones,
    as the vehicle knows nothing of the plan's site. The flight model takes the vehicle's
    limits instead (:class:`~validator.motion.limits.VehicleLimits`)."""
    return Site(
        name="sitl-vehicle",
        frame=frame,
        home_xy_m=np.zeros(2),
        altitude_m=0.0,
        max_speed_mps=max_speed_mps,
        period_s=1.0,
        slots=1,
        max_accel_mps2=DEFAULT_MAX_ACCEL_MPS2,
        max_jerk_mps3=DEFAULT_MAX_JERK_MPS3,
        p_avg_w=1.0,
        p_peak_w=1.0,
        beta0=1.0,
        noise_w=1.0,
        gn_names=(),
        gn_xy_m=np.zeros((0, 2)),
        nfz_names=(),
        nfz_xy_m=np.zeros((0, 2)),
        nfz_radius_m=np.zeros(0),
        buffer_m=0.0,
    )


def vehicle_profile(name: str, limits: VehicleLimits, params: Mapping[str, float]) -> Profile:
    """Profile ``name`` for a vehicle with ``limits``, with every parameter of ``params`` it
    knows (autopilot units)."""
    return make_profile(name, limits, flown_params(name, params))


@dataclass(frozen=True)
class AutoTrack:
    """A sampled flight: ``t_s`` (K,) from 0, ``xy_m`` (K, 2), ``alt_m`` (K,), the mission
    item index being flown at each sample ``item`` (K,), and ``reached``: (t_s, item index)
    of every navigation item completed, in order. ``lands``: the flight ends on the ground;
    ``completes``: it ends the mission (not in an unlimited loiter). ``homes``: (t_s, home) each
    time a DO_SET_HOME moves the vehicle's home, in order."""

    t_s: NDArray[np.float64]
    xy_m: NDArray[np.float64]
    alt_m: NDArray[np.float64]
    item: NDArray[np.int64]
    reached: tuple[tuple[float, int], ...]
    lands: bool
    completes: bool = True
    homes: tuple[tuple[float, Home], ...] = ()

    @property
    def duration_s(self) -> float:
        return float(self.t_s[-1])

    def state_at(self, tau_s: float) -> tuple[NDArray[np.float64], float, NDArray[np.float64]]:
        """Position (2,), altitude and velocity (east, north, up; m/s) at ``tau_s``,
        interpolated linearly; held at the last sample after the end."""
        t = self.t_s
        if t.size == 1:
            return self.xy_m[0].copy(), float(self.alt_m[0]), np.zeros(3)
        tau = float(np.clip(tau_s, t[0], t[-1]))
        k = min(max(int(np.searchsorted(t, tau, side="right")) - 1, 0), t.size - 2)
        dt = float(t[k + 1] - t[k])
        f = (tau - t[k]) / dt if dt > 0 else 0.0
        xy = self.xy_m[k] + f * (self.xy_m[k + 1] - self.xy_m[k])
        alt = float(self.alt_m[k] + f * (self.alt_m[k + 1] - self.alt_m[k]))
        if tau_s >= t[-1] or dt <= 0:
            vel = np.zeros(3)
        else:
            vel = np.append((self.xy_m[k + 1] - self.xy_m[k]) / dt,
                            (self.alt_m[k + 1] - self.alt_m[k]) / dt)
        return np.asarray(xy, dtype=float), alt, vel

    def current_index_at(self, tau_s: float) -> int:
        """The mission item index being flown at ``tau_s``."""
        k = int(np.searchsorted(self.t_s, tau_s, side="right")) - 1
        return int(self.item[min(max(k, 0), self.item.size - 1)])


def _first_leg(flight: Flight, start_index: int) -> int:
    """The first of ``flight``'s legs still to fly when the mission (re)starts at item
    ``start_index`` (the number of legs when none is)."""
    for k, leg in enumerate(flight.legs):
        if leg.item >= start_index or leg.first_item >= start_index:
            return k
    return len(flight.legs)


def _same_home(a: Home, b: Home) -> bool:
    return (a.set_by_item == b.set_by_item and a.alt_m == b.alt_m
            and bool(np.array_equal(a.xy_m, b.xy_m)))


def _homes_set(flight: Flight, first: int, start_index: int,
               current_s: Sequence[float]) -> tuple[tuple[float, Home], ...]:
    """(t_s, home) each time a DO_SET_HOME moves the home, when legs ``first``, ``first + 1``
    ... of ``flight`` become current at ``current_s`` (NaN: never): a leg carries the home in
    force on it, and the DO items before its item run as it becomes current. One before
    ``start_index`` ran before a restart there, and is not run again."""
    out = []
    for k, t_s in enumerate(current_s):
        j = first + k
        home = flight.home_of(j)
        if home.set_by_item is None or math.isnan(t_s):
            continue
        if j == first and home.set_by_item < start_index:
            continue
        if j > first and _same_home(home, flight.home_of(j - 1)):
            continue
        out.append((float(t_s), home))
    return tuple(out)


def _homes_where_flown(auto: AutoTrack, plan: Plan) -> tuple[tuple[float, Home], ...]:
    """``auto``'s homes with each set at the current position moved to where its track is
    then: ArduCopter takes its own location as it runs the item (``ahrs.get_location``), after
    cutting the corner, where the resolved flight has the waypoint."""
    px4 = plan.firmware_type == Autopilot.PX4
    out = []
    for t_s, home in auto.homes:
        item = home.set_by_item
        if item is not None and set_home_source(plan.items[item], px4)[0]:
            xy, alt, _ = auto.state_at(t_s)
            home = Home(xy, item, alt)
        out.append((t_s, home))
    return tuple(out)


def build_auto_track(
    plan: Plan,
    frame: LocalFrame,
    *,
    start_index: int,
    start_xy_m: NDArray[np.float64],
    start_alt_m: float,
    profile: Profile,
    dt_s: float,
) -> AutoTrack | None:
    """The track the vehicle flies from mission item ``start_index`` (0-based plan index),
    starting at ``start_xy_m`` / ``start_alt_m`` (m above home). None when nothing is left to
    fly. ``frame`` is the vehicle's home frame; ``profile`` its flight model."""
    site = vehicle_site(frame, profile_speed(profile))
    flight = resolve_flight(plan, site, "vehicle mission")
    first_leg = _first_leg(flight, start_index)
    legs = list(flight.legs[first_leg:])
    done_at_start: list[int] = []
    # A takeoff the vehicle has already climbed to completes at once, as in ArduCopter.
    while legs and legs[0].kind == "takeoff" and legs[0].end_alt_m <= start_alt_m + TAKEOFF_DONE_M:
        done_at_start.append(legs.pop(0).item)
    if not legs:
        return None
    first = legs[0]
    end_alt = max(first.end_alt_m, start_alt_m) if first.kind == "takeoff" else first.end_alt_m
    end_xy = start_xy_m.copy() if first.kind == "takeoff" else first.end_xy_m
    legs[0] = dataclasses.replace(first, start_xy_m=np.asarray(start_xy_m, dtype=float).copy(),
                                  start_alt_m=float(start_alt_m), end_xy_m=end_xy,
                                  end_alt_m=end_alt)
    if len(legs) > 1:  # the second leg starts where the (moved) first one ends
        legs[1] = dataclasses.replace(legs[1], start_xy_m=legs[0].end_xy_m.copy(),
                                      start_alt_m=legs[0].end_alt_m)
    sub = dataclasses.replace(flight, legs=tuple(legs), cycle=None, service=None)
    track = replay(sub, profile, dt_s=dt_s)
    reached = [(0.0, i) for i in done_at_start]
    # An item flown as several legs (LAND's transit and descent, RTL) is reached at its end.
    reached += [(float(track.leg_done_s[k]), leg.item) for k, leg in enumerate(legs)
                if not np.isnan(track.leg_done_s[k])
                and (k + 1 == len(legs) or legs[k + 1].item != leg.item)]
    last = legs[-1]
    unlimited = plan.items[last.item].command == Cmd.NAV_LOITER_UNLIM
    # a leg is current from the end of the one before (the mission's first: from the start)
    current_s = [0.0] * (len(done_at_start) + 1) + [float(t) for t in track.leg_done_s[:-1]]
    auto = AutoTrack(
        t_s=track.t_s,
        xy_m=track.xy_m,
        alt_m=track.alt_m,
        item=track.mission_seq,
        reached=tuple(reached[:-1] if unlimited else reached),
        lands=last.kind == "land",
        completes=not unlimited,
        homes=_homes_set(flight, first_leg, start_index, current_s),
    )
    return dataclasses.replace(auto, homes=_homes_where_flown(auto, plan))


def profile_speed(profile: Profile) -> float:
    """The vehicle's top speed (m/s) as the profile states it."""
    return float(profile.si("VEHICLE_SPEED_MAX"))
