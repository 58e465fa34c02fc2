"""Hand-made sites and solutions for export tests: no optimiser needed, every number known."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from mission_planner.optimize.solution import Solution
from validator.site import Site, parse_site

# What the exporter promises beyond its safety gate: legs re-read from int32-rounded
# coordinates keep R + buffer less at most this (m). It nudges legs a centimetre beyond R +
# buffer and the rounding moves a leg by less than 0.8 cm.
NUDGED_LEG_SLACK_M = 1e-3


def site_dict(**changes: Any) -> dict[str, Any]:
    """The paper's default site as a mapping; keyword arguments replace top-level keys."""
    data: dict[str, Any] = {
        "name": "handmade",
        "origin": {"lat": 37.5585, "lon": 126.999, "alt": 40.0},
        "home": {"x": 0.0, "y": 0.0},
        "uav": {"altitude": 30.0, "max_speed": 30.0, "period": 50.0, "slots": 50},
        "radio": {"p_avg_dbm": 20.0, "p_peak_dbm": 26.0206, "beta0_db": -30.0,
                  "noise_dbm": -70.0},
        "ground_nodes": [
            {"name": "GN1", "x": 60.0, "y": 340.0},
            {"name": "GN2", "x": 330.0, "y": 350.0},
            {"name": "GN3", "x": 340.0, "y": 70.0},
            {"name": "GN4", "x": 90.0, "y": 90.0},
        ],
        "no_fly_zones": [
            {"name": "NFZ1", "x": 190.0, "y": 330.0, "radius": 30.0},
            {"name": "NFZ2", "x": 330.0, "y": 210.0, "radius": 30.0},
            {"name": "NFZ3", "x": 210.0, "y": 90.0, "radius": 30.0},
        ],
        "safety": {"buffer_m": 2.0},
    }
    data.update(changes)
    return data


def make_site(**changes: Any) -> Site:
    return parse_site(site_dict(**changes))


def circle_points(centre: tuple[float, float], radius_m: float, n: int,
                  phase_rad: float = 0.0) -> NDArray[np.float64]:
    """n + 1 points of a closed regular n-gon inscribed in a circle (first == last)."""
    ang = phase_rad + np.linspace(0.0, 2.0 * np.pi, n + 1)
    q = np.c_[centre[0] + radius_m * np.cos(ang), centre[1] + radius_m * np.sin(ang)]
    q[-1] = q[0]
    return q


def solution_for(site: Site, trajectory_m: NDArray[np.float64],
                 delta_s: NDArray[np.float64] | None = None,
                 scheme: str = "proposed") -> Solution:
    """A Solution on ``trajectory_m`` with equal slots (unless given), average power, and each
    slot served to the nearest GN."""
    n = len(trajectory_m) - 1
    delta = np.full(n, site.period_s / n) if delta_s is None else np.asarray(delta_s, float)
    d = np.linalg.norm(trajectory_m[1:, None, :] - site.gn_xy_m[None, :, :], axis=2)
    return Solution(site=site, scheme=scheme, trajectory_m=np.asarray(trajectory_m, float),
                    delta_s=delta, power_w=np.full(n, site.p_avg_w),
                    schedule=np.argmin(d, axis=1).astype(np.int64))


def circle_tour(site: Site, centre: tuple[float, float] = (200.0, 200.0),
                radius_m: float = 60.0) -> Solution:
    """Equal slots around a circle of ``radius_m`` (clear of the default site's NFZs)."""
    return solution_for(site, circle_points(centre, radius_m, site.slots))


def subdivided(corners: list[tuple[float, float]], per_side: int) -> NDArray[np.float64]:
    """A closed polygon through ``corners`` with each side cut into ``per_side`` equal slots:
    (len(corners)·per_side + 1, 2) points, first == last."""
    c = np.asarray(corners, dtype=float)
    nxt = np.roll(c, -1, axis=0)
    f = np.arange(per_side)[None, :, None] / per_side
    pts = (c[:, None, :] + f * (nxt - c)[:, None, :]).reshape(-1, 2)
    return np.vstack([pts, pts[:1]])


# A tour round the airfield sample's zones that starts north of its CTR, so both transits from
# and to home (south of the runway) must go round it.
AIRFIELD_TOUR = [(300.0, 300.0), (570.0, 300.0), (570.0, 460.0), (60.0, 460.0), (60.0, 300.0)]


def airfield_solution() -> Solution:
    """The airfield sample (60 slots, T = 300 s) flown round :data:`AIRFIELD_TOUR`."""
    from pathlib import Path

    from validator.site import load_site

    site = load_site(Path(__file__).resolve().parents[2] / "samples" / "airfield.yaml")
    site = site.with_limits(slots=60, period_s=300.0)
    return solution_for(site, subdivided(AIRFIELD_TOUR, 12))
