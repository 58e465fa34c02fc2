"""When the simulated vehicle breaches its fence, and what ArduCopter's FENCE_ACTION then does."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from validator.fence_geometry import LocalFence
from validator.mavlink.sim.arducopter import CopterMode

NO_FENCE = LocalFence([], [])

# FENCE_ACTION -> the mode a breach switches to (0, report only, and unknown values: none).
# The vehicle keeps no path to retrace, so SmartRTL's actions (3 and 5) fly RTL here.
BREACH_MODES = {1: CopterMode.RTL, 3: CopterMode.RTL, 5: CopterMode.RTL,
                2: CopterMode.LAND, 4: CopterMode.BRAKE}


def breached(fence: LocalFence, xy: NDArray[np.float64]) -> bool:
    """Whether ``xy`` (m east/north of home) is inside an exclusion area or outside an
    inclusion area of ``fence``."""
    for centre, radius, inclusion in fence.circles:
        inside = float(np.hypot(*(xy - centre))) < radius
        if inside != inclusion:
            return True
    if fence.polygons:
        from shapely.geometry import Point

        p = Point(float(xy[0]), float(xy[1]))
        for poly, inclusion in fence.polygons:
            if poly.contains(p) != inclusion:
                return True
    return False
