"""Flyable plans: planned vs replayed cycle time and min rate, with and without dynamics.

Run by hand (figures, not pass/fail):

    .venv/bin/python benchmarks/bench_dynamics.py            # sample site + 10 random sites
    .venv/bin/python benchmarks/bench_dynamics.py --sites 3  # a shorter run
    .venv/bin/python benchmarks/bench_dynamics.py --realistic --sites 5  # realistic sites

For samples/paper-default.yaml and the benchmark sites ``random_site(seed)`` (seeds 0..N-1;
400 m square, K = 4, M = 3, R = 30 m, T = 50 s, N = 50, V = 30 m/s, with the site file's
default 2 m safety buffer), each planned with ``--dynamics none`` (the paper's kinematic model)
and ``--dynamics vehicle`` (the default) and exported as plan-mission does (long legs merged),
prints: solve time (the optimiser, wall clock), service waypoints and how many were merged,
the planned cycle T and the cycle replayed by the validator's ``arducopter`` model at the
recommended parameters (the .param plan-mission writes), the planned min rate and the min rate
along the replayed track, and the worst replayed NFZ clearance; then per site the ratio of the
vehicle plan's min rate to the none plan's (planned and replayed) and a summary.

``--realistic`` (issue 11, throughput per flown second): samples/realistic.yaml and random
realistic sites instead: ``random_site(seed)`` with V drawn in 8–15 m/s and T in 120–240 s
(seeded, so the same sites every run), 3 m buffer, N = 64, ArduCopter's default A and J. The
replayed min rate is integrated along the replayed track per flown second, so the vehicle plan
(which flies its cycle in T) is compared with the paper-model plan flown as it is (which
overruns T); the ratio is the throughput the nodes really get, vehicle over paper.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mission_planner.flight_report import replay_mission
from mission_planner.pipeline import plan_and_build
from mission_planner.study.sites import random_site
from validator.errors import CommandParser
from validator.site import Site, load_site

SAMPLES = Path(__file__).resolve().parents[1] / "samples"
SAMPLE = SAMPLES / "paper-default.yaml"
REALISTIC = SAMPLES / "realistic.yaml"
# "vehicle" passes through the corners whose turn keeps the buffer; "stops" is the vehicle
# plan that stops at every waypoint (--stop-at-every-waypoint), as plans were before
MODES = ("none", "stops", "vehicle")
REALISTIC_SPEED_MPS = (8.0, 15.0)
REALISTIC_PERIOD_S = (120.0, 240.0)


def realistic_site(seed: int) -> Site:
    """A random realistic site: V in 8–15 m/s and T in 120–240 s drawn from ``seed``."""
    rng = np.random.default_rng([11, seed])
    speed = round(float(rng.uniform(*REALISTIC_SPEED_MPS)), 1)
    period = float(round(rng.uniform(*REALISTIC_PERIOD_S)))
    return random_site(seed, buffer_m=3.0, max_speed_mps=speed, period_s=period, slots=64)


@dataclass(frozen=True)
class Row:
    site: str
    dynamics: str
    solve_s: float
    waypoints: int
    merged: int
    period_s: float
    replayed_cycle_s: float
    planned_rate: float
    replayed_rate: float
    clearance_m: float
    problems: int

    @property
    def cycle_ratio(self) -> float:
        return self.replayed_cycle_s / self.period_s

    @property
    def rate_ratio(self) -> float:
        return self.replayed_rate / self.planned_rate if self.planned_rate else float("nan")


def measure(name: str, site: Site, mode: str) -> Row:
    started = time.perf_counter()
    mission = plan_and_build(site, dynamics="none" if mode == "none" else "vehicle",
                             pass_through_corners=mode != "stops")
    solve_s = time.perf_counter() - started
    check = replay_mission(mission)
    nan = float("nan")
    return Row(
        site=name,
        dynamics=mode,
        solve_s=solve_s,
        waypoints=len(mission.steps),
        merged=mission.merged_waypoints,
        period_s=site.period_s,
        replayed_cycle_s=check.replayed_cycle_s or nan,
        # the optimiser's own figure: what the paper's model promises for this plan
        planned_rate=mission.solution.min_rate_bps_hz,
        replayed_rate=check.replayed_min_rate_bps_hz or nan,
        clearance_m=min(check.clearance_by_nfz_m.values(), default=nan),
        problems=len(mission.problems),
    )


def print_row(r: Row) -> None:
    print(f"{r.site:>14} {r.dynamics:>8} {r.solve_s:>7.1f} {r.waypoints:>4} {r.merged:>4} "
          f"{r.period_s:>5.0f} {r.replayed_cycle_s:>7.1f} {r.cycle_ratio:>6.2f} "
          f"{r.planned_rate:>8.4f} {r.replayed_rate:>8.4f} {r.rate_ratio:>6.3f} "
          f"{r.clearance_m:>8.2f}{'  UNSAFE' if r.problems else ''}", flush=True)


def main() -> None:
    parser = CommandParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sites", type=int, default=10,
                        help="random benchmark sites (seeds 0..N-1; default 10)")
    parser.add_argument("--buffer-m", type=float, default=2.0,
                        help="safety buffer of the random sites (m; default 2, the site default)")
    parser.add_argument("--no-sample", action="store_true", help="skip the sample site")
    parser.add_argument("--realistic", action="store_true",
                        help="samples/realistic.yaml and random realistic sites (V 8-15 m/s, "
                             "T 120-240 s) instead of the paper's")
    args = parser.parse_args()

    sites: list[tuple[str, Site]] = []
    if not args.no_sample:
        sample = REALISTIC if args.realistic else SAMPLE
        sites.append((sample.stem, load_site(sample)))
    for s in range(args.sites):
        if args.realistic:
            site = realistic_site(s)
            sites.append((f"s{s} V{site.max_speed_mps:g} T{site.period_s:g}", site))
        else:
            sites.append((f"seed {s}", random_site(s, buffer_m=args.buffer_m)))

    print(f"{'site':>14} {'dynamics':>8} {'solve s':>7} {'wps':>4} {'mrgd':>4} {'T s':>5} "
          f"{'flown s':>7} {'/T':>6} {'planned':>8} {'flown':>8} {'ratio':>6} {'clr m':>8}")
    print(f"{'':>50}{'min rate bps/Hz':^24}")
    rows: dict[tuple[str, str], Row] = {}
    for name, site in sites:
        for dyn in MODES:
            try:
                row = measure(name, site, dyn)
            except Exception as err:  # a figure, not a verdict: report it and go on
                print(f"{name:>14} {dyn:>8} failed: {type(err).__name__}: {err}", flush=True)
                continue
            rows[name, dyn] = row
            print_row(row)

    print("\nmin rate with dynamics / without (same site; replayed = per flown second):")
    print(f"{'site':>14} {'stops planned':>13} {'replayed':>9} {'vehicle planned':>15} "
          f"{'replayed':>9}")
    ratios: dict[str, tuple[list[float], list[float]]] = {"stops": ([], []), "vehicle": ([], [])}
    width = {"stops": 13, "vehicle": 15}  # the header's column widths
    for name, _ in sites:
        if (name, "none") not in rows:
            continue
        n = rows[name, "none"]
        cells = []
        for mode, (planned, flown) in ratios.items():
            if (name, mode) not in rows:
                cells.append(f"{'-':>{width[mode]}} {'-':>9}")
                continue
            v = rows[name, mode]
            planned.append(v.planned_rate / n.planned_rate)
            flown.append(v.replayed_rate / n.replayed_rate)
            cells.append(f"{planned[-1]:>{width[mode]}.3f} {flown[-1]:>9.3f}")
        print(f"{name:>14} {' '.join(cells)}")

    print("\nsummary (mean over sites; min-max):")
    for dyn in MODES:
        rs = [rows[name, dyn] for name, _ in sites if (name, dyn) in rows]
        if not rs:
            continue
        cyc = [r.cycle_ratio for r in rs]
        rate = [r.rate_ratio for r in rs]
        on_time = sum(abs(c - 1.0) <= 0.10 for c in cyc)
        within = sum(x >= 0.95 for x in rate)
        clear = sum(r.clearance_m >= 0 for r in rs)
        failed = len(sites) - len(rs)
        print(f"  {dyn:>8}: {len(rs)} plans ({failed} failed); "
              f"replayed cycle / T {statistics.mean(cyc):.2f} ({min(cyc):.2f}-"
              f"{max(cyc):.2f}), within 10 %: {on_time}/{len(rs)}; replayed / planned min rate "
              f"{statistics.mean(rate):.3f} ({min(rate):.3f}-{max(rate):.3f}), within 5 %: "
              f"{within}/{len(rs)}; replayed track clear of every NFZ: {clear}/{len(rs)}; "
              f"solve {statistics.mean(r.solve_s for r in rs):.1f} s; "
              f"waypoints {statistics.mean(r.waypoints for r in rs):.1f} "
              f"({statistics.mean(r.merged for r in rs):.1f} merged)")
    for mode, (planned, flown) in ratios.items():
        if not planned:
            continue
        print(f"  {mode} / none min rate: planned {statistics.mean(planned):.3f} "
              f"({min(planned):.3f}-{max(planned):.3f}), replayed "
              f"{statistics.mean(flown):.3f} ({min(flown):.3f}-{max(flown):.3f}); "
              f"replayed {mode} >= none on {sum(r >= 1.0 for r in flown)}/{len(flown)} sites")


if __name__ == "__main__":
    main()
