"""``plan-mission``: optimise a site's service cycle and export it as an autopilot mission.

    plan-mission SITE.yaml -o mission.plan [--scheme proposed|conventional|tangent]
        [--report R.json] [--dynamics vehicle|none] [--buffer-m B] [--autopilot ardupilot|px4]
        [--cycles C] [--wind SPEED@FROM[,TURB]]
        [--fence-margin-m M] [--operating-area polygon|circle] [--operating-area-margin-m A]
        [--format plan|waypoints] [--params F.param] [--no-merge] [--stop-at-every-waypoint]
        [--second-start] [--geojson F.geojson] [--plot F.png] [--html F.html [--html-map]]
        [--force] [--quiet] [--at ISO-8601] [--authorised ZONE ...]

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

A site whose ``airspace:`` holds UAS zones (ED-269, ED-318) is planned among the zones that
apply at ``--at`` for the mission's duration (:mod:`mission_planner.airspace_time`), less
those ``--authorised``; the report's ``"airspace"`` section lists every zone within reach,
taken or why not, and stderr a line per zone.

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
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from mission_planner.airspace_time import plan_for_time
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
from mission_planner.progress import PlanProgress
from mission_planner.waypoint_radius import radius_params
from validator.errors import CommandParser, InputError, UserError, report_error
from validator.fileio import write_all_atomic
from validator.geojson_format import dumps_geojson, plan_geojson
from validator.plan_format import dumps_plan
from validator.site import Site
from validator.uas_zones.applicability import AirspaceOptions, parse_at
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
    if mission.solution.site.airspace.uas:
        out["airspace"] = mission.solution.site.airspace.report()
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
    html: str | Path | None = None,
    html_map: bool = False,
) -> dict[Path, str | bytes]:
    """Every file the mission is exported to (path -> content), not yet written.

    ``fmt`` "plan" writes a QGroundControl plan to ``out``; "waypoints" a QGC WPL 110 mission
    with its fence and rally files beside it (``NAME.fence.waypoints``, ``NAME.rally.waypoints``).
    ``params`` names the autopilot parameter file (``autopilot_params``, default
    :func:`~mission_planner.autopilot_params.recommended_params`); ``flight`` adds the replay
    to the report and its track to the ``html`` view (:mod:`validator.view`; ``html_map``: on
    OpenStreetMap tiles).
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
    if html is not None:
        files[Path(html)] = mission_view(mission, flight, Path(out).name, html_map)
    return files


def mission_view(mission: Mission, flight: FlightCheck | None = None, name: str = "",
                 map_background: bool = False) -> str:
    """The mission's interactive view (:func:`validator.view.view_html`) with the replay of
    ``flight`` on its time slider."""
    from validator.flight import resolve_flight
    from validator.view import TrackLayer, ViewInputs, view_html

    site = mission.solution.site
    resolved = (flight.flight if flight is not None and flight.flight is not None
                else resolve_flight(mission.plan, site, "mission"))
    tracks = ((TrackLayer(f"replay ({flight.profile.name})", flight.track),)
              if flight is not None and flight.track is not None else ())
    title = f"{site.name}: {name or 'mission'} ({mission.solution.scheme})"
    return view_html(ViewInputs(mission.plan, site, resolved, tracks, title=title),
                     map_background=map_background)


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
    p.add_argument("--at", metavar="ISO-8601",
                   help="when the mission starts, with its time zone (2026-12-02T10:00+01:00): "
                   "UAS zones of the airspace apply when active then or during the flight "
                   "(default: every zone taken as active)")
    p.add_argument("--authorised", action="append", default=[], metavar="ZONE",
                   help="identifier of a REQ_AUTHORISATION or CONDITIONAL zone the operator "
                   "holds the authorisation for, or meets the conditions of (repeatable)")
    p.add_argument("--html", type=Path,
                   help="also write an interactive view: one self-contained HTML page with "
                   "zones, fence, legs, waypoints and the replayed flight on a time slider")
    p.add_argument("--html-map", action="store_true",
                   help="with --html, draw the view on OpenStreetMap tiles (fetched by the "
                   "browser when the page opens, so online only; default: local metres)")
    p.add_argument("--force", action="store_true",
                   help="write the mission even if the safety gate refuses it")
    p.add_argument("--quiet", "--no-progress", action="store_true",
                   help="no progress line (warnings and the result still print; there is none "
                   "either when stderr is not a terminal)")
    # Removed: the optimiser is deterministic, so a seed never did anything. Accepted with a
    # deprecation line for one release.
    p.add_argument("--seed", type=int, help=argparse.SUPPRESS)
    return p


