"""Random sites as in the paper's section IV: GNs and NFZs drawn in a square area.

:func:`random_site` is the one generator used by the Fig. 4 study and the planner benchmark,
so a seed names the same site everywhere. Defaults are the paper's: a 400 m x 400 m area,
K = 4 GNs, M = 3 NFZs of radius 30 m, T = 50 s, N = 50, H = 30 m, V = 30 m/s,
P_avg = 20 dBm, P_peak = 4 P_avg, beta0 = -30 dB, sigma^2 = -70 dBm, and no safety buffer.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from validator.errors import InputError
from validator.site import Site, parse_site

PAPER_AREA_M = 400.0
PAPER_ORIGIN = (37.5585, 126.999, 40.0)  # lat deg, lon deg, ground alt m AMSL
PAPER_P_PEAK_DBM = 20.0 + 10.0 * math.log10(4.0)  # P_peak = 4 P_avg
MAX_DRAWS_PER_ITEM = 2000


def _draw_clear(
    rng: np.random.Generator,
    low_m: float,
    high_m: float,
    centres_m: NDArray[np.float64],
    clear_m: NDArray[np.float64],
) -> NDArray[np.float64] | None:
    """A uniform point in the square [low, high]² at least ``clear_m[i]`` from ``centres_m[i]``.

    Rejection sampling; ``None`` when :data:`MAX_DRAWS_PER_ITEM` draws all fail.
    """
    for _ in range(MAX_DRAWS_PER_ITEM):
        p = rng.uniform(low_m, high_m, size=2)
        if centres_m.size == 0 or np.all(np.linalg.norm(centres_m - p, axis=1) >= clear_m):
            return p
    return None


def random_site(
    seed: int,
    *,
    num_gns: int = 4,
    num_nfzs: int = 3,
    radius_m: float = 30.0,
    slots: int = 50,
    area_m: float = PAPER_AREA_M,
    buffer_m: float = 0.0,
    period_s: float = 50.0,
    altitude_m: float = 30.0,
    max_speed_mps: float = 30.0,
    p_avg_dbm: float = 20.0,
    p_peak_dbm: float = PAPER_P_PEAK_DBM,
    beta0_db: float = -30.0,
    noise_dbm: float = -70.0,
) -> Site:
    """A random site in the square [0, area_m]² (metres east/north of the paper's origin).

    - NFZs: ``num_nfzs`` circles of radius ``radius_m``, centres uniform so that each zone lies
      inside the area, non-overlapping (drawn one by one, rejecting overlaps).
    - GNs: ``num_gns`` points uniform in the area, outside every NFZ.
    - Home: uniform in the area, outside every NFZ plus ``buffer_m``.

    NFZs, GNs and home come from three independent streams spawned from ``seed``
    (``numpy.random.SeedSequence``), so sweeping one parameter moves as little as possible: with
    the same seed and radius, the first M zones of an M+1-zone site are those of the M-zone site.
    The result is validated by :func:`validator.site.parse_site` like any site file.

    Raises :class:`InputError` naming the parameter when the numbers are invalid or the zones
    cannot be packed into the area.
    """
    if seed < 0:
        raise InputError(f"seed: must be >= 0, got {seed}")
    for name, value in (("num_gns", num_gns), ("slots", slots)):
        if value < 1:
            raise InputError(f"{name}: must be >= 1, got {value}")
    if num_nfzs < 0:
        raise InputError(f"num_nfzs: must be >= 0, got {num_nfzs}")
    if not radius_m > 0:
        raise InputError(f"radius_m: must be > 0, got {radius_m}")
    if not area_m > 2 * radius_m:
        raise InputError(f"area_m: must exceed the NFZ diameter {2 * radius_m:g} m, got {area_m}")
    if buffer_m < 0:
        raise InputError(f"buffer_m: must be >= 0, got {buffer_m}")

    nfz_rng, gn_rng, home_rng = (
        np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(3)
    )
    centres = np.zeros((0, 2))
    for m in range(num_nfzs):
        c = _draw_clear(nfz_rng, radius_m, area_m - radius_m, centres,
                        np.full(len(centres), 2.0 * radius_m))
        if c is None:
            raise InputError(
                f"num_nfzs: cannot place {num_nfzs} non-overlapping zones of radius {radius_m:g} m "
                f"in a {area_m:g} m square (seed {seed}, stuck at zone {m + 1})"
            )
        centres = np.vstack([centres, c])
    radii = np.full(num_nfzs, float(radius_m))

    gns = []
    for k in range(num_gns):
        g = _draw_clear(gn_rng, 0.0, area_m, centres, radii)
        if g is None:
            raise InputError(f"num_gns: no room for GN{k + 1} outside the zones (seed {seed})")
        gns.append(g)
    home = _draw_clear(home_rng, 0.0, area_m, centres, radii + buffer_m)
    if home is None:
        raise InputError(f"buffer_m: no room for home outside the buffered zones (seed {seed})")

    lat0, lon0, alt0 = PAPER_ORIGIN
    data = {
        "name": f"random-{seed}",
        "origin": {"lat": lat0, "lon": lon0, "alt": alt0},
        "home": {"x": float(home[0]), "y": float(home[1])},
        "uav": {"altitude": altitude_m, "max_speed": max_speed_mps, "period": period_s,
                "slots": slots},
        "radio": {"p_avg_dbm": p_avg_dbm, "p_peak_dbm": p_peak_dbm, "beta0_db": beta0_db,
                  "noise_dbm": noise_dbm},
        "ground_nodes": [
            {"name": f"GN{k + 1}", "x": float(g[0]), "y": float(g[1])} for k, g in enumerate(gns)
        ],
        "no_fly_zones": [
            {"name": f"NFZ{m + 1}", "x": float(c[0]), "y": float(c[1]), "radius": float(radius_m)}
            for m, c in enumerate(centres)
        ],
        "safety": {"buffer_m": buffer_m},
    }
    return parse_site(data, f"random site (seed {seed})")
