"""``nfz-study``: the paper's Fig. 3 and Fig. 4, and a wind sweep (thin wrapper over fig3, fig4
and wind).

    nfz-study fig3 SITE -o DIR [--buffer-m B] [--max-iterations I] [--quiet]
    nfz-study fig4 -o DIR [--trials N] [--radii 10,20,30,40,50] [--counts 1,2,3,4,5] [--seed S]
                   [--slots N] [--max-iterations I] [--workers W | --scheduler tcp://HOST:PORT]
                   [--format csv|parquet] [--retry-errors] [--quiet]
    nfz-study wind SITE -o DIR [--speeds 0,2,4,6,8] [--directions 0,90,180,270]
                   [--turbulence M/S] [--autopilot ardupilot|px4] [--workers W | --scheduler ...]

Exit status (:data:`validator.cli_common.EXIT_STATUS`): bad input or a broken executor (a
scheduler that cannot be reached): one line on stderr, exit 2, no output. Interrupted: exit
130; run the same command again to resume. Failed trials: kept in the table with their error;
a sweep point that lost some of its trials keeps a result over the rest (one line on stderr
for each such point: how many failed and the first error; its marker hollow in the figure),
one all of whose trials failed has none (one line naming each such point and why); either
way exit 1, every point's result written all the same (exit 0 when no trial failed). Results
(figures, tables) on stdout.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn, TypeVar

from validator.cli_common import (
    EXIT_INPUT,
    EXIT_STATUS,
    EXIT_VERDICT,
    add_autopilot_arguments,
    add_deprecated,
    add_quiet_argument,
    run_command,
)
from validator.errors import CommandParser, InputError
from validator.output_paths import check_not_inputs, output_path
from validator.plan_format import Autopilot
from validator.site_airspace import site_inputs

if TYPE_CHECKING:
    from mission_planner.optimize.bcd import PlannerOptions
    from mission_planner.study.fig4 import Fig4Result
    from mission_planner.study.wind import WindResult

T = TypeVar("T")
STUDY_EXTRA = ("tqdm", "dask", "distributed")


def _list_of(kind: Callable[[str], T]) -> Callable[[str], tuple[T, ...]]:
    def parse(text: str) -> tuple[T, ...]:
        parts = text.split(",")
        if not text.strip():
            raise argparse.ArgumentTypeError("give at least one value")
        try:  # an empty item ("10,,20") is a typo, not a value to skip
            values = tuple(kind(v) for v in parts)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected comma-separated numbers, got {text!r}") from None
        if not all(math.isfinite(float(v)) for v in values):  # type: ignore[arg-type]
            raise argparse.ArgumentTypeError(f"expected finite numbers, got {text!r}")
        return values

    parse.__name__ = "list"
    return parse


class _Parser(CommandParser):
    def error(self, message: str) -> NoReturn:
        raise InputError(message)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="nfz-study",
                     description="The paper's Fig. 3 and Fig. 4 (one site; Monte-Carlo sweeps of "
                                 "NFZ radius and count),\nand a sweep of winds.",
                     epilog=EXIT_STATUS, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    raw = argparse.RawDescriptionHelpFormatter

    p3 = sub.add_parser("fig3", help="both schemes on one site: map, δ[n], p[n] (PNG + CSV)",
                        epilog=EXIT_STATUS, formatter_class=raw)
    p3.add_argument("site", help="site YAML file")
    _add_output(p3, "output directory")
    p3.add_argument("--buffer-m", type=float, default=None,
                    help="replace the site's safety buffer, m (0 reproduces the paper)")
    p3.add_argument("--max-iterations", type=int, default=None,
                    help="cap on Algorithm 1's iterations (planner default)")

    p4 = sub.add_parser("fig4", help="Monte-Carlo sweeps of NFZ radius and count (Fig. 4)",
                        epilog=EXIT_STATUS, formatter_class=raw)
    _add_output(p4, "output directory (re-run to resume)")
    p4.add_argument("--trials", type=int, default=100, help="random sites per point (100)")
    p4.add_argument("--radii", type=_list_of(float), default=(10, 20, 30, 40, 50),
                    help="NFZ radii of the radius sweep, m (10,20,30,40,50)")
    p4.add_argument("--counts", type=_list_of(int), default=(1, 2, 3, 4, 5),
                    help="NFZ counts of the count sweep (1,2,3,4,5)")
    p4.add_argument("--radius", type=float, default=30.0,
                    help="NFZ radius in the count sweep, m (30)")
    p4.add_argument("--count", type=int, default=3, help="NFZ count in the radius sweep (3)")
    p4.add_argument("--seed", type=int, default=0, help="study seed (0)")
    p4.add_argument("--slots", type=int, default=50, help="time slots N (50)")
    p4.add_argument("--gns", type=int, default=4, help="ground nodes K (4)")
    p4.add_argument("--buffer-m", type=float, default=0.0,
                    help="safety buffer added to every NFZ when planning, m (0, as the paper); "
                         "outage is always judged against the published radius")
    p4.add_argument("--max-iterations", type=int, default=None,
                    help="cap on Algorithm 1's iterations (planner default)")
    _add_trial_options(p4)

    pw = sub.add_parser("wind", help="one site planned for and flown in a sweep of winds",
                        epilog=EXIT_STATUS, formatter_class=raw)
    pw.add_argument("site", help="site YAML file")
    _add_output(pw, "output directory (re-run to resume)")
    pw.add_argument("--speeds", type=_list_of(float), default=(0.0, 2.0, 4.0, 6.0, 8.0),
                    help="wind speeds, m/s (0,2,4,6,8)")
    pw.add_argument("--directions", type=_list_of(float), default=(0.0, 90.0, 180.0, 270.0),
                    help="directions the wind blows from, degrees true (0,90,180,270)")
    pw.add_argument("--turbulence", type=float, default=0.0,
                    help="turbulence of every windy trial, m/s (0)")
    add_autopilot_arguments(pw, default=Autopilot.ARDUPILOTMEGA,
                            help="the plans' autopilot and flight model (ardupilot)")
    _add_trial_options(pw)
    add_quiet_argument(p3, "accepted for every command alike (fig3 shows no progress)")
    return parser


def _add_output(p: argparse.ArgumentParser, help: str) -> None:
    # required, but checked after parsing (_main): argparse would not count the old --out
    p.add_argument("-o", "--output", type=output_path, metavar="DIR", help=help + " (required)")
    add_deprecated(p, "--out", "--output", dest="output", type=output_path, metavar="DIR")


def _add_trial_options(p: argparse.ArgumentParser) -> None:
    """How a study's trials run and are kept: workers or a Dask scheduler, the table format,
    retrying errors, the progress bar (the same for every study)."""
    p.add_argument("--workers", type=int, default=None,
                   help="local worker processes (all CPUs); 1 runs in this process")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="run the trials on this Dask scheduler instead")
    p.add_argument("--format", dest="table_format", default="csv",
                   help="trial table format: csv or parquet (needs pyarrow)")
    p.add_argument("--retry-errors", action="store_true",
                   help="re-run logged trials that ended in an error")
    add_quiet_argument(p, "no progress bar (trials done, rate, time left; shown only on a "
                          "terminal)")


def _options(args: argparse.Namespace) -> PlannerOptions:
    """PlannerOptions from the command line: the paper's model (the figures reproduce it), the
    planner's defaults where not given."""
    from dataclasses import replace

    from mission_planner.optimize import PAPER_OPTIONS

    if args.max_iterations is None:
        return PAPER_OPTIONS
    if args.max_iterations < 1:
        raise InputError(f"--max-iterations: must be >= 1, got {args.max_iterations}")
    return replace(PAPER_OPTIONS, max_iterations=args.max_iterations)


