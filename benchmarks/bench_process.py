"""Whole-process benchmark: ``plan-mission`` on the sample site as a user runs it.

Run by hand (figures, not pass/fail):  .venv/bin/python benchmarks/bench_process.py [--runs 5]

Times ``plan-mission samples/paper-default.yaml -o OUT.plan`` as a fresh process for both
``--dynamics`` modes (median of ``--runs``; Python start-up, imports, planning, export and the
flight replay included) and prints today's figure beside each. On a shared machine compare
the CPU seconds (user + system of the process), which load changes far less than wall time.
``PYTHONPATH`` passes through, so the same script times another checkout of the package.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SAMPLE = Path(__file__).resolve().parents[1] / "samples" / "paper-default.yaml"
# Before issue 15 (cvxpy-compiled subproblems): median of 3 whole processes on the sample, this
# machine near quiet (load 1.7-2.7): wall and CPU seconds.
TODAY = {"none": "3.89 s, CPU 2.93 s", "vehicle": "7.98 s, CPU 7.16 s"}

RUN = "from mission_planner.cli import plan_mission_main; plan_mission_main()"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for dynamics in ("none", "vehicle"):
            times, cpu = [], []
            for i in range(args.runs):
                out = Path(tmp) / f"{dynamics}{i}.plan"
                cmd = [sys.executable, "-c", RUN, str(SAMPLE), "-o", str(out),
                       "--dynamics", dynamics]
                started = time.perf_counter()
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                # From the temporary directory: run from a checkout, ``-c`` would put that
                # checkout first on sys.path, ahead of PYTHONPATH.
                done = subprocess.run(cmd, capture_output=True, text=True, check=False, cwd=tmp)
                times.append(time.perf_counter() - started)
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                cpu.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
                if done.returncode != 0:
                    print(f"plan-mission failed ({dynamics}): {done.stderr.strip()[-500:]}")
                    sys.exit(1)
            print(f"plan-mission --dynamics {dynamics:<7}: median of {args.runs} "
                  f"{statistics.median(times):.2f} s (min {min(times):.2f}, max "
                  f"{max(times):.2f}), CPU {statistics.median(cpu):.2f} s; today "
                  f"{TODAY[dynamics]}")


if __name__ == "__main__":
    main()
