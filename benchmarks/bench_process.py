"""Whole-process benchmark: ``plan-mission`` on the sample site as a user runs it.

Run by hand (figures, not pass/fail):

    .venv/bin/python benchmarks/bench_process.py [--runs 5]
    git worktree add /tmp/before f04b71c   # the last commit before issue 15
    .venv/bin/python benchmarks/bench_process.py --before /tmp/before

Times ``plan-mission samples/paper-default.yaml -o OUT.plan`` as a fresh process for both
``--dynamics`` modes (median of ``--runs``; Python start-up, imports, planning, export and the
flight replay included) and prints the issue's figure beside each. ``--before CHECKOUT`` also
times that checkout of the package on the same machine, alternating run by run, so that the
machine's spells (this one drifts by ±15 %) fall on both alike; the issue's figures were taken
on a slower machine. On a shared machine compare the CPU seconds (user + system of the
process), which load changes far less than wall time.

Each checkout runs once untimed first, with bytecode writing on: an installed program has its
``.pyc`` files after its first run, and a ``PYTHONDONTWRITEBYTECODE`` in the caller's
environment would otherwise charge every run the compile of every module (about 0.05 s).
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from validator.errors import CommandParser

SAMPLE = Path(__file__).resolve().parents[1] / "samples" / "paper-default.yaml"
# Issue 15's figures, before it (cvxpy-compiled subproblems): median of 3 whole processes on the
# sample, the machine near quiet (load 1.7-2.7): wall and CPU seconds.
TODAY = {"none": "3.89 s, CPU 2.93 s", "vehicle": "7.98 s, CPU 7.16 s"}
DYNAMICS = ("none", "vehicle")

RUN = "from mission_planner.cli import plan_mission_main; plan_mission_main()"


def _time_once(checkout: str | None, dynamics: str, out: Path) -> tuple[float, float]:
    """Wall and CPU seconds of one ``plan-mission`` process of ``checkout`` (None: the
    package this Python imports)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    if checkout is not None:
        env["PYTHONPATH"] = checkout
    cmd = [sys.executable, "-c", RUN, str(SAMPLE), "-o", str(out), "--dynamics", dynamics]
    started = time.perf_counter()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    # From the output's directory: run from a checkout, ``-c`` would put that checkout first on
    # sys.path, ahead of PYTHONPATH.
    done = subprocess.run(cmd, capture_output=True, text=True, check=False, cwd=out.parent,
                          env=env)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.exit(f"plan-mission failed ({checkout or 'this checkout'}, {dynamics}): "
                 f"{done.stderr.strip()[-500:]}")
    return wall, after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime


def _figure(times: list[tuple[float, float]]) -> str:
    wall = [w for w, _ in times]
    return (f"{statistics.median(wall):.2f} s (min {min(wall):.2f}, max {max(wall):.2f}), "
            f"CPU {statistics.median(c for _, c in times):.2f} s")


def main() -> None:
    parser = CommandParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--before", metavar="CHECKOUT",
                        help="also time this checkout of the package, alternating run by run")
    args = parser.parse_args()
    if args.before is not None and not (Path(args.before) / "mission_planner").is_dir():
        # PYTHONPATH would name nothing, and the child would quietly time this checkout twice.
        print(f"bench_process: --before {args.before}: no mission_planner package there",
              file=sys.stderr)
        sys.exit(2)
    checkouts: list[str | None] = [None] if args.before is None else [None, args.before]
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "bench.plan"
        for dynamics in DYNAMICS:
            for checkout in checkouts:
                _time_once(checkout, dynamics, out)  # bytecode written, caches warm
            times: dict[str | None, list[tuple[float, float]]] = {c: [] for c in checkouts}
            for _ in range(args.runs):
                for checkout in checkouts:
                    times[checkout].append(_time_once(checkout, dynamics, out))
            line = f"plan-mission --dynamics {dynamics:<7}: median of {args.runs} "
            line += _figure(times[None])
            if args.before is not None:
                line += f"; {args.before}: {_figure(times[args.before])}"
            print(f"{line}; the issue's before, on its machine: {TODAY[dynamics]}")


if __name__ == "__main__":
    main()