def _fig3(args: argparse.Namespace) -> int:
    from mission_planner.study.fig3 import FILES, run_fig3
    from validator.site import load_site

    options = _options(args)
    check_not_inputs([args.output / name for name in FILES], site_inputs(args.site))
    site = load_site(args.site)
    result = run_fig3(site, args.output, options=options, buffer_m=args.buffer_m)
    for sol in result.solutions:
        print(f"{sol.scheme}: min rate {sol.min_rate_bps_hz:.4f} bps/Hz, "
              f"min leg clearance {sol.nfz_clearance_min_m:.2f} m")
    for path in result.files:
        print(path)
    return 0


def _fig4(args: argparse.Namespace) -> int:
    from mission_planner.study.config import Fig4Config
    from mission_planner.study.fig4 import run_fig4

    config = Fig4Config(
        trials=args.trials, radii_m=tuple(float(r) for r in args.radii),
        counts=tuple(args.counts), seed=args.seed, slots=args.slots, num_gns=args.gns,
        radius_m=args.radius, num_nfzs=args.count, buffer_m=args.buffer_m,
    )
    result = run_fig4(
        args.output, config, options=_options(args), workers=args.workers, scheduler=args.scheduler,
        progress=False if args.quiet else None, table_format=args.table_format,
        retry_errors=args.retry_errors,
    )
    return _said(result, args.output)


