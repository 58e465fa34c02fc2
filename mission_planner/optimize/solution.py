"""The optimiser's result and its JSON report.

Slot convention (the paper's): slot n = 1..N lasts ``delta_s[n-1]`` seconds, the UAV flies the
straight leg ``trajectory_m[n-1] → trajectory_m[n]`` during it, and the rate of slot n is that of
position ``trajectory_m[n]`` at power ``power_w[n-1]`` to GN ``schedule[n-1]``.
``trajectory_m[0] == trajectory_m[N]``: the cycle is closed.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from validator.channel import hover_upper_bound, spectral_efficiency
from validator.geometry import expanded_radius, leg_clearances
from validator.motion.speed_model import commanded_top_speed_mps
from validator.site import Site
from validator.wind_track import buffer_share
from validator.zones import path_clearances_m

# The zone rule: proposed = Theorem 1's expanded radius (6-1), conventional = waypoints only (5),
# tangent = each leg beyond a tangent line of the circle (research); polygons: separating lines.
SCHEMES = ("proposed", "conventional", "tangent")


def average_rates(
    site: Site,
    trajectory_m: NDArray[np.float64],
    delta_s: NDArray[np.float64],
    power_w: NDArray[np.float64],
    schedule: NDArray[np.int64],
) -> NDArray[np.float64]:
    """Exact time-averaged rate (bps/Hz) of every GN (eq. 13) for a binary schedule."""
    rates = np.zeros(site.num_gns)
    for k in range(site.num_gns):
        served = schedule == k
        se = spectral_efficiency(
            trajectory_m[1:][served],
            site.gn_xy_m[k],
            site.altitude_m,
            power_w[served],
            site.beta0,
            site.noise_w,
        )
        rates[k] = float(np.sum(delta_s[served] * se)) / site.period_s
    return rates


@dataclass(frozen=True)
class VehicleTiming:
    """How a dynamics-aware plan was timed: the hand-off from the optimiser
    (:mod:`mission_planner.optimize.flyable`) to the exporter (:mod:`mission_planner.mission`),
    which must lay the mission out for the same autopilot and parameters.

    ``timing_params`` are the autopilot parameters the motion model was given, in the
    autopilot's own units (ArduPilot's cm and cm/s, PX4's m and m/s: see
    :mod:`validator.autopilot.tables`). ``waypoint_slots`` are the trajectory indices at which
    the cycle reaches each waypoint; ``move_s`` is the time the cycle spends moving."""

    autopilot: str  # the --autopilot word ("ardupilot", "px4")
    timing_params: Mapping[str, float]
    planning_speed_mps: float
    speeds_tried: int
    waypoint_slots: tuple[int, ...]
    move_s: float
    # in wind, which path won: "air-frame" (the cone's) or "still-air" (re-timed in the wind)
    wind_path: str | None = None
    # in wind, the start schedule Algorithm 1 ran from for the winning path ("nearest", "shares")
    start_schedule: str | None = None

    def as_dict(self) -> dict[str, object]:
        """The report's ``notes`` object (its keys predate this record)."""
        wind = {} if self.wind_path is None else {"wind_path": self.wind_path,
                                                   "start_schedule": self.start_schedule}
        return {
            "dynamics": "vehicle",
            "autopilot": self.autopilot,
            "timing_params": dict(self.timing_params),
            "planning_speed_mps": self.planning_speed_mps,
            "speeds_tried": self.speeds_tried,
            "waypoint_slots": list(self.waypoint_slots),
            "move_s": self.move_s,
            **wind,
        }