def plan_mission_main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``plan-mission`` (see the module doc); returns the exit status."""
    args = _parser().parse_args(argv)
    if args.seed is not None:
        print("plan-mission: --seed is deprecated and has no effect (the optimiser is "
              "deterministic)", file=sys.stderr)
    try:
        fmt = args.format or ("waypoints" if args.output.suffix == ".waypoints" else "plan")
        param_file = args.params or params_path(args.output)
        if args.html_map and not args.html:
            raise InputError("--html-map: only with --html")
        outputs = [args.output, param_file] + [
            p for p in (args.report, args.geojson, args.plot, args.html) if p]
        if fmt == "waypoints":
            from validator.waypoints_format import sidecar_paths

            outputs += list(sidecar_paths(args.output))
        check_output_paths(outputs)
        airspace = AirspaceOptions(parse_at(args.at) if args.at else None,
                                   authorised=frozenset(args.authorised))
        wind = parse_wind_arg(args.wind) if args.wind is not None else None
        options = MissionOptions(
            autopilot=args.autopilot,
            cycles=args.cycles,
            fence_margin_m=args.fence_margin_m,
            operating_area=args.operating_area,
            operating_area_margin_m=args.operating_area_margin_m,
            merge_legs=not args.no_merge,
        )

        def forecast(site: Site) -> Site:
            """The site in the day's forecast, which overrides the site's own wind."""
            return site if wind is None else site.with_limits(wind=None if wind.calm else wind)

        def made(site: Site) -> tuple[Mission, AutopilotParams, FlightCheck]:
            mission = plan_and_build(forecast(site), args.scheme, options, dynamics=args.dynamics,
                                     progress=progress if progress.shown else None,
                                     pass_through_corners=not args.stop_at_every_waypoint,
                                     second_start=args.second_start,
                                     wind_buffer=args.buffer_m is None)
            params = recommended_params(mission)
            return mission, params, replay_mission(mission, params)

        with PlanProgress(enabled=False if args.quiet else None) as progress:
            site, (mission, autopilot_params, flight) = plan_for_time(
                args.site, airspace, args.cycles, made, lambda m: m[2].report.duration_s,
                args.buffer_m)
        site = forecast(site)
        for line in site.airspace.lines():
            print(f"plan-mission: {line}", file=sys.stderr)
        if args.at and not site.airspace.uas:
            print("plan-mission: note: the site names no UAS zones (ED-269, ED-318): --at "
                  "changes nothing", file=sys.stderr)
        if mission.problems:
            for problem in mission.problems:
                print(f"plan-mission: unsafe: {problem}", file=sys.stderr)
            if not args.force:
                print(f"plan-mission: refused to write {args.output} "
                      f"({len(mission.problems)} problems); --force writes it anyway",
                      file=sys.stderr)
                return 1
            print("plan-mission: --force: writing the unsafe mission", file=sys.stderr)
        files = output_files(mission, args.output, fmt=fmt, report=args.report,
                             geojson=args.geojson, plot=args.plot, params=param_file,
                             autopilot_params=autopilot_params, flight=flight,
                             html=args.html, html_map=args.html_map)
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
