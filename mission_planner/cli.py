"""``plan-mission``: optimise a site's service cycle and export it as an autopilot mission.

    plan-mission SITE.yaml -o mission.plan [--scheme proposed|conventional|tangent]
        [--report R.json] [--dynamics vehicle|none] [--buffer-m B] [--autopilot ardupilot|px4]
        [--cycles C] [--wind SPEED@FROM[,TURB]]
        [--fence-margin-m M] [--operating-area polygon|circle] [--operating-area-margin-m A]
        [--format plan|waypoints] [--params F.param] [--no-merge] [--stop-at-every-waypoint]
        [--second-start] [--geojson F.geojson] [--plot F.png] [--force] [--quiet]

``--dynamics vehicle`` (default) keeps speed changes within the site's ``uav.max_accel`` and
``uav.max_jerk``; ``--dynamics none`` is the paper's kinematic model (top speed only) and
reproduces its results. With ``--dynamics vehicle`` an ArduCopter plan flies through the corners
whose blended turn keeps the buffer (:mod:`mission_planner.optimize.corners`);
``--stop-at-every-waypoint`` makes it stop at each. ``--second-start`` runs Algorithm 1 from a
second starting schedule and keeps the better plan (twice the time). Beside the mission goes the
parameter file the autopilot needs (``OUT.param`` or ``--params``;
:mod:`mission_planner.autopilot_params`). The mission is then replayed with the validator's
model of the autopilot set to those parameters (:mod:`mission_planner.flight_report`): the
report gets a ``"flight"`` section and stderr a one-line warning when the flown cycle is more
than 10 % longer (or shorter) than T, and another when the site's ``uav.max_speed`` is above the
vehicle's real top speed (:func:`speed_warning`). ``--wind`` (or the site's ``wind:``) plans
for a forecast: the top speed holds in the air (:mod:`validator.wind`), the report and the
plan's ``nfzMission`` say which wind it was made for.

Exit status: 0 written; 1 refused by the safety gate (some leg inside an NFZ plus its buffer,
or another problem of :func:`mission_planner.mission.plan_problems`), nothing written unless
``--force``; 2 bad input (one line on stderr naming the field), nothing written.
Every output is prepared in memory first and written atomically.

The same steps from Python: :func:`plan_and_build`, :func:`~mission_planner.flight_report.
replay_mission`, then :func:`output_files` and :func:`write_outputs`.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from mission_planner.autopilot_params import (
    AutopilotParams,
    dumps_params,
    recommended_params,
)
from mission_planner.flight_report import FlightCheck, replay_mission
from mission_planner.mission import (
    AUTOPILOTS,
    OPERATING_AREAS,
    Mission,
    MissionOptions,
    build_mission,
    check_options,
    mission_summary,
)
from mission_planner.optimize.retime import top_speed_mps
from mission_planner.waypoint_radius import radius_params
from validator.errors import CommandParser, InputError, UserError, report_error
from validator.fileio import write_all_atomic
from validator.geojson_format import dumps_geojson, plan_geojson
from validator.plan_format import dumps_plan
from validator.site import Site, load_site
from validator.waypoints_format import waypoint_files
from validator.wind import parse_wind_arg
from validator.wind_track import wind_buffer_m

FORMATS = ("plan", "waypoints")
DYNAMICS = ("vehicle", "none")  # PlannerOptions.dynamics; kept here so --help needs no cvxpy
Progress = Callable[[int, float], None]


def mission_report(mission: Mission, flight: FlightCheck | None = None,
                   params: AutopilotParams | None = None) -> dict[str, Any]:
    """The report JSON: the solution's report plus the mission summary under ``"mission"``,
    the recommended autopilot parameters under ``"autopilot_params"`` and the replay under
    ``"flight"`` when given."""
    out = {**mission.solution.report(), "mission": mission_summary(mission)}
    if params is not None:
        out["autopilot_params"] = params.as_dict()
    if flight is not None:
        out["flight"] = flight.as_dict()
    return out


def params_path(out: str | Path) -> Path:
    """Default parameter file beside the mission: OUT with suffix ``.param``."""
    return Path(out).with_suffix(".param")


def output_files(
    mission: Mission,
    out: str | Path,
    *,
    fmt: str = "plan",
    report: str | Path | None = None,
    geojson: str | Path | None = None,
    plot: str | Path | None = None,
    params: str | Path | None = None,
    autopilot_params: AutopilotParams | None = None,
    flight: FlightCheck | None = None,
) -> dict[Path, str | bytes]:
    """Every file the mission is exported to (path -> content), not yet written.

    ``fmt`` "plan" writes a QGroundControl plan to ``out``; "waypoints" a QGC WPL 110 mission
    with its fence and rally files beside it (``NAME.fence.waypoints``, ``NAME.rally.waypoints``).
    ``params`` names the autopilot parameter file (``autopilot_params``, default
    :func:`~mission_planner.autopilot_params.recommended_params`); ``flight`` adds the replay
    to the report.
    """
    if fmt not in FORMATS:
        raise InputError(f"format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
    files: dict[Path, str | bytes] = {}
    if fmt == "plan":
        files[Path(out)] = dumps_plan(mission.plan)
    else:
        files.update(waypoint_files(mission.plan, out))
    if params is not None:
        autopilot_params = autopilot_params or recommended_params(mission)
        site = mission.solution.site
        title = (f"{autopilot_params.autopilot} parameters for {Path(out).name} (site "
                 f"{site.name}), written by plan-mission")
        files[Path(params)] = dumps_params(autopilot_params, title)
    if report is not None:
        files[Path(report)] = json.dumps(mission_report(mission, flight, autopilot_params),
                                         indent=1) + "\n"
    if geojson is not None:
        files[Path(geojson)] = dumps_geojson(plan_geojson(mission.plan, mission.solution.site))
    if plot is not None:
        from mission_planner.figure import figure_png, solution_figure

        files[Path(plot)] = figure_png(solution_figure(mission.solution, mission))
    return files


def check_output_paths(paths: Sequence[Path]) -> None:
    """Refuse outputs that collide or whose folder does not exist, before any work is done."""
    seen: set[Path] = set()
    for p in paths:
        resolved = p.resolve()
        if resolved in seen:
            raise InputError(f"{p}: named for two outputs")
        seen.add(resolved)
        if not p.parent.resolve().is_dir():
            raise InputError(f"{p}: folder {p.parent} does not exist")
        if p.is_dir():
            raise InputError(f"{p}: is a folder")


def write_outputs(files: dict[Path, str | bytes]) -> None:
    """Write the files atomically, all or none (:func:`validator.fileio.write_all_atomic`)."""
    write_all_atomic(files)


def plan_and_build(
    site: Site,
    scheme: str = "proposed",
    options: MissionOptions | None = None,
    *,
    dynamics: str = "vehicle",
    progress: Progress | None = None,
    pass_through_corners: bool = True,
    second_start: bool = False,
    wind_buffer: bool = True,
) -> Mission:
    """Optimise ``site`` with the paper's Algorithm 1 and lay out its mission.

    ``dynamics`` "vehicle" keeps speed changes within the site's acceleration and jerk
    limits; "none" is the paper's kinematic model. ``pass_through_corners`` False stops the
    vehicle at every waypoint; ``second_start`` also runs Algorithm 1 from 1/K schedule
    shares and keeps the better (:class:`~mission_planner.optimize.PlannerOptions`). In wind
    (``site.wind``) with ``wind_buffer`` the safety buffer grows by how much closer the flown
    track comes in that wind (:func:`validator.wind_track.wind_buffer_m`), so the flown track
    keeps the site's buffer; plan-mission does so unless ``--buffer-m`` is given. Options
    are checked before the (slow) optimisation. The safety verdict is in ``Mission.problems``;
    nothing is written here.
    """
    if wind_buffer and site.flight_wind is not None:
        site = site.with_buffer(wind_buffer_m(site.buffer_m, site.flight_wind))
    opt = options or MissionOptions()
    check_options(site, opt)
    if dynamics not in DYNAMICS:
        raise InputError(f"dynamics: expected one of {', '.join(DYNAMICS)}, got {dynamics!r}")
    from mission_planner.optimize import PlannerOptions, plan  # the solver, only to plan
    from mission_planner.optimize.bcd import START_SCHEDULES

    # Corners (ArduCopter's blends, PX4's acceptance) are timed with the waypoint radius the
    # parameter file will set
    timing = radius_params(site, opt.autopilot, opt.fence_margin_m)
    starts = START_SCHEDULES if second_start else START_SCHEDULES[:1]
    planner_options = PlannerOptions(dynamics=dynamics, autopilot=opt.autopilot,
                                     timing_params=timing,
                                     pass_through_corners=pass_through_corners,
                                     start_schedules=starts)
    solution = plan(site, scheme, options=planner_options, progress=progress)
    return build_mission(solution, opt)


def speed_warning(site: Site, dynamics: str, autopilot: str = "ardupilot") -> str | None:
    """One line when the site's V is above the vehicle's real top speed
    (:func:`~mission_planner.optimize.retime.top_speed_mps`), else None."""
    top = top_speed_mps(site, autopilot)
    if site.max_speed_mps <= top:
        return None
    then = (f"planning at {top:.2f} m/s" if dynamics == "vehicle" else
            f"--dynamics none plans at {site.max_speed_mps:g} m/s as the paper does, so the "
            f"vehicle flies slower than planned")
    return (f"{site.name}: uav.max_speed {site.max_speed_mps:g} m/s is above the vehicle's "
            f"real top speed {top:.2f} m/s (lean limit with drag, at {site.altitude_m:g} m "
            f"above the ground); {then}")


def _parser() -> argparse.ArgumentParser:
    p = CommandParser(
        prog="plan-mission",
        description="Optimise a site's UAV service cycle (trajectory, slot lengths, power, "
        "scheduling) avoiding no-fly zones, and export it as an autopilot mission.",
    )
    p.add_argument("site", type=Path, help="site file (YAML)")
    p.add_argument("-o", "--output", type=Path, required=True,
                   help="mission file to write (.plan, or .waypoints with --format waypoints)")
    p.add_argument("--scheme", choices=("proposed", "conventional", "tangent"),
                   default="proposed",
                   help="NFZ rule: proposed = whole leg outside (Theorem 1), conventional = "
                   "waypoints only, tangent = whole leg beyond a tangent line of each circle "
                   "(research option); polygon zones: whole leg under proposed and tangent "
                   "(default: proposed)")
    p.add_argument("--dynamics", choices=DYNAMICS, default="vehicle",
                   help="vehicle = speed changes within the site's uav.max_accel and "
                   "uav.max_jerk (default); none = the paper's kinematic model (top speed "
                   "only), which reproduces the paper's results")
    p.add_argument("--stop-at-every-waypoint", action="store_true",
                   help="with --dynamics vehicle, stop at every waypoint instead of flying "
                   "through the corners whose blended turn keeps the buffer (ArduPilot)")
    p.add_argument("--second-start", action="store_true",
                   help="also run the optimiser from every node sharing every slot and keep "
                   "the better plan: a better optimum on some sites, twice the time")
    p.add_argument("--report", type=Path,
                   help="write the solution, mission, autopilot-parameter and replayed-flight "
                   "report (JSON)")
    p.add_argument("--buffer-m", type=float,
                   help="safety buffer added to every NFZ radius (m; default: the site's)")
    p.add_argument("--wind", metavar="SPEED@FROM",
                   help="the day's wind forecast at the flight altitude, overriding the "
                   "site's wind: m/s and the direction it blows from in degrees true, "
                   "e.g. 7@300; SPEED@FROM,TURB adds the turbulence (m/s); 0 for still air")
    p.add_argument("--autopilot", choices=tuple(AUTOPILOTS), default="ardupilot",
                   help="firmware the plan is for (default: ardupilot)")
    p.add_argument("--cycles", type=int, default=1,
                   help="service cycles to fly before returning (DO_JUMP; default 1)")
    p.add_argument("--fence-margin-m", type=float,
                   help="exclusion fence radius = NFZ radius + this (m; default: buffer / 2; "
                   "at most the buffer)")
    p.add_argument("--operating-area", choices=OPERATING_AREAS,
                   help="add an inclusion fence around everything flown")
    p.add_argument("--operating-area-margin-m", type=float, default=20.0,
                   help="distance of the inclusion fence outside the flown area (m; default 20)")
    p.add_argument("--format", choices=FORMATS,
                   help="plan (QGroundControl) or waypoints (QGC WPL 110 with .fence/.rally "
                   "files beside it); default: from the output's suffix, else plan")
    p.add_argument("--params", type=Path,
                   help="autopilot parameter file to write (default: the output with suffix "
                   ".param): WPNAV_SPEED/ACCEL/JERK/RADIUS for ArduPilot, MPC_XY_CRUISE, "
                   "MPC_XY_VEL_MAX, MPC_ACC_HOR, MPC_JERK_AUTO, NAV_ACC_RAD for PX4")
    p.add_argument("--no-merge", action="store_true",
                   help="one waypoint per moving slot (default: straight slots at one speed "
                   "merge into one long leg)")
    p.add_argument("--geojson", type=Path, help="also write a GeoJSON FeatureCollection")
    p.add_argument("--plot", type=Path, help="also draw the paper's Fig. 3 (PNG)")
    p.add_argument("--force", action="store_true",
                   help="write the mission even if the safety gate refuses it")
    p.add_argument("--quiet", action="store_true",
                   help="no progress lines (warnings and the result still print)")
    # Removed: the optimiser is deterministic, so a seed never did anything. Accepted with a
    # deprecation line for one release.
    p.add_argument("--seed", type=int, help=argparse.SUPPRESS)
    return p


PIPE_PROGRESS_EVERY = 10  # iterations between progress lines when stderr is not a terminal


class _ProgressLine:
    """Progress of the optimiser on stderr: one line rewritten in place on a terminal, a line
    every :data:`PIPE_PROGRESS_EVERY` iterations (and the first) in a pipe or log."""

    def __init__(self) -> None:
        self.started = time.monotonic()
        self.tty = sys.stderr.isatty()
        self.count = 0

    def __call__(self, iteration: int, objective: float) -> None:
        self.count += 1
        text = (f"plan-mission: iteration {iteration}: objective {objective:.6g} "
                f"({time.monotonic() - self.started:.1f} s)")
        if self.tty:
            print(f"\r{text}", end="", file=sys.stderr, flush=True)
        elif self.count == 1 or self.count % PIPE_PROGRESS_EVERY == 0:
            print(text, file=sys.stderr, flush=True)


def plan_mission_main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``plan-mission`` (see the module doc); returns the exit status."""
    args = _parser().parse_args(argv)
    if args.seed is not None:
        print("plan-mission: --seed is deprecated and has no effect (the optimiser is "
              "deterministic)", file=sys.stderr)
    try:
        fmt = args.format or ("waypoints" if args.output.suffix == ".waypoints" else "plan")
        param_file = args.params or params_path(args.output)
        outputs = [args.output, param_file] + [p for p in (args.report, args.geojson, args.plot)
                                               if p]
        if fmt == "waypoints":
            from validator.waypoints_format import sidecar_paths

            outputs += list(sidecar_paths(args.output))
        check_output_paths(outputs)
        site = load_site(args.site)
        if args.buffer_m is not None:
            site = site.with_buffer(args.buffer_m)
        if args.wind is not None:
            wind = parse_wind_arg(args.wind)
            site = site.with_limits(wind=None if wind.calm else wind)
        options = MissionOptions(
            autopilot=args.autopilot,
            cycles=args.cycles,
            fence_margin_m=args.fence_margin_m,
            operating_area=args.operating_area,
            operating_area_margin_m=args.operating_area_margin_m,
            merge_legs=not args.no_merge,
        )
        progress = None if args.quiet else _ProgressLine()
        try:
            mission = plan_and_build(site, args.scheme, options, dynamics=args.dynamics,
                                     progress=progress,
                                     pass_through_corners=not args.stop_at_every_waypoint,
                                     second_start=args.second_start,
                                     wind_buffer=args.buffer_m is None)
        finally:
            if progress is not None and progress.tty:
                print(file=sys.stderr)
        if mission.problems:
            for problem in mission.problems:
                print(f"plan-mission: unsafe: {problem}", file=sys.stderr)
            if not args.force:
                print(f"plan-mission: refused to write {args.output} "
                      f"({len(mission.problems)} problems); --force writes it anyway",
                      file=sys.stderr)
                return 1
            print("plan-mission: --force: writing the unsafe mission", file=sys.stderr)
        autopilot_params = recommended_params(mission)
        flight = replay_mission(mission, autopilot_params)
        files = output_files(mission, args.output, fmt=fmt, report=args.report,
                             geojson=args.geojson, plot=args.plot, params=param_file,
                             autopilot_params=autopilot_params, flight=flight)
        write_outputs(files)
    except UserError as err:
        return report_error("plan-mission", err)
    except KeyboardInterrupt:
        print("plan-mission: interrupted; nothing written", file=sys.stderr)
        return 130
    for note in autopilot_params.notes:
        print(f"plan-mission: note: {note}", file=sys.stderr)
    too_fast = speed_warning(site, args.dynamics, args.autopilot)
    if too_fast:
        print(f"plan-mission: warning: {too_fast}", file=sys.stderr)
    warning = flight.warning()
    if warning:
        print(f"plan-mission: warning: {warning}", file=sys.stderr)
    summary = mission_summary(mission)
    clearance = summary["nfz_clearance_min_m"]
    print(
        f"plan-mission: wrote {', '.join(str(p) for p in files)}: {summary['items']} items "
        f"({summary['service_waypoints_merged']} waypoints merged into longer legs), "
        f"cycle {summary['cycle_duration_s']:.1f} s (T = {summary['period_s']:g} s), "
        f"min rate {mission.solution.min_rate_bps_hz:.4f} bps/Hz, min NFZ clearance "
        + ("none (no NFZ)" if clearance is None else f"{clearance:.3f} m")
        + f"; {flight.profile.name} replay: " + _replay_summary(flight)
        + (f"; planned for wind {site.wind.label()}" if site.wind is not None else ""),
        file=sys.stderr,
    )
    return 0


def _replay_summary(flight: FlightCheck) -> str:
    cycle, rate = flight.replayed_cycle_s, flight.replayed_min_rate_bps_hz
    clearance = min(flight.clearance_by_nfz_m.values(), default=None)
    return ", ".join([
        "cycle " + ("not completed" if cycle is None else f"{cycle:.1f} s"),
        "min rate " + ("not scored" if rate is None else f"{rate:.4f} bps/Hz"),
        "min NFZ clearance " + ("none (no NFZ)" if clearance is None else f"{clearance:.2f} m"),
    ])


def main() -> None:
    sys.exit(plan_mission_main())


if __name__ == "__main__":
    main()
