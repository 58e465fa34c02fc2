"""Random sites as in the paper's section IV: GNs and NFZs drawn in a square area.

:func:`random_site` is the one generator used by the Fig. 4 study and the planner benchmark,
so a seed names the same site everywhere; :func:`random_polygon_site` draws polygon zones
instead (convex and non-convex), for the polygon benchmark. Defaults are the paper's: a
400 m x 400 m area, K = 4 GNs, M = 3 NFZs of radius 30 m, T = 50 s, N = 50, H = 30 m, V = 30 m/s,
P_avg = 20 dBm, P_peak = 4 P_avg, beta0 = -30 dB, sigma^2 = -70 dBm, and no safety buffer.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
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


def check_zone_fits(radius_m: float, area_m: float, field: str) -> None:
    """Refuse, naming ``field``, a zone radius no random site can hold: each zone lies wholly
    inside the square area (its centre is drawn at least its radius from every side), so a
    study asked for it would fail every trial rather than say so once."""
    if not area_m > 2 * radius_m:
        raise InputError(f"{field}: a zone of radius {radius_m:g} m does not fit in the "
                         f"{area_m:g} m square of the sites (radius < {area_m / 2:g} m)")


def max_zones(radius_m: float, area_m: float) -> int:
    """An upper bound on how many zones of radius ``radius_m`` fit, apart, in the square.

    The centres lie in the square of side ``area_m - 2 radius_m`` (each zone inside the area)
    and at least ``2 radius_m`` apart (no overlap, touching allowed). Scaled by that distance:
    points at least 1 apart in a square of side t, which Oler's inequality (1961; for any
    convex region, 2/sqrt(3) area + perimeter / 2 + 1) bounds by 2/sqrt(3) t**2 + 2 t + 1. It
    is sound, so it never refuses a count that fits, and stronger than the zones' total area
    against the square's. It is not tight: three zones of 110 m pass it, yet three fit only up
    to 101.7 m (the best spread of three points in a square), and the sampler gives up well
    before either, so a count it passes may still fail every draw.
    """
    t = (area_m - 2.0 * radius_m) / (2.0 * radius_m)
    bound = 2.0 / math.sqrt(3.0) * t * t + 2.0 * t + 1.0
    return math.floor(bound * (1.0 + 1e-9))  # a rounding error may not refuse a count that fits


def check_zones_pack(count: int, radius_m: float, area_m: float, field: str) -> None:
    """Refuse, naming ``field``, ``count`` zones of radius ``radius_m`` that cannot lie apart in
    the square (:func:`max_zones`): every draw of such a site fails, so a study would fail each
    trial of that point rather than say so once, before any work."""
    check_zone_fits(radius_m, area_m, field)
    most = max_zones(radius_m, area_m)
    if count > most:
        raise InputError(f"{field}: {count} zones of radius {radius_m:g} m cannot lie apart in "
                         f"the {area_m:g} m square of the sites (at most {most} fit)")


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
    check_zone_fits(radius_m, area_m, "area_m")
    check_zones_pack(num_nfzs, radius_m, area_m, "num_nfzs")
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


def _polygon(rng: np.random.Generator, centre: NDArray[np.float64], size_m: float,
             convex: bool) -> NDArray[np.float64]:
    """A random polygon inside the circle of radius ``size_m`` round ``centre``.

    Convex: 4 to 8 points drawn on an ellipse (aspect 0.4 to 1, random heading), their hull.
    Non-convex: a star of 5 to 9 rays, every other ray 35 to 65 % as long, so at least one
    corner is reflex.
    """
    if convex:
        count = int(rng.integers(4, 9))
        angle = np.sort(rng.uniform(0.0, 2 * np.pi, count))
        aspect, heading = rng.uniform(0.4, 1.0), rng.uniform(0.0, np.pi)
        pts = np.stack([np.cos(angle), aspect * np.sin(angle)], axis=1)
        rot = np.array([[np.cos(heading), -np.sin(heading)], [np.sin(heading), np.cos(heading)]])
        hull = shapely.MultiPoint(pts @ rot.T).convex_hull
        return centre + size_m * np.asarray(hull.exterior.coords)[:-1]
    count = int(rng.integers(5, 10))
    angle = (np.arange(count) + rng.uniform(0.15, 0.85, count)) * 2 * np.pi / count
    reach = np.where(np.arange(count) % 2 == 0, rng.uniform(0.8, 1.0, count),
                     rng.uniform(0.35, 0.65, count))
    return centre + size_m * np.stack([reach * np.cos(angle), reach * np.sin(angle)], axis=1)


def random_polygon_site(
    seed: int,
    *,
    num_gns: int = 4,
    num_zones: int = 3,
    size_m: float = 45.0,
    nonconvex_share: float = 0.5,
    slots: int = 50,
    area_m: float = PAPER_AREA_M,
    buffer_m: float = 0.0,
    period_s: float = 50.0,
    max_speed_mps: float = 30.0,
) -> Site:
    """A random site like :func:`random_site` whose no-fly zones are polygons.

    Each zone lies in a circle of radius ``size_m`` whose centre is drawn so that the circle
    lies inside the area and no two circles overlap; a zone is non-convex with probability
    ``nonconvex_share`` (a star), else convex (the hull of points on an ellipse). GNs are
    uniform in the area outside every zone, home outside every zone plus ``buffer_m``. Zones, GNs
    and home come from three streams spawned from ``seed``; the paper's radio and altitude.
    """
    if seed < 0:
        raise InputError(f"seed: must be >= 0, got {seed}")
    if not area_m > 2 * size_m > 0:
        raise InputError(f"size_m: must be > 0 and below half the area {area_m:g} m, "
                         f"got {size_m}")
    zone_rng, gn_rng, home_rng = (
        np.random.default_rng(s) for s in np.random.SeedSequence([seed, 1]).spawn(3)
    )
    centres = np.zeros((0, 2))
    zones = []
    for m in range(num_zones):
        c = _draw_clear(zone_rng, size_m, area_m - size_m, centres,
                        np.full(len(centres), 2.0 * size_m))
        if c is None:
            raise InputError(f"num_zones: cannot place {num_zones} zones of size {size_m:g} m "
                             f"(seed {seed}, stuck at zone {m + 1})")
        centres = np.vstack([centres, c])
        zones.append(_polygon(zone_rng, c, size_m, bool(zone_rng.uniform() < nonconvex_share)))
    shapes = [shapely.Polygon(z) for z in zones]

    def clear(rng: np.random.Generator, margin_m: float) -> NDArray[np.float64] | None:
        for _ in range(MAX_DRAWS_PER_ITEM):
            p = rng.uniform(0.0, area_m, size=2)
            if all(shapely.Point(p).distance(z) > margin_m for z in shapes):
                return p
        return None

    gns = [clear(gn_rng, 0.0) for _ in range(num_gns)]
    home = clear(home_rng, buffer_m + 1.0)
    if home is None or any(g is None for g in gns):
        raise InputError(f"num_zones: no room outside the zones (seed {seed})")
    lat0, lon0, alt0 = PAPER_ORIGIN
    data = {
        "name": f"random-polygons-{seed}",
        "origin": {"lat": lat0, "lon": lon0, "alt": alt0},
        "home": {"x": float(home[0]), "y": float(home[1])},
        "uav": {"altitude": 30.0, "max_speed": max_speed_mps, "period": period_s,
                "slots": slots},
        "radio": {"p_avg_dbm": 20.0, "p_peak_dbm": PAPER_P_PEAK_DBM, "beta0_db": -30.0,
                  "noise_dbm": -70.0},
        "ground_nodes": [
            {"name": f"GN{k + 1}", "x": float(g[0]), "y": float(g[1])}
            for k, g in enumerate(gns) if g is not None
        ],
        "no_fly_zones": [
            {"name": f"ZONE{m + 1}", "polygon": [{"x": float(x), "y": float(y)} for x, y in z]}
            for m, z in enumerate(zones)
        ],
        "safety": {"buffer_m": buffer_m},
    }
    return parse_site(data, f"random polygon site (seed {seed})")
