"""PX4 v1.15.4 SIH flights through pass-through corners (``tests/data/px4-corners``), and the
one measure of a corner that both a recorded track and the ``px4`` replay are put through.

Each folder holds the site, the plan and parameter file that were flown, and ``flown.json``:
what the flight measured (the service cycle, the closest approach to each zone, and per
corner :func:`corner_figures`), not the track itself. Lengths are metres, times seconds.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from validator.autopilot.param_file import read_params
from validator.flight import Flight, resolve_flight
from validator.plan_format import Plan, read_plan
from validator.replay import Track, score_track
from validator.site import Site, load_site

DATA = Path(__file__).resolve().parents[1] / "data" / "px4-corners"
NEAR_M = 15.0  # a corner's turn is judged on the track within this distance of its waypoint
MIN_TURN_DEG = 10.0  # gentler bends are flown as straight lines (no turn to measure)
MIN_LEG_M = 2 * NEAR_M  # a corner is measured alone: no other waypoint within NEAR_M of it


def names() -> list[str]:
    """Folder names of the recorded flights, sorted."""
    return sorted(p.name for p in DATA.iterdir() if (p / "flown.json").is_file())


@dataclass(frozen=True)
class CornerFlight:
    name: str
    site: Site
    plan: Plan
    flight: Flight
    params: dict[str, float]  # the parameter file the vehicle flew with (PX4 units)
    flown: dict[str, Any]  # flown.json


@cache
def load(name: str) -> CornerFlight:
    folder = DATA / name
    site = load_site(folder / "site.yaml")
    plan = read_plan(folder / "mission.plan")
    flight = resolve_flight(plan, site, str(folder / "mission.plan"))
    return CornerFlight(name, site, plan, flight, read_params(folder / "mission.param"),
                        json.loads((folder / "flown.json").read_text()))


def corner_legs(flight: Flight) -> list[int]:
    """Legs ``k`` of ``flight`` whose waypoint is flown through (no hold) into a turn of at
    least :data:`MIN_TURN_DEG` onto leg ``k + 1``, both legs at least :data:`MIN_LEG_M` long."""
    out = []
    for k, leg in enumerate(flight.legs[:-1]):
        nxt = flight.legs[k + 1]
        if not leg.pass_through or leg.kind != "waypoint" or nxt.kind != "waypoint":
            continue
        if min(_length_m(leg.start_xy_m, leg.end_xy_m), _length_m(nxt.start_xy_m, nxt.end_xy_m)
               ) < MIN_LEG_M:
            continue
        if _turn_deg(leg.start_xy_m, leg.end_xy_m, nxt.end_xy_m) >= MIN_TURN_DEG:
            out.append(k)
    return out


def _length_m(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    return float(np.hypot(*(np.asarray(b, dtype=float) - np.asarray(a, dtype=float))))


def _turn_deg(a: NDArray[np.float64], c: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    u, v = np.asarray(c) - np.asarray(a), np.asarray(b) - np.asarray(c)
    nu, nv = float(np.hypot(*u)), float(np.hypot(*v))
    if nu < 1.0 or nv < 1.0:
        return 0.0
    return float(np.degrees(np.arccos(np.clip(np.dot(u, v) / (nu * nv), -1.0, 1.0))))


def corner_figures(track: Track, flight: Flight, k: int) -> dict[str, float]:
    """How ``track`` flew through the waypoint of leg ``k`` onto leg ``k + 1``.

    ``closest_m``: its closest approach to the waypoint; ``inside_m`` / ``outside_m``: how far
    it strayed from the two legs toward the inside of the turn (cutting it) and toward the
    outside (overshooting it), within :data:`NEAR_M` of the waypoint; ``speed_mps``: its speed
    at the closest approach; ``in_s``: the time from the start of leg ``k`` (its previous
    waypoint's hold over) to this waypoint counted reached, ``out_s`` from then to the next
    waypoint counted reached."""
    leg, nxt = flight.legs[k], flight.legs[k + 1]
    a, c, b = (np.asarray(p, dtype=float) for p in (leg.start_xy_m, leg.end_xy_m, nxt.end_xy_m))
    u, v = (c - a) / np.hypot(*(c - a)), (b - c) / np.hypot(*(b - c))
    left = np.sign(u[0] * v[1] - u[1] * v[0])  # +1 when the track turns left
    sel = (track.t_s >= track.leg_start_s[k]) & (track.t_s <= track.leg_reached_s[k + 1])
    pts, speed = track.xy_m[sel], track.speed_mps[sel]
    near = np.hypot(*(pts - c).T) <= NEAR_M
    pts, speed = pts[near], speed[near]
    # inside the turn: on the turn's side of both legs' lines (the wedge a cut corner crosses)
    off_in = ((pts - c) @ np.array([-u[1], u[0]])) * left
    off_out = ((pts - c) @ np.array([-v[1], v[0]])) * left
    cut = (off_in > 0) & (off_out > 0)
    off = np.minimum(_segment_distance(pts, a, c), _segment_distance(pts, c, b))
    i = int(np.argmin(np.hypot(*(pts - c).T)))
    return {
        "closest_m": float(np.hypot(*(pts[i] - c))),
        "inside_m": float(np.max(off[cut], initial=0.0)),
        "outside_m": float(np.max(off[~cut], initial=0.0)),
        "speed_mps": float(speed[i]),
        "in_s": float(track.leg_reached_s[k] - track.leg_start_s[k]),
        "out_s": float(track.leg_reached_s[k + 1] - track.leg_reached_s[k]),
        "turn_deg": _turn_deg(a, c, b),
    }


def _segment_distance(pts: NDArray[np.float64], a: NDArray[np.float64],
                      b: NDArray[np.float64]) -> NDArray[np.float64]:
    ab = b - a
    t = np.clip(((pts - a) @ ab) / float(ab @ ab), 0.0, 1.0)
    return np.asarray(np.hypot(*(pts - (a + t[:, None] * ab)).T), dtype=float)


def flown_summary(flight: Flight, site: Site, plan: Plan, track: Track) -> dict[str, Any]:
    """What ``flown.json`` keeps of a flight: the service cycle (s), the closest approach to
    each zone (m beyond its published radius), and per pass-through corner (by leg index)
    :func:`corner_figures`. The same for a replay, to compare."""
    scored = score_track(track, flight, site, plan)
    return {
        "cycle_s": None if scored.cycle is None else scored.cycle.flown_cycle_s,
        "clearance_m": {z.name: z.clearance_m for z in scored.nfz},
        "corners": {str(k): corner_figures(track, flight, k) for k in corner_legs(flight)},
    }
