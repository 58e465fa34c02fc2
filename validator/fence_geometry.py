"""A plan's geofence in a site's local frame: the one conversion from the plan's degrees to
metres that the audit, the replay, the GeoJSON export and the simulated vehicle share.

Circles become (centre (2,) m, radius m, inclusion) and polygons (shapely polygon in metres,
inclusion), in the plan's order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray

from validator.geodesy import LocalFrame
from validator.plan_format import Plan

LocalCircle = tuple[NDArray[np.float64], float, bool]  # centre (m), radius (m), inclusion
LocalPolygon = tuple[shapely.Polygon, bool]  # polygon (m), inclusion


@dataclass(frozen=True)
class LocalFence:
    """The fence areas of a plan in metres east/north of a frame's origin."""

    circles: list[LocalCircle]
    polygons: list[LocalPolygon]

    def exclusion_circles(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Centres (k, 2) and radii (k,) in metres of the exclusion circles."""
        excl = [(c, r) for c, r, inclusion in self.circles if not inclusion]
        return (np.array([c for c, _ in excl], dtype=float).reshape(-1, 2),
                np.array([r for _, r in excl], dtype=float))


def local_fence(plan: Plan, frame: LocalFrame) -> LocalFence:
    """The circles and polygons of ``plan``'s geofence in ``frame``."""
    circles = [(np.asarray(frame.to_local(c.lat_deg, c.lon_deg), dtype=float), c.radius_m,
                c.inclusion) for c in plan.circles]
    polygons = []
    for p in plan.polygons:
        lat = np.array([v[0] for v in p.vertices_deg])
        lon = np.array([v[1] for v in p.vertices_deg])
        polygons.append((shapely.Polygon(frame.to_local(lat, lon)), p.inclusion))
    return LocalFence(circles, polygons)