@dataclass(frozen=True)
class Solution:
    """A planned service cycle: trajectory, slot lengths, power and schedule (see module doc)."""

    site: Site
    scheme: str
    trajectory_m: NDArray[np.float64]  # (N+1, 2)
    delta_s: NDArray[np.float64]  # (N,)
    power_w: NDArray[np.float64]  # (N,)
    schedule: NDArray[np.int64]  # (N,) GN index per slot, -1 = nobody
    iterations: int = 0
    solve_seconds: float = 0.0
    history: list[float] = field(default_factory=list)
    timing: VehicleTiming | None = None  # None: timed by the paper's model (no dynamics)

    @property
    def rates_bps_hz(self) -> NDArray[np.float64]:
        return average_rates(
            self.site, self.trajectory_m, self.delta_s, self.power_w, self.schedule
        )

    @property
    def min_rate_bps_hz(self) -> float:
        return float(np.min(self.rates_bps_hz))

    @property
    def leg_length_m(self) -> NDArray[np.float64]:
        return np.asarray(np.linalg.norm(np.diff(self.trajectory_m, axis=0), axis=1), dtype=float)

    @property
    def nfz_clearance_m(self) -> NDArray[np.float64]:
        """(N, M): clearance of each leg from each NFZ as published (buffer not included)."""
        return leg_clearances(self.trajectory_m, self.site.nfz_xy_m, self.site.nfz_radius_m)

    @property
    def polygon_clearance_m(self) -> NDArray[np.float64]:
        """(N, P): signed clearance of each leg from each polygon zone as published (buffer not
        included; negative: the depth the leg reaches inside)."""
        return path_clearances_m(self.site.polygon_zones, self.trajectory_m)

    @cached_property
    def zone_clearance_m(self) -> NDArray[np.float64]:
        """(N, Z): clearance of each leg from each zone, in ``site.zone_names`` order (circles,
        then polygons), as published. Cached: a solution is never changed, and the report and
        Fig. 3 (once per inset) ask for it again; a polygon's clearance costs shapely calls."""
        return np.hstack([self.nfz_clearance_m.reshape(len(self.trajectory_m) - 1, -1),
                          self.polygon_clearance_m])

    @property
    def nfz_clearance_min_m(self) -> float:
        """The least clearance of any leg from any zone, circle or polygon (m)."""
        c = self.zone_clearance_m
        return float(np.min(c)) if c.size else float("inf")

    def _zone_clearance_min_m(self) -> dict[str, float]:
        """Each zone's least leg clearance (m), circles then polygons, by name."""
        c = self.zone_clearance_m
        return {n: float(v) for n, v in zip(self.site.zone_names, np.min(c, axis=0), strict=True)}

    def report(self) -> dict[str, object]:
        """The JSON-ready report of this solution."""
        site = self.site
        rates = self.rates_bps_hz
        clearance = self.nfz_clearance_min_m
        exp_r = (
            expanded_radius(
                site.planning_radius_m[None, :], (site.max_speed_mps * self.delta_s)[:, None]
            )
            if site.num_nfzs
            else np.zeros((0, 0))
        )
        return {
            "site": site.name,
            "scheme": self.scheme,
            "min_rate_bps_hz": float(np.min(rates)),
            "rates_bps_hz": {n: float(r) for n, r in zip(site.gn_names, rates, strict=True)},
            "hover_upper_bound_bps_hz": hover_upper_bound(
                site.num_gns, site.altitude_m, site.p_avg_w, site.beta0, site.noise_w
            ),
            "iterations": self.iterations,
            "solve_seconds": self.solve_seconds,
            "trajectory_m": self.trajectory_m.tolist(),
            "delta_s": self.delta_s.tolist(),
            "power_w": self.power_w.tolist(),
            "schedule": [site.gn_names[k] if k >= 0 else None for k in self.schedule],
            "nfz_clearance_min_m": clearance if np.isfinite(clearance) else None,
            "buffer_m": site.buffer_m,
            "expanded_radius_max_m": float(np.max(exp_r)) if exp_r.size else None,
            "history": [float(h) for h in self.history],
            **({"zone_clearance_min_m": self._zone_clearance_min_m()}
               if site.polygon_zones else {}),
            **({"notes": self.timing.as_dict()} if self.timing is not None else {}),
            **({"wind": wind_report(site, self.timing.autopilot if self.timing else None)}
               if site.wind is not None else {}),
        }


def wind_report(site: Site, autopilot: str | None = None) -> dict[str, object]:
    """What wind a plan was made for: the site's forecast, its layer at the flight altitude
    (:mod:`validator.wind`) and what it eats of the buffer the plan keeps
    (:func:`validator.wind_track.buffer_share`); for a vehicle plan (flown by ``autopilot``)
    the most airspeed its legs are commanded, held through the gusts
    (:func:`validator.motion.speed_model.commanded_top_speed_mps`)."""
    assert site.wind is not None
    at = site.wind.at(site.altitude_m)
    held = ({} if autopilot is None or site.flight_wind is None
            else {"commanded_airspeed_max_mps": commanded_top_speed_mps(site, autopilot)})
    return {**site.wind.to_dict(), "at_flight_altitude": {
        "speed_mps": at.speed_mps, "from_deg": at.from_deg, "turbulence_mps": at.turbulence_mps},
        **held, **buffer_share(site.buffer_m, site.flight_wind)}
