"""``plan-mission``: optimise a site's service cycle and export it as an autopilot mission.

    plan-mission SITE.yaml -o mission.plan [--scheme proposed|conventional|tangent]
        [--report R.json] [--dynamics vehicle|none] [--buffer-m B] [--autopilot ardupilot|px4]
        [--cycles C] [--wind SPEED@FROM[,TURB]]
        [--fence-margin-m M] [--operating-area polygon|circle] [--operating-area-margin-m A]
        [--format plan|waypoints] [--params-out F.param] [--no-merge] [--stop-at-every-waypoint]
        [--second-start] [--geojson F.geojson] [--plot F.png] [--html F.html [--html-map]]
        [--force] [--quiet] [--at ISO-8601] [--authorised ZONE ...]

``--dynamics vehicle`` (default) keeps speed changes within the site's ``uav.max_accel`` and
``uav.max_jerk``; ``--dynamics none`` is the paper's kinematic model (top speed only) and
reproduces its results. With ``--dynamics vehicle`` a plan flies through the corners whose
turn keeps the buffer (:mod:`mission_planner.optimize.corners`; a PX4 plan only where that
replays better than stopping); ``--stop-at-every-waypoint`` makes it stop at each.
``--second-start`` runs Algorithm 1 from a second starting schedule and keeps the better plan
(twice the time). Beside the mission goes the parameter file the autopilot needs (``OUT.param``
or ``--params-out FILE``;
:mod:`mission_planner.autopilot_params`). The mission is then replayed with the validator's
model of the autopilot set to those parameters (:mod:`mission_planner.flight_report`): the
report gets a ``"flight"`` section and stderr a one-line warning when the flown cycle is more
than 10 % longer (or shorter) than T, and another when the site's ``uav.max_speed`` is above the
vehicle's real top speed (:func:`~mission_planner.pipeline.speed_warning`). ``--wind`` (or
the site's ``wind:``) plans for a forecast: the top speed holds in the air
(:mod:`validator.wind`), the report and the plan's ``nfzMission`` say which wind it was made
for.

A site whose ``airspace:`` holds UAS zones (ED-269, ED-318) is planned among the zones that
apply at ``--at`` for the mission's duration (:mod:`mission_planner.airspace_time`), less
those ``--authorised``; the report's ``"airspace"`` section lists every zone within reach,
taken or why not, and stderr a line per zone.

The result line goes to stdout; progress, notes and warnings to stderr. Exit status
(:data:`validator.cli_common.EXIT_STATUS`): 0 written; 1 refused by the safety gate (some leg
inside an NFZ plus its buffer, or another problem of
:func:`mission_planner.mission.plan_problems`, or the replay's: a zone or fence entered, a
flight longer than the site's ``uav.endurance``), nothing written unless ``--force``; 2 bad input
(one line on stderr naming the field), nothing written; 130 interrupted, nothing written.
Every output is prepared in memory first and written atomically.

The same steps from Python: the front door, :mod:`mission_planner.api` (``plan_mission``,
``replay``, ``write_mission``), over :mod:`mission_planner.pipeline`.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from mission_planner.airspace_time import plan_for_time, with_airspace
from mission_planner.api import write_mission
from mission_planner.autopilot_params import AutopilotParams, recommended_params
from mission_planner.flight_report import FlightCheck, refusals, replay_mission
from mission_planner.mission import (
    OPERATING_AREAS,
    Mission,
    MissionOptions,
    mission_summary,
)
from mission_planner.pipeline import (
    DYNAMICS,
    FORMATS,
    check_output_paths,
    params_path,
    plan_and_build,
    position_loss_drift_warning,
    speed_warning,
)
from mission_planner.progress import PlanProgress
from validator.cli_common import (
    EXIT_OK,
    EXIT_VERDICT,
    add_autopilot_arguments,
    add_deprecated,
    add_quiet_argument,
    command_parser,
    run_command,
)
from validator.errors import InputError
from validator.output_paths import output_path
from validator.plan_format import Autopilot
from validator.site import Site
from validator.site_airspace import site_inputs
from validator.uas_zones.applicability import AirspaceOptions, parse_at
from validator.wind import parse_wind_arg
from validator.wind_track import extrapolation_warning


def _parser() -> argparse.ArgumentParser:
    p = command_parser(
        "plan-mission",
        "Optimise a site's UAV service cycle (trajectory, slot lengths, power, scheduling) "
        "avoiding no-fly zones, and export it as an autopilot mission.",
    )
    p.add_argument("site", type=Path, help="site file (YAML)")
    p.add_argument("-o", "--output", type=output_path, required=True,
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
                   "through the corners whose turn keeps the buffer (PX4: only where that replays "
                   "better than stopping)")
    p.add_argument("--second-start", action="store_true",
                   help="also run the optimiser from every node sharing every slot and keep "
                   "the better plan: a better optimum on some sites, twice the time")
    p.add_argument("--report", type=output_path,
                   help="write the solution, mission, autopilot-parameter and replayed-flight "
                   "report (JSON)")
    p.add_argument("--buffer-m", type=float,
                   help="safety buffer added to every NFZ radius (m), kept as given; default: "
                   "the site's, widened for the wind and for a GPS loss's coast "
                   "where the plan needs it")
    p.add_argument("--wind", metavar="SPEED@FROM",
                   help="the day's wind forecast at the flight altitude, overriding the "
                   "site's wind: m/s and the direction it blows from in degrees true, "
                   "e.g. 7@300; SPEED@FROM,TURB adds the turbulence (m/s); 0 for still air")
    add_autopilot_arguments(p, default=Autopilot.ARDUPILOTMEGA,
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
    p.add_argument("--params-out", type=output_path, metavar="FILE",
                   help="the parameter file to write for the vehicle to fly with (default: "
                   "the output with suffix .param): WPNAV_SPEED/ACCEL/JERK/RADIUS for "
                   "ArduPilot, MPC_XY_CRUISE, MPC_XY_VEL_MAX, MPC_ACC_HOR, MPC_JERK_AUTO, "
                   "NAV_ACC_RAD for PX4; the other commands read it as --params FILE")
    add_deprecated(p, "--params", "--params-out", dest="params_out", type=output_path,
                   metavar="FILE")
    p.add_argument("--no-merge", action="store_true",
                   help="one waypoint per moving slot (default: straight slots at one speed "
                   "merge into one long leg)")
    p.add_argument("--geojson", type=output_path, help="also write a GeoJSON FeatureCollection")
    p.add_argument("--plot", type=output_path, help="also draw the paper's Fig. 3 (PNG)")
    p.add_argument("--at", metavar="ISO-8601",
                   help="when the mission starts, with its time zone (2026-12-02T10:00+01:00): "
                   "UAS zones of the airspace apply when active then or during the flight "
                   "(default: every zone taken as active)")
    p.add_argument("--authorised", action="append", default=[], metavar="ZONE",
                   help="identifier of a REQ_AUTHORISATION or CONDITIONAL zone the operator "
                   "holds the authorisation for, or meets the conditions of (repeatable)")
    p.add_argument("--html", type=output_path,
                   help="also write an interactive view: one self-contained HTML page with "
                   "zones, fence, legs, waypoints and the replayed flight on a time slider")
    p.add_argument("--html-map", action="store_true",
                   help="with --html, draw the view on OpenStreetMap tiles (fetched by the "
                   "browser when the page opens, so online only; default: local metres)")
    p.add_argument("--force", action="store_true",
                   help="write the mission even if the safety gate refuses it")
    add_quiet_argument(p, "no progress line and no notes on stderr (warnings and the result "
                          "still print; there is no progress either when stderr is not a "
                          "terminal)")
    # Removed: the optimiser is deterministic, so a seed never did anything. Accepted with a
    # deprecation line for one release.
    p.add_argument("--seed", type=int, help=argparse.SUPPRESS)
    return p


def plan_mission_main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``plan-mission`` (see the module doc); returns the exit status."""
    return run_command("plan-mission", lambda: _plan(_parser().parse_args(argv)))


