"""Planner benchmark: speed on the sample site, quality on ten seeded random sites.

Run by hand (figures, not pass/fail):

    .venv/bin/python benchmarks/bench_planner.py                     # the paper's model
    .venv/bin/python benchmarks/bench_planner.py --dynamics vehicle  # plan-mission's default

Prints
- wall time of planning samples/paper-default.yaml: the first run in this process and the
  median of ``--runs`` runs (Python start-up and imports excluded; ``bench_process.py`` times
  whole ``plan-mission`` processes);
- for 10 random sites (400 m square, K = 4, M = 3, R = 30 m, the paper's defaults) and both
  schemes: min rate, its ratio to the hover upper bound, iterations, solve time, and whether
  and how deep the straight legs cut an NFZ;
- beside each min rate, today's (before issue 15) and the change; the promise is that no site
  loses more than 0.1 %.
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

from mission_planner.optimize import PlannerOptions, plan
from mission_planner.study.sites import random_site
from validator.channel import hover_upper_bound
from validator.errors import CommandParser
from validator.site import Site, load_site

SAMPLE = Path(__file__).resolve().parents[1] / "samples" / "paper-default.yaml"

# Before issue 15, this machine under a load of 8-12 (two compile jobs): sample site seconds
# (first run, median) and min rate; per seed, (proposed, conventional) min rate bps/Hz.
TODAY: dict[str, dict[object, tuple[float, float]]] = {
    "none": {
        "sample": (16.07, 16.07),
        0: (2.4172, 2.4172), 1: (2.2407, 2.2410), 2: (2.2292, 2.2312), 3: (2.2590, 2.2610),
        4: (2.1622, 2.1412), 5: (2.2807, 2.2815), 6: (2.3701, 2.3701), 7: (2.2722, 2.2722),
        8: (2.2521, 2.2612), 9: (2.2908, 2.2921),
    },
    "vehicle": {
        "sample": (53.44, 53.44),
        0: (1.8106, 1.8340), 1: (1.3841, 1.3841), 2: (1.2714, 1.5038), 3: (1.5803, 1.5799),
    },
}
TODAY_SAMPLE_RATE = {"none": 2.1129, "vehicle": 1.3515}


def bound(site: Site) -> float:
    return hover_upper_bound(site.num_gns, site.altitude_m, site.p_avg_w, site.beta0, site.noise_w)


def main() -> None:
    parser = CommandParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--sites", type=int, default=10)
    parser.add_argument("--dynamics", choices=("none", "vehicle"), default="none")
    args = parser.parse_args()
    options = PlannerOptions(dynamics=args.dynamics)
    today = TODAY[args.dynamics]

    sample = load_site(SAMPLE)
    times = []
    for _ in range(args.runs):
        started = time.perf_counter()
        sol = plan(sample, "proposed", options=options)
        times.append(time.perf_counter() - started)
    print(
        f"sample site ({SAMPLE.name}, proposed, dynamics {args.dynamics}): first run "
        f"{times[0]:.2f} s, median of {args.runs} {statistics.median(times):.2f} s, "
        f"min rate {sol.min_rate_bps_hz:.4f} bps/Hz ({sol.iterations} iterations)"
    )
    if "sample" in today:
        first, median = today["sample"]
        print(f"  today: first run {first:.2f} s, median {median:.2f} s, "
              f"min rate {TODAY_SAMPLE_RATE.get(args.dynamics, float('nan')):.4f} bps/Hz")

    print(
        f"\n{'seed':>4} {'scheme':>12} {'min rate':>9} {'today':>7} {'change':>8} {'ratio':>6}"
        f" {'iter':>5} {'time s':>7} {'clearance m':>12}"
    )
    results: dict[str, list[tuple[float, float, float]]] = {"proposed": [], "conventional": []}
    worst = 0.0
    for seed in range(args.sites):
        site = random_site(seed)
        for i, scheme in enumerate(results):
            started = time.perf_counter()
            sol = plan(site, scheme, options=options)
            elapsed = time.perf_counter() - started
            ratio = sol.min_rate_bps_hz / bound(site)
            results[scheme].append((sol.min_rate_bps_hz, ratio, sol.nfz_clearance_min_m))
            before = today.get(seed, (float("nan"),) * 2)[i]
            change = 100 * (sol.min_rate_bps_hz - before) / before
            worst = min(worst, change) if change == change else worst
            print(
                f"{seed:>4} {scheme:>12} {sol.min_rate_bps_hz:>9.4f} {before:>7.4f} "
                f"{change:>+7.2f}% {ratio:>6.3f} {sol.iterations:>5} {elapsed:>7.2f} "
                f"{sol.nfz_clearance_min_m:>12.3f}"
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
    print(f"largest loss against today: {worst:+.2f} % (promise: no worse than -0.10 %)")


if __name__ == "__main__":
    main()
