"""PX4 plans: stopping at every waypoint vs flying through the corners whose swing region keeps
the buffer (issue 26 item 6), replayed by the validator's ``px4`` model.

Run by hand (figures, not pass/fail):

    .venv/bin/python benchmarks/bench_px4_corners.py              # samples + realistic_site(1..6)
    .venv/bin/python benchmarks/bench_px4_corners.py --sites 2    # realistic_site(1..2) only
    .venv/bin/python benchmarks/bench_px4_corners.py --samples realistic airfield --sites 0

Per site, ``plan-mission --autopilot px4 --stop-at-every-waypoint`` ("stops", as PX4 plans
were before), the plan flown through the corners whose swing region keeps the buffer alone
("through", :func:`mission_planner.pipeline.plan_solution`) and ``plan-mission --autopilot
px4`` ("kept": the better of the two on the replayed min rate): planning time (wall
clock), waypoints flown through in the service cycle, the cycle replayed by the ``px4`` model
at the recommended parameters over T, the min rate along the replayed track (bps/Hz, per
flown second), the least replayed clearance and the least swing-region clearance of the
corners flown through (m beyond the published radius; the buffer is the site's).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from mission_planner.flight_report import replay_mission
from mission_planner.mission import MissionOptions, build_mission
from mission_planner.pipeline import plan_and_build, plan_solution
from validator.errors import CommandParser
from validator.motion.px4_swing import zone_swing_clearances_m
from validator.site import Site, load_site

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the realistic sites' definition
from bench_dynamics import realistic_site  # noqa: E402

SAMPLES = Path(__file__).resolve().parents[1] / "samples"


MODES = ("stops", "through", "kept")


def measure(name: str, site: Site, mode: str) -> str:
    options = MissionOptions(autopilot="px4")
    started = time.perf_counter()
    if mode == "through":  # the pass-through plan alone, before the pipeline's comparison
        mission = build_mission(plan_solution(site, options=options), options)
    else:
        mission = plan_and_build(site, options=options, pass_through_corners=mode == "kept")
    solve_s = time.perf_counter() - started
    check = replay_mission(mission)
    flight = check.flight
    acceptance_m = check.profile.si("NAV_ACC_RAD")
    through, swing = 0, float("inf")
    for k, leg in enumerate(flight.legs[:-1]):
        nxt = flight.legs[k + 1]
        if (leg.pass_through and leg.kind == "waypoint" and nxt.kind == "waypoint"
                and leg.length_m > 0 and nxt.length_m > 0 and flight.cycle is not None
                and flight.cycle.start_leg <= k < flight.cycle.end_leg):
            through += 1
            clr = zone_swing_clearances_m(leg.start_xy_m, leg.end_xy_m, nxt.end_xy_m,
                                          acceptance_m, site.nfz_xy_m, site.nfz_radius_m,
                                          site.polygon_zones)
            swing = min(swing, float(clr.min(initial=float("inf"))))
    cycle = check.replayed_cycle_s or float("nan")
    rate = check.replayed_min_rate_bps_hz or float("nan")
    clear = min((p.clearance_m for p in check.report.nfz), default=float("nan"))
    return (f"{name:>16} {mode:>8} {solve_s:>7.1f} {through:>4} {cycle / site.period_s:>7.3f} "
            f"{rate:>8.4f} {clear:>7.2f} {swing:>7.2f} {site.buffer_m:>5g}"
            f"{'  UNSAFE' if mission.problems else ''}")


def main() -> None:
    parser = CommandParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sites", type=int, default=6, help="realistic_site(1..N) (default 6)")
    parser.add_argument("--samples", nargs="*", default=None,
                        help="sample site stems (default: every samples/*.yaml)")
    args = parser.parse_args()
    stems = args.samples if args.samples is not None else sorted(
        p.stem for p in SAMPLES.glob("*.yaml"))
    sites = [(stem, load_site(SAMPLES / f"{stem}.yaml")) for stem in stems]
    sites += [(f"realistic_site({s})", realistic_site(s)) for s in range(1, args.sites + 1)]
    print(f"{'site':>16} {'corners':>8} {'plan s':>7} {'thru':>4} {'cycle/T':>7} "
          f"{'min rate':>8} {'clr m':>7} {'swing m':>7} {'buf m':>5}")
    for name, site in sites:
        for mode in MODES:
            try:
                print(measure(name, site, mode), flush=True)
            except Exception as err:  # a figure, not a verdict: report it and go on
                print(f"{name:>16} failed: {type(err).__name__}: {err}", flush=True)


if __name__ == "__main__":
    main()
