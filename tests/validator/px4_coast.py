"""A GPS-loss flight's true track against the coast region the model gives its legs
(:mod:`validator.position_loss` with a :class:`~validator.coast_rules.CoastRule`): for the
pinned PX4 SIH flights and for the one the realtime test flies."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely

from validator.coast_rules import CoastRule
from validator.flight import Flight
from validator.position_loss import _leg_region


def legs_flown(flight: Flight, injected_xy_m: Sequence[float],
               track_xy_m: Sequence[Sequence[float]]) -> list[int]:
    """The leg the loss came on (the nearest leg running the way the track first went, or any
    near a hover) and the next: the mission the vehicle flies on its estimate until the
    failsafe."""
    track = np.asarray(track_xy_m, dtype=float)
    went = track[min(2, len(track) - 1)] - track[0]
    p = shapely.Point(injected_xy_m)
    legs = [k for k, leg in enumerate(flight.legs) if leg.length_m > 0 and (
        float(np.hypot(*went)) < 1.0 or float(np.dot(leg.end_xy_m - leg.start_xy_m, went)) > 0)]
    k = min(legs, key=lambda k: shapely.distance(shapely.LineString(
        [flight.legs[k].start_xy_m, flight.legs[k].end_xy_m]), p))
    return [j for j in (k, k + 1) if j < len(flight.legs)]


def outside_m(flight: Flight, speed_mps: float, injected_xy_m: Sequence[float],
              track_xy_m: Sequence[Sequence[float]], rule: CoastRule) -> float:
    """How far (m) the true track after the loss went outside ``rule``'s region of the legs it
    flew at ``speed_mps`` (0: inside)."""
    region = shapely.union_all([_leg_region(flight, k, speed_mps, rule=rule)
                                for k in legs_flown(flight, injected_xy_m, track_xy_m)])
    return max(float(shapely.distance(region, shapely.Point(q))) for q in track_xy_m)
