"""Planner benchmark: speed on the sample site, quality on ten seeded random sites.

Run by hand (figures, not pass/fail):  .venv/bin/python benchmarks/bench_planner.py

Prints
- wall time of planning samples/paper-default.yaml: the first run in a fresh process (includes
  cvxpy compiling the three subproblems) and the median of 5 runs (Python start-up and imports
  excluded; later runs reuse the compiled problems, as a notebook or a study does);
- for 10 random sites (400 m square, K = 4, M = 3, R = 30 m, the paper's defaults) and both
  schemes: min rate, its ratio to the hover upper bound, iterations, solve time, and whether
  and how deep the straight legs cut an NFZ.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from mission_planner.optimize import plan
from mission_planner.study.sites import random_site
from validator.channel import hover_upper_bound
from validator.site import Site, load_site

SAMPLE = Path(__file__).resolve().parents[1] / "samples" / "paper-default.yaml"


def bound(site: Site) -> float:
    return hover_upper_bound(site.num_gns, site.altitude_m, site.p_avg_w, site.beta0, site.noise_w)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--sites", type=int, default=10)
    args = parser.parse_args()

    sample = load_site(SAMPLE)
    times = []
    for _ in range(args.runs):
        started = time.perf_counter()
        sol = plan(sample, "proposed")
        times.append(time.perf_counter() - started)
    print(
        f"sample site ({SAMPLE.name}, proposed): first run {times[0]:.2f} s, "
        f"median of {args.runs} {statistics.median(times):.2f} s, "
        f"min rate {sol.min_rate_bps_hz:.4f} bps/Hz ({sol.iterations} iterations)"
    )

    print(
        f"\n{'seed':>4} {'scheme':>12} {'min rate':>9} {'ratio':>6} {'iter':>5} {'time s':>7}"
        f" {'clearance m':>12}"
    )
    results: dict[str, list[tuple[float, float, float]]] = {"proposed": [], "conventional": []}
    for seed in range(args.sites):
        site = random_site(seed)
        for scheme in results:
            started = time.perf_counter()
            sol = plan(site, scheme)
            elapsed = time.perf_counter() - started
            ratio = sol.min_rate_bps_hz / bound(site)
            results[scheme].append((sol.min_rate_bps_hz, ratio, sol.nfz_clearance_min_m))
            print(
                f"{seed:>4} {scheme:>12} {sol.min_rate_bps_hz:>9.4f} {ratio:>6.3f} "
                f"{sol.iterations:>5} {elapsed:>7.2f} {sol.nfz_clearance_min_m:>12.3f}"
            )

    print()
    for scheme, rows in results.items():
        ratios = [r for _, r, _ in rows]
        cuts = [c for _, _, c in rows if c < 0]
        depth = f", deepest {-min(cuts):.2f} m" if cuts else ""
        print(
            f"{scheme:>12}: mean min rate {statistics.mean(r for r, _, _ in rows):.4f} bps/Hz, "
            f"mean ratio {statistics.mean(ratios):.4f}, lowest {min(ratios):.3f}; "
            f"{len(cuts)}/{len(rows)} plans cut an NFZ{depth}"
        )
    prop = statistics.mean(r for r, _, _ in results["proposed"])
    conv = statistics.mean(r for r, _, _ in results["conventional"])
    print(f"proposed vs conventional mean min rate: {100 * (prop - conv) / conv:+.2f} %")


if __name__ == "__main__":
    main()
