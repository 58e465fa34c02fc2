"""Polygon zones and the tangent rule: safety, min rate and time over random sites.

Run by hand (figures, not pass/fail), with the paper's kinematic model (``PAPER_OPTIONS``):

    .venv/bin/python benchmarks/bench_polygons.py --sites 50 --jobs 1

Prints
1. for ``--sites`` random polygon sites (:func:`random_polygon_site`: 400 m square, K = 4, three
   zones each within 45 m of its centre, about half of them non-convex, buffer 2 m) planned with
   ``proposed``: min rate, worst leg clearance from any polygon (must be ≥ the buffer), solve
   time; and the same site with each polygon replaced by the circle of the same area round its
   centroid (the min-rate cost of polygons against circles), and with each non-convex zone
   replaced by its convex hull (what planning round the hull instead of the convex parts costs);
   twins whose circle would swallow a GN or home are left out and counted;
2. ``tangent`` against ``proposed`` on the circle benchmark sites: ``samples/*.yaml`` and the
   study's random sites (:func:`random_site`, the paper's defaults): min rates side by side,
   and the worst leg clearance of each.
"""

from __future__ import annotations

import statistics
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mission_planner.optimize import PAPER_OPTIONS, plan
from mission_planner.study.sites import random_polygon_site, random_site
from validator.errors import CommandParser
from validator.site import Site, load_site
from validator.zones import path_clearances_m, polygon_zone

SAMPLES = sorted((Path(__file__).resolve().parents[1] / "samples").glob("*.yaml"))
BUFFER_M = 2.0


def worst_clearance_m(site: Site, trajectory_m: np.ndarray) -> float:
    """The least clearance of any leg from any polygon zone (m), exact (shapely)."""
    return float(path_clearances_m(site.polygon_zones, trajectory_m).min())


def circle_twin(site: Site) -> Site | None:
    """The site with each polygon zone replaced by the circle of its area round its centroid;
    None when such a circle would hold a GN, or home within the buffer."""
    centres = np.array([z.shape.centroid.coords[0] for z in site.polygon_zones])
    radii = np.array([np.sqrt(z.area_m2 / np.pi) for z in site.polygon_zones])
    gn = np.linalg.norm(site.gn_xy_m[:, None] - centres[None], axis=-1)
    home = np.linalg.norm(site.home_xy_m - centres, axis=-1)
    if np.any(gn < radii[None]) or np.any(home < radii + site.buffer_m):
        return None
    names = tuple(z.name for z in site.polygon_zones)
    return replace(site, nfz_names=names, nfz_xy_m=centres, nfz_radius_m=radii,
                   polygon_zones=())


def hull_twin(site: Site) -> Site:
    """The site with each non-convex polygon zone replaced by its convex hull."""
    hulls = tuple(polygon_zone(z.name, np.asarray(z.shape.convex_hull.exterior.coords), "hull")
                  for z in site.polygon_zones)
    return replace(site, polygon_zones=hulls)


def polygon_row(seed: int) -> dict[str, Any]:
    site = random_polygon_site(seed, buffer_m=BUFFER_M)
    started = time.perf_counter()
    sol = plan(site, "proposed", options=PAPER_OPTIONS)
    elapsed = time.perf_counter() - started
    row: dict[str, Any] = {
           "seed": seed, "rate": sol.min_rate_bps_hz, "time_s": elapsed,
           "clear_m": worst_clearance_m(site, sol.trajectory_m), "iterations": sol.iterations,
           "nonconvex": sum(not z.is_convex for z in site.polygon_zones),
           "parts": sum(len(z.parts) for z in site.polygon_zones)}
    twin = circle_twin(site)
    row["circle_rate"] = (None if twin is None else
                          plan(twin, "proposed", options=PAPER_OPTIONS).min_rate_bps_hz)
    if row["nonconvex"]:
        row["hull_rate"] = plan(hull_twin(site), "proposed", options=PAPER_OPTIONS).min_rate_bps_hz
    return row


