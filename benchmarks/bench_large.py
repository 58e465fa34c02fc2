"""Large-site benchmark: wall time and peak memory of one ``plan`` in a fresh process.

Run by hand (figures, not pass/fail):

    .venv/bin/python benchmarks/bench_large.py                  # N = 200, K = 10, M = 10, 800 m
    .venv/bin/python benchmarks/bench_large.py --slots 400      # does N = 400 plan at all?
    .venv/bin/python benchmarks/bench_large.py --period 100     # T = 100 s: the issue's size

The plan runs in a child process so that its peak resident memory (``ru_maxrss`` of the child,
start-up and imports included) is the planner's alone. Prints today's figures beside the new
ones where they were measured (issue 15, this 2-core machine).
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import time

from validator.errors import CommandParser

# Before issue 15 (cvxpy-compiled subproblems), seed 0, 800 m square:
# (N, K, M, scheme, T s) -> (plan s, peak MB, min rate bps/Hz). T = 50 s was measured on a
# 2-core machine under a load of about 8 (two compile jobs); T = 100 s is f04b71c on a quiet
# machine on 2026-12-02 (issue 15 named 30 s and 6.8 GB for its N = 200 site).
TODAY = {
    (200, 10, 10, "proposed", 50.0): (116.4, 3685.0, 0.4844),
    (200, 10, 10, "proposed", 100.0): (35.0, 6663.0, 0.7130),
}

CHILD = """
import json, sys, time
from mission_planner.optimize import PlannerOptions, plan
from mission_planner.study.sites import random_site
a = json.loads(sys.argv[1])
site = random_site(a["seed"], num_gns=a["gns"], num_nfzs=a["nfzs"], slots=a["slots"],
                   area_m=a["area"], period_s=a["period"])
started = time.perf_counter()
sol = plan(site, a["scheme"], options=PlannerOptions(dynamics=a["dynamics"]))
print(json.dumps({"plan_s": time.perf_counter() - started, "min_rate": sol.min_rate_bps_hz,
                  "iterations": sol.iterations}))
"""


def main() -> None:
    parser = CommandParser(description=__doc__.splitlines()[0])
    parser.add_argument("--slots", type=int, default=200)
    parser.add_argument("--gns", type=int, default=10)
    parser.add_argument("--nfzs", type=int, default=10)
    parser.add_argument("--area", type=float, default=800.0, help="square side, m")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--period", type=float, default=50.0, help="cycle T, s")
    parser.add_argument("--scheme", default="proposed")
    parser.add_argument("--dynamics", default="none")
    args = parser.parse_args()

    spec = {k: getattr(args, k) for k in ("slots", "gns", "nfzs", "area", "seed", "scheme",
                                          "dynamics", "period")}
    started = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", CHILD, json.dumps(spec)], capture_output=True,
                         text=True, check=False)
    wall = time.perf_counter() - started
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    if out.returncode != 0:
        print(f"plan failed (exit {out.returncode}, peak {peak_mb:.0f} MB):\n{out.stderr[-2000:]}")
        sys.exit(1)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    print(f"N={args.slots} K={args.gns} M={args.nfzs} area={args.area:g} m T={args.period:g} s "
          f"seed={args.seed} {args.scheme}, dynamics {args.dynamics}")
    print(f"  now:   process {wall:.1f} s (plan {res['plan_s']:.1f} s), peak {peak_mb:.0f} MB, "
          f"min rate {res['min_rate']:.4f} bps/Hz, {res['iterations']} iterations")
    today = TODAY.get((args.slots, args.gns, args.nfzs, args.scheme, args.period))
    if today is not None and args.dynamics == "none" and args.seed == 0 and args.area == 800:
        print(f"  today: plan {today[0]:.1f} s, peak {today[1]:.0f} MB, "
              f"min rate {today[2]:.4f} bps/Hz")


if __name__ == "__main__":
    main()