def _plan(args: argparse.Namespace) -> int:
    if args.seed is not None:
        print("warning: --seed is deprecated and has no effect (the optimiser is "
              "deterministic)", file=sys.stderr)
    autopilot: Autopilot = args.autopilot
    fmt = args.format or ("waypoints" if args.output.suffix == ".waypoints" else "plan")
    inputs = site_inputs(args.site)
    if args.params_out is None:  # its name is derived from the output's, which must be a file
        check_output_paths([args.output], inputs)
    param_file = args.params_out or params_path(args.output)
    if args.html_map and not args.html:
        raise InputError("--html-map: only with --html")
    outputs = [args.output, param_file] + [
        p for p in (args.report, args.geojson, args.plot, args.html) if p]
    if fmt == "waypoints":
        from validator.waypoints_format import sidecar_paths

        outputs += list(sidecar_paths(args.output))
    check_output_paths(outputs, inputs)
    airspace = AirspaceOptions(parse_at(args.at) if args.at else None,
                               authorised=frozenset(args.authorised))
    wind = parse_wind_arg(args.wind) if args.wind is not None else None
    options = MissionOptions(
        autopilot=autopilot.key,
        cycles=args.cycles,
        fence_margin_m=args.fence_margin_m,
        operating_area=args.operating_area,
        operating_area_margin_m=args.operating_area_margin_m,
        merge_legs=not args.no_merge,
    )

    def made(site: Site) -> tuple[Mission, AutopilotParams, FlightCheck]:
        mission = plan_and_build(site.with_forecast(wind), args.scheme, options,
                                 dynamics=args.dynamics,
                                 progress=progress if progress.shown else None,
                                 pass_through_corners=not args.stop_at_every_waypoint,
                                 second_start=args.second_start,
                                 wind_buffer=args.buffer_m is None,
                                 position_loss_berth=args.buffer_m is None)
        params = recommended_params(mission)
        return mission, params, replay_mission(mission, params)

    with PlanProgress(enabled=False if args.quiet else None) as progress:
        site, (mission, autopilot_params, flight) = plan_for_time(
            args.site, airspace, args.cycles, made, lambda m: m[2].report.duration_s,
            args.buffer_m)
    site = site.with_forecast(wind)
    mission = with_airspace(mission, site.airspace)
    for line in site.airspace.lines():
        print(f"plan-mission: {line}", file=sys.stderr)
    if args.at and not site.airspace.uas and not args.quiet:
        print("plan-mission: note: the site names no UAS zones (ED-269, ED-318): --at "
              "changes nothing", file=sys.stderr)
    problems = refusals(mission, flight)
    if problems:
        for problem in problems:
            print(f"plan-mission: unsafe: {problem}", file=sys.stderr)
        if not args.force:
            print(f"plan-mission: refused to write {args.output} "
                  f"({len(problems)} problems); --force writes it anyway",
                  file=sys.stderr)
            return EXIT_VERDICT
        print("plan-mission: --force: writing the unsafe mission", file=sys.stderr)
    written = write_mission(mission, args.output, fmt=fmt, report=args.report,
                            geojson=args.geojson, plot=args.plot, params=param_file,
                            autopilot_params=autopilot_params, flight=flight,
                            html=args.html, html_map=args.html_map, force=True)
    for note in () if args.quiet else autopilot_params.notes:
        print(f"plan-mission: note: {note}", file=sys.stderr)
    berth = mission.position_loss_berth
    if berth is not None and (berth.left or not args.quiet):
        print(f"plan-mission: {'warning' if berth.left else 'note'}: {berth.message}",
              file=sys.stderr)
    drifting = position_loss_drift_warning(mission)
    if drifting:
        print(f"plan-mission: warning: {drifting}", file=sys.stderr)
    guessed = extrapolation_warning(mission.solution.site.flight_wind,
                                    px4=mission.options.autopilot == "px4")
    if guessed:
        print(f"plan-mission: warning: {guessed}", file=sys.stderr)
    too_fast = speed_warning(site, args.dynamics, autopilot.key)
    if too_fast:
        print(f"plan-mission: warning: {too_fast}", file=sys.stderr)
    warning = flight.warning()
    if warning:
        print(f"plan-mission: warning: {warning}", file=sys.stderr)
    summary = mission_summary(mission)
    clearance = summary["nfz_clearance_min_m"]
    print(
        f"plan-mission: wrote {', '.join(str(p) for p in written.files)}: {summary['items']} items "
        f"({summary['service_waypoints_merged']} waypoints merged into longer legs), "
        f"cycle {summary['cycle_duration_s']:.1f} s (T = {summary['period_s']:g} s), "
        f"min rate {mission.solution.min_rate_bps_hz:.4f} bps/Hz, min NFZ clearance "
        + ("none (no NFZ)" if clearance is None else f"{clearance:.3f} m")
        + f"; {flight.profile.name} replay: " + _replay_summary(flight, site.endurance_s)
        + (f"; planned for wind {site.wind.label()}" if site.wind is not None else ""),
    )
    return EXIT_OK


def _replay_summary(flight: FlightCheck, endurance_s: float | None) -> str:
    cycle, rate = flight.replayed_cycle_s, flight.replayed_min_rate_bps_hz
    clearance = min(flight.clearance_by_nfz_m.values(), default=None)
    return ", ".join([
        "cycle " + ("not completed" if cycle is None else f"{cycle:.1f} s"),
        f"take-off to landing {flight.report.duration_s:.0f} s"
        + ("" if endurance_s is None else f" of the {endurance_s:g} s endurance"),
        "min rate " + ("not scored" if rate is None else f"{rate:.4f} bps/Hz"),
        "min NFZ clearance " + ("none (no NFZ)" if clearance is None else f"{clearance:.2f} m"),
    ])


def main() -> None:
    sys.exit(plan_mission_main())


if __name__ == "__main__":
    main()
