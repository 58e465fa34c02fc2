"""The local east/north frame of a site, and MAVLink's int32 coordinate rounding.

Positions are metres east (x) and north (y) of the site origin in the WGS84 east/north/up frame
(pymap3d ENU) whose tangent plane touches the ellipsoid height of the origin's ground altitude,
with every point taken at that height. (At 584 m, a plane at height 0 instead would shift points
360 m out by 3 cm.) Latitudes and longitudes are degrees; altitudes metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymap3d
from numpy.typing import ArrayLike, NDArray

E7 = 1e7  # MAVLink MISSION_ITEM_INT stores degrees x 1e7 as int32
# Rounding to the nearest 1e-7° moves a point by at most half a step on each axis: 0.5e-7° of
# latitude is at most 0.56 cm (a degree of latitude is at most 111.7 km, at the poles), of
# longitude 0.56 cm x cos(latitude); so at most 0.56 cm x √2 ≈ 0.79 cm in all (on the equator).
E7_ROUNDING_MAX_M = 0.5 / E7 * 111_700.0 * math.sqrt(2.0)
# The one margin for that rounding: each clearance check's tolerance, the exporter's extra
# clearance of legs and transits, and the polygon fence's growth before rounding (m).
E7_ROUNDING_MARGIN_M = 0.01
assert E7_ROUNDING_MARGIN_M > E7_ROUNDING_MAX_M
# How near a pole a site may be anchored (degrees): toward a pole longitude stops meaning east
# (a 1 km leg east at 89.9° spans 10° of it), ArduPilot's flat-earth navigation floors its
# longitude scale cos(lat) at 0.01 (89.4°) and misplaces every point east of home beyond, and
# the view's map tiles (Web Mercator) end at 85.05°. No settled place lies beyond 82.5°.
MAX_LAT_DEG = 85.0


def check_latitude(lat_deg: float) -> float:
    """``lat_deg`` when a site can be anchored there; ValueError within 90 - MAX_LAT_DEG
    degrees of a pole."""
    if abs(lat_deg) > MAX_LAT_DEG:
        raise ValueError(f"{lat_deg:g}° is within {90 - MAX_LAT_DEG:g}° of a pole, where "
                         "autopilots' flat-earth navigation and the map end (at most "
                         f"±{MAX_LAT_DEG:g}°)")
    return lat_deg


@dataclass(frozen=True)
class LocalFrame:
    """East/north tangent-plane frame anchored at ``(lat0_deg, lon0_deg, alt0_m)``."""

    lat0_deg: float
    lon0_deg: float
    alt0_m: float = 0.0

    def to_geodetic(self, xy_m: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Latitudes and longitudes (degrees) of points ``xy_m`` (..., 2) on the ground plane."""
        xy = np.asarray(xy_m, dtype=float)
        # up = 0 puts the point on the tangent plane, a few mm above height alt0 within 1 km;
        # the round trip through to_local moves it by under 1 µm.
        lat, lon, _ = pymap3d.enu2geodetic(
            xy[..., 0],
            xy[..., 1],
            np.zeros(xy.shape[:-1]),
            self.lat0_deg,
            self.lon0_deg,
            self.alt0_m,
        )
        return np.asarray(lat, dtype=float), np.asarray(lon, dtype=float)

    def to_local(self, lat_deg: ArrayLike, lon_deg: ArrayLike) -> NDArray[np.float64]:
        """Metres east/north (..., 2) of geodetic points, projected onto the tangent plane."""
        lat = np.asarray(lat_deg, dtype=float)
        lon = np.asarray(lon_deg, dtype=float)
        e, n, _ = pymap3d.geodetic2enu(
            lat, lon, np.full(lat.shape, self.alt0_m), self.lat0_deg, self.lon0_deg, self.alt0_m
        )
        return np.stack([np.asarray(e, dtype=float), np.asarray(n, dtype=float)], axis=-1)


def to_int_e7(deg: ArrayLike) -> NDArray[np.int64]:
    """Degrees as MAVLink int32 degrees x 1e7, rounded to nearest as ground stations do."""
    return np.rint(np.asarray(deg, dtype=float) * E7).astype(np.int64)


def from_int_e7(value: ArrayLike) -> NDArray[np.float64]:
    """Degrees of MAVLink int32 degrees x 1e7 (as MISSION_ITEM_INT, GLOBAL_POSITION_INT and
    HOME_POSITION carry them)."""
    return np.asarray(value, dtype=float) / E7


def round_e7(deg: ArrayLike) -> NDArray[np.float64]:
    """Degrees after a trip through MAVLink's int32 1e-7 degree representation."""
    return from_int_e7(to_int_e7(deg))