def tangent_row(source: str | int) -> dict[str, Any]:
    site = load_site(source) if isinstance(source, str) else random_site(source)
    name = Path(source).stem if isinstance(source, str) else f"random-{source}"
    out: dict[str, Any] = {"site": name}
    for scheme in ("proposed", "tangent"):
        started = time.perf_counter()
        sol = plan(site, scheme, options=PAPER_OPTIONS)
        out[scheme] = sol.min_rate_bps_hz
        out[scheme + "_clear_m"] = sol.nfz_clearance_min_m - site.buffer_m
        out[scheme + "_s"] = time.perf_counter() - started
    return out


def _summary(values: list[float]) -> str:
    return (f"mean {statistics.fmean(values):.4f}  median {statistics.median(values):.4f}  "
            f"min {min(values):.4f}  max {max(values):.4f}")


def main() -> None:
    parser = CommandParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sites", type=int, default=50)
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args()
    seeds = list(range(args.sites))
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(polygon_row, seeds))
        circle = list(pool.map(tangent_row, [str(p) for p in SAMPLES] + seeds))

    print(f"1. proposed on {len(rows)} random polygon sites (buffer {BUFFER_M:g} m, "
          f"{sum(r['nonconvex'] for r in rows)} of {3 * len(rows)} zones non-convex, "
          f"{sum(r['parts'] for r in rows)} convex parts)")
    print(f"{'seed':>4} {'min rate':>9} {'worst clear m':>13} {'time s':>7} {'iter':>4} "
          f"{'circles':>8} {'hulls':>8}")
    for r in rows:
        circ = f"{r['circle_rate']:.4f}" if r["circle_rate"] is not None else "-"
        hull = f"{r['hull_rate']:.4f}" if "hull_rate" in r else "-"
        print(f"{r['seed']:>4} {r['rate']:>9.4f} {r['clear_m']:>13.3f} {r['time_s']:>7.1f} "
              f"{r['iterations']:>4} {circ:>8} {hull:>8}")
    print(f"min rate bps/Hz: {_summary([r['rate'] for r in rows])}")
    print(f"worst leg clearance: {min(r['clear_m'] for r in rows):.4f} m "
          f"(buffer {BUFFER_M:g} m; legs inside a zone: "
          f"{sum(r['clear_m'] < BUFFER_M - 1e-6 for r in rows)} sites)")
    print(f"time s: {_summary([r['time_s'] for r in rows])}")
    paired = [r for r in rows if r["circle_rate"] is not None]
    cost = [100 * (r["rate"] / r["circle_rate"] - 1) for r in paired]
    print(f"polygons vs circles of the same area ({len(paired)} sites; "
          f"{len(rows) - len(paired)} twins left out): min rate change % {_summary(cost)}")
    hulls = [r for r in rows if "hull_rate" in r]
    hcost = [100 * (r["hull_rate"] / r["rate"] - 1) for r in hulls]
    print(f"convex hull instead of convex parts ({len(hulls)} sites with a non-convex zone): "
          f"min rate change % {_summary(hcost)}")

    print(f"\n2. tangent vs proposed on circle sites ({len(circle)}: samples, random_site 0.."
          f"{args.sites - 1})")
    print(f"{'site':>16} {'proposed':>9} {'tangent':>9} {'change %':>9} {'clear m p/t':>14}")
    for r in circle:
        change = 100 * (r["tangent"] / r["proposed"] - 1)
        print(f"{r['site']:>16} {r['proposed']:>9.4f} {r['tangent']:>9.4f} {change:>9.3f} "
              f"{r['proposed_clear_m']:>6.2f}/{r['tangent_clear_m']:<6.2f}")
    change = [100 * (r["tangent"] / r["proposed"] - 1) for r in circle]
    print(f"tangent vs proposed min rate change %: {_summary(change)}; tangent higher on "
          f"{sum(c > 0.01 for c in change)}, lower on {sum(c < -0.01 for c in change)} of "
          f"{len(change)} (±0.01 % = equal)")
    print(f"worst clearance beyond the buffer: proposed "
          f"{min(r['proposed_clear_m'] for r in circle):.3f} m, tangent "
          f"{min(r['tangent_clear_m'] for r in circle):.3f} m")
    print(f"time s: proposed {statistics.fmean(r['proposed_s'] for r in circle):.1f}, tangent "
          f"{statistics.fmean(r['tangent_s'] for r in circle):.1f} (mean)")


if __name__ == "__main__":
    main()
