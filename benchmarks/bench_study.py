"""Study throughput and planner scaling, run by hand (not part of the test suite).

    .venv/bin/python benchmarks/bench_study.py            # a few sizes, a few minutes
    .venv/bin/python benchmarks/bench_study.py --full     # N 25..200, K 2..10, M 1..10

1. Trials per minute of a Fig. 4 style study at the paper's size (N = 50, K = 4, M = 3, R = 30 m)
   with 1 and 2 local workers (``run_trials``; 1 worker runs in this process).
   ``--fig4 T``: the wall time of a real Fig. 4 study (``run_fig4``, the paper's grid of
   5 radii and 5 zone counts, both schemes) with T trials per point on 2 workers, and the full
   study's (100 per point: 1800 trials, the radius and count sweeps share one point)
   projected from it, beside today's.
2. Solve time of ``plan`` on random paper sites as N, K and M grow one at a time from the
   paper's defaults, with the growth exponent b of time ~ N^b fitted by least squares on logs.
   Each row is the median over ``--seeds`` sites; the first site of each size also pays cvxpy's
   one-off compile of that problem shape, as the first trial of a study does.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from mission_planner.optimize import PlannerOptions
from mission_planner.study.config import trial_seed
from mission_planner.study.executors import default_workers, run_trials
from mission_planner.study.trials import TrialSpec, run_trial
from validator.errors import CommandParser

QUICK = {"N": (25, 50, 100), "K": (2, 4, 8), "M": (1, 3, 6)}
FULL = {"N": (25, 50, 75, 100, 150, 200), "K": (2, 4, 6, 8, 10), "M": (1, 2, 4, 6, 8, 10)}
PAPER = {"N": 50, "K": 4, "M": 3}
# Before issue 15: 35-45 trials a minute on 2 workers, a full Fig. 4 study close to an hour.
TODAY_FIG4_MIN = 50.0


def throughput(workers: int, trials: int, slots: int, seed: int) -> float:
    """Trials per minute of ``trials`` paper-size trials (both schemes alternating)."""
    specs = [
        TrialSpec(seed=trial_seed(seed, i // 2), scheme=("proposed", "conventional")[i % 2],
                  slots=slots)
        for i in range(trials)
    ]
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        run = run_trials(specs, tmp, workers=workers, progress=False)
        elapsed = time.perf_counter() - start
    if run.failed:
        print(f"  note: {len(run.failed)} of {trials} trials failed: {run.failed[0]['error']}")
    return 60.0 * trials / elapsed


def fig4_wall_time(trials_per_point: int) -> None:
    """Run a Fig. 4 study with ``trials_per_point`` on 2 workers; print its wall time and the
    full study's (100 trials per point) projected at the same rate."""
    from mission_planner.study.config import Fig4Config
    from mission_planner.study.fig4 import run_fig4

    config = Fig4Config(trials=trials_per_point)
    total = len(config.specs())
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        run_fig4(tmp, config, workers=2, progress=False)
        elapsed = time.perf_counter() - start
    full = elapsed * len(Fig4Config().specs()) / total
    print(f"fig4: {total} trials ({trials_per_point} per point) on 2 workers in {elapsed:.0f} s "
          f"({60 * total / elapsed:.0f} trials/minute); full study (100 per point) "
          f"{full / 60:.1f} min; today about {TODAY_FIG4_MIN:.0f} min", flush=True)


def _spec(vary: str, value: int, seed: int, scheme: str) -> TrialSpec:
    p = dict(PAPER)
    p[vary] = value
    return TrialSpec(seed=seed, scheme=scheme, num_gns=p["K"], num_nfzs=p["M"], slots=p["N"])


def scaling(vary: str, values: Sequence[int], seeds: int, scheme: str,
            options: PlannerOptions) -> list[dict[str, Any]]:
    """Median solve time, iterations and time per iteration for each value of ``vary``."""
    rows = []
    for value in values:
        runs = [run_trial(_spec(vary, value, trial_seed(0, i), scheme), options)
                for i in range(seeds)]
        ok = [r for r in runs if not r["error"]]
        if not ok:
            print(f"  {vary}={value}: every run failed: {runs[0]['error']}")
            continue
        rows.append({
            vary: value,
            "solve_s": statistics.median(r["solve_seconds"] for r in ok),
            "iterations": statistics.median(r["iterations"] for r in ok),
            "s_per_iteration": statistics.median(r["solve_seconds"] / max(r["iterations"], 1)
                                                 for r in ok),
            "failed": len(runs) - len(ok),
        })
        r = rows[-1]
        print(f"  {vary}={value:4d}  solve {r['solve_s']:8.2f} s  iterations {r['iterations']:6.1f}"
              f"  {1000 * r['s_per_iteration']:8.1f} ms/iteration  failed {r['failed']}",
              flush=True)
    return rows


def growth_exponent(x: Sequence[float], y: Sequence[float]) -> float:
    """b of y ~ a x^b, least squares on log-log."""
    slope, _ = np.polyfit(np.log(np.asarray(x, float)), np.log(np.asarray(y, float)), 1)
    return float(slope)


def main(argv: Sequence[str] | None = None) -> int:
    parser = CommandParser(description=__doc__.split("\n")[0] if __doc__ else None)
    parser.add_argument("--full", action="store_true", help="N 25..200, K 2..10, M 1..10")
    parser.add_argument("--seeds", type=int, default=2, help="sites per size (2)")
    parser.add_argument("--scheme", default="proposed", choices=("proposed", "conventional"))
    parser.add_argument("--trials", type=int, default=16,
                        help="trials per throughput run (16: enough to amortise worker start-up)")
    parser.add_argument("--slots", type=int, default=50, help="N of the throughput runs (50)")
    parser.add_argument("--max-iterations", type=int, default=None,
                        help="cap on Algorithm 1's iterations (planner default)")
    parser.add_argument("--skip-throughput", action="store_true")
    parser.add_argument("--skip-scaling", action="store_true")
    parser.add_argument("--fig4", type=int, default=0, metavar="T",
                        help="also time a Fig. 4 study with T trials per point on 2 workers")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")  # cvxpy's per-solve accuracy warnings would drown the table
    options = (PlannerOptions(dynamics="none") if args.max_iterations is None
               else PlannerOptions(dynamics="none", max_iterations=args.max_iterations))

    print(f"machine: {default_workers()} CPUs available to this process")
    if not args.skip_throughput:
        print(f"throughput: {args.trials} trials, N={args.slots}, K=4, M=3, R=30 m, both schemes")
        for workers in (1, 2):
            tpm = throughput(workers, args.trials, args.slots, seed=0)
            print(f"  {workers} worker{'s' if workers > 1 else ' '}: {tpm:6.1f} trials/minute",
                  flush=True)
    if args.fig4:
        fig4_wall_time(args.fig4)
    if not args.skip_scaling:
        sizes = FULL if args.full else QUICK
        print(f"scaling ({args.scheme}, {args.seeds} sites per size, others at N=50 K=4 M=3):")
        for vary, values in sizes.items():
            rows = scaling(vary, values, args.seeds, args.scheme, options)
            if vary == "N" and len(rows) >= 2:
                n = [r["N"] for r in rows]
                print(f"  growth exponent in N: solve time ~ N^"
                      f"{growth_exponent(n, [r['solve_s'] for r in rows]):.2f}, "
                      f"time per iteration ~ N^"
                      f"{growth_exponent(n, [r['s_per_iteration'] for r in rows]):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