def _wind(args: argparse.Namespace) -> int:
    from mission_planner.study.wind import run_wind_study, wind_files
    from validator.site import load_site

    check_not_inputs([args.output / name for name in wind_files(args.table_format)],
                     site_inputs(args.site))
    result = run_wind_study(
        load_site(args.site), args.output, speeds_mps=args.speeds, directions_deg=args.directions,
        turbulence_mps=args.turbulence, autopilot=args.autopilot.key, workers=args.workers,
        scheduler=args.scheduler, progress=False if args.quiet else None,
        table_format=args.table_format, retry_errors=args.retry_errors,
    )
    return _said(result, args.output)


def _said(result: Fig4Result | WindResult, out: Path) -> int:
    """Print what a study run did and wrote; exit 1 when a trial failed.

    A point whose every trial failed is a hole in the figure and the table; a point that lost
    some of its trials keeps a result averaged over the sites left, which may lean to the
    easier ones. Either way the figure is not the one asked for, so the study is not a success
    even though every result (valid data) is written: one line on stderr per point that lost
    trials, one naming the holes. No trial of the default studies fails (README, Studies)."""
    run = result.run
    print(f"{len(run.rows)} trials ({run.executed} run now, {run.skipped} from {out})")
    for path in result.files:
        print(path)
    for point in result.partial:
        print(f"nfz-study: {point.warning()}", file=sys.stderr)
    if result.missing:
        holes = "; ".join(f"{point} ({why})" for point, why in result.missing)
        print(f"nfz-study: no result at {len(result.missing)} of {result.points} sweep points "
              f"(every trial failed): {holes}", file=sys.stderr)
    return EXIT_VERDICT if result.missing or result.partial else 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``nfz-study``; returns the exit status."""
    return run_command("nfz-study", lambda: _main(argv),
                       interrupted="interrupted; finished trials are kept, run again to resume")


def _main(argv: Sequence[str] | None) -> int:
    from mission_planner.study.executors import ExecutorError

    try:
        args = build_parser().parse_args(argv)
        if args.output is None:
            raise InputError("the following arguments are required: -o/--output")
        return {"fig3": _fig3, "fig4": _fig4, "wind": _wind}[args.command](args)
    except ModuleNotFoundError as err:
        if err.name not in STUDY_EXTRA:
            raise
        print(f"nfz-study: needs the study extra (missing {err.name}): "
              "pip install 'nfz-mission[study]'", file=sys.stderr)
        return EXIT_INPUT
    except ExecutorError as err:
        print(f"nfz-study: {err}; finished trials are kept, run again to resume", file=sys.stderr)
        return EXIT_INPUT


if __name__ == "__main__":
    sys.exit(main())
