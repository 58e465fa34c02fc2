"""The steps of ``plan-mission`` as functions: plan and lay out a mission, then every file it
is exported to, prepared in memory and written all or none.

:func:`plan_and_build` optimises a site (the paper's Algorithm 1) and lays out its mission;
:func:`output_files` renders the mission, its parameter file, report, GeoJSON, figure and view
as ``path -> content``; :func:`write_outputs` writes them atomically. The command
(:mod:`mission_planner.cli`) parses arguments and prints around these; notebooks use the front
door, :mod:`mission_planner.api`.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable, Sequence
from pathlib import Path

from mission_planner.autopilot_params import (
    AutopilotParams,
    dumps_params,
    recommended_params,
)
from mission_planner.flight_report import FlightCheck, replay_mission
from mission_planner.mission import (
    Mission,
    MissionOptions,
    build_mission,
    check_options,
    cycle_duration_s,
    mission_summary,
)
from mission_planner.optimize.solution import Solution
from validator.autopilot.waypoint_radius import radius_params
from validator.coast_rules import coast_rule
from validator.errors import InputError
from validator.fileio import write_all_atomic
from validator.geojson_format import dumps_geojson, plan_geojson
from validator.motion.speed_model import top_speed_mps
from validator.output_paths import check_output_paths  # re-exported: callers look here
from validator.plan_format import dumps_plan
from validator.position_loss import (
    Berth,
    PositionLossFinding,
    Slowed,
    audit_position_loss,
    berth_buffer_m,
)
from validator.site import Site
from validator.waypoints_format import waypoint_files
from validator.wind_track import wind_buffer_m

__all__ = ["DYNAMICS", "FORMATS", "Progress", "check_output_paths", "mission_report",
           "mission_view", "output_files", "params_path", "plan_and_build", "plan_solution",
           "position_loss_drift_warning", "position_loss_findings", "speed_warning",
           "write_outputs"]

FORMATS = ("plan", "waypoints")
DYNAMICS = ("vehicle", "none")  # PlannerOptions.dynamics; kept here so --help needs no cvxpy
Progress = Callable[[int, float], None]
BERTH_TRIES = 3  # plans with a wider buffer for position loss, at most
# In wind only the first, up to the wander's berth: there a GPS loss drifts with the air for
# the whole landing (validator.position_loss.drift_xy_m, 167 m in 4 m/s), far beyond any
# coast a wider buffer keeps clear, so plan-mission warns of the drift instead (realistic.yaml
# in 3 m/s from 270: 1.80 bps/Hz at 12.5 m, 1.50 at the 27.5 m a second berth asked for).
BERTH_TRIES_IN_WIND = 1
# How much longer (fraction of T) the cycle may grow by slowing legs whose GPS-loss coast the
# berth left in reach: the coast is a warning's risk, a late cycle serves every node late
COAST_SLOWING_MAX = 0.01
# The wind's path family the plan at the buffer asked for is made with, where a berth may
# follow (plan_and_build): that plan is mostly a probe for the coast's findings.
BERTH_PROBE_PATHS = ("air-frame",)


def mission_report(mission: Mission, flight: FlightCheck | None = None,
                   params: AutopilotParams | None = None) -> dict[str, object]:
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
    if mission.position_loss_berth is not None:
        out["position_loss_berth"] = mission.position_loss_berth.as_dict()
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
    OpenStreetMap tiles), which also draws the site's wind and the failsafe paths the
    parameter file leaves (:func:`mission_view`).
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
        files[Path(html)] = mission_view(mission, flight, Path(out).name, html_map,
                                         autopilot_params)
    return files


def mission_view(mission: Mission, flight: FlightCheck | None = None, name: str = "",
                 map_background: bool = False,
                 autopilot_params: AutopilotParams | None = None) -> str:
    """The mission's interactive view (:func:`validator.view.view_html`) with the replay of
    ``flight`` on its time slider, the wind the plan was made for (the site's forecast) and,
    with ``autopilot_params`` (the ``.param`` written beside the mission), the failsafe paths
    they leave as :func:`validator.failsafe.audit_failsafes` checks them."""
    from validator.failsafe import audit_failsafes
    from validator.flight import resolve_flight
    from validator.view import TrackLayer, ViewInputs, failsafe_paths, view_html

    site = mission.solution.site
    resolved = (flight.flight if flight is not None and flight.flight is not None
                else resolve_flight(mission.plan, site, "mission"))
    tracks = ((TrackLayer(f"replay ({flight.profile.name})", flight.track),)
              if flight is not None and flight.track is not None else ())
    paths = (failsafe_paths(audit_failsafes(mission.plan, site, resolved,
                                            autopilot_params.values), resolved)
             if autopilot_params is not None else ())
    wind = None if site.wind is None or site.wind.calm else site.wind
    title = f"{site.name}: {name or 'mission'} ({mission.solution.scheme})"
    return view_html(ViewInputs(mission.plan, site, resolved, tracks, paths, wind, title=title),
                     map_background=map_background)


def write_outputs(files: dict[Path, str | bytes]) -> None:
    """Write the files atomically, all or none (:func:`validator.fileio.write_all_atomic`)."""
    write_all_atomic(files)


def plan_solution(
    site: Site,
    scheme: str = "proposed",
    options: MissionOptions | None = None,
    *,
    dynamics: str = "vehicle",
    progress: Progress | None = None,
    pass_through_corners: bool = True,
    second_start: bool = False,
    wind_buffer: bool = True,
    wind_paths: Sequence[str] | None = None,
    first_fit: bool = False,
) -> Solution:
    """Optimise ``site`` with the paper's Algorithm 1 for the mission ``options`` will lay out.

    ``dynamics`` "vehicle" keeps speed changes within the site's acceleration and jerk
    limits; "none" is the paper's kinematic model. ``pass_through_corners`` False stops the
    vehicle at every waypoint; ``second_start`` also runs Algorithm 1 from 1/K schedule
    shares and keeps the better (:class:`~mission_planner.optimize.PlannerOptions`). In wind
    (``site.wind``) with ``wind_buffer`` the safety buffer grows by how much closer the flown
    track comes in that wind (:func:`validator.wind_track.wind_buffer_m`), so the flown track
    keeps the site's buffer; plan-mission does so unless ``--buffer-m`` is given.
    ``wind_paths``: the families of paths searched in wind (default: every one of
    :data:`~mission_planner.optimize.bcd.WIND_PATHS`). ``first_fit`` ends the top-speed search
    at the first speed that fits T: a plan only looked at, as the berth's probe. Options are
    checked before the (slow) optimisation.
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
                                     start_schedules=starts, first_fit=first_fit)
    if wind_paths is not None:
        planner_options = dataclasses.replace(planner_options, wind_paths=tuple(wind_paths))
    return plan(site, scheme, options=planner_options, progress=progress)


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
    position_loss_berth: bool = True,
) -> Mission:
    """:func:`plan_solution`, then lay out its mission
    (:func:`~mission_planner.mission.build_mission`). The safety verdict is in
    ``Mission.problems``; nothing is written here.

    A PX4 vehicle plan flown through its corners (``pass_through_corners``) is kept only
    where it beats the plan stopping at every waypoint on the min rate along the ``px4``
    replay (:func:`~mission_planner.flight_report.replay_mission`; a tie, or a plan the gate
    refuses, stops): PX4's speed search ends at the first planning speed whose moves fit T,
    and the faster moves of a path flown through may fit first with a worse path.

    With ``position_loss_berth`` a vehicle plan, ArduCopter's or PX4's (the paper's
    kinematic model, ``dynamics`` "none", stays the paper's) from which a GPS loss could
    coast into a zone (:func:`position_loss_findings`) is planned again with the wider buffer
    :func:`validator.position_loss.berth_buffer_m` asks for (up to :data:`BERTH_TRIES`
    plans, :data:`BERTH_TRIES_IN_WIND` in wind; kept while the gate accepts it and home stays
    outside the wider buffer), and says so in ``Mission.position_loss_berth`` (also when no
    wider plan could be made and the findings stay warnings); a leg whose coast the last plan
    still leaves in reach is then commanded the speed that keeps it out, where one does
    (:func:`_coast_slowed`); plan-mission does so unless ``--buffer-m`` is given. In wind
    the plan at the buffer asked for searches :data:`BERTH_PROBE_PATHS` alone, up to the
    first speed that fits (``first_fit``), unless it is the one kept (no finding, or no wider
    plan), which is then made again with every family and a full search."""
    opt = options or MissionOptions()

    def planned(at: Site, widened: bool, through: bool, report: Progress | None,
                probe: bool) -> Mission:
        return build_mission(plan_solution(
            at, scheme, opt, dynamics=dynamics, progress=report,
            pass_through_corners=through, second_start=second_start,
            wind_buffer=wind_buffer and not widened,
            wind_paths=BERTH_PROBE_PATHS if probe else None, first_fit=probe), opt)

    def made(at: Site, widened: bool, probe: bool = False) -> Mission:
        mission = planned(at, widened, pass_through_corners, progress, probe)
        if opt.autopilot != "px4" or dynamics != "vehicle" or not pass_through_corners:
            return mission
        stopping = planned(at, widened, False, None, probe)
        return (mission if _replayed_min_rate(mission) > _replayed_min_rate(stopping)
                else stopping)

    berths = position_loss_berth and dynamics == "vehicle"
    if not berths:
        return made(site, False)
    # In wind the plan at the buffer asked for is nearly always replaced by a berth plan (its
    # legs hug the buffer, so a coast from them reaches the zone): it is a probe for the
    # coast's findings, never flown, so one family and the first speed that fits will do, and
    # the searches are spent on the plan that is kept (bench_wind: planning CPU in wind
    # 1.49 -> 1.13 x for one family; no raise: 9 % less CPU again, 21 of 23 plans the same; no
    # bisection either, 1-3 candidates where 4-6: 11 % less again over 42 site-wind pairs, the
    # berth the same on 31, min rates -0.3 % to +1.9 %).
    probing = site.flight_wind is not None
    mission = made(site, False, probe=probing)
    lost = position_loss_findings(mission, drift=False)
    if not lost and probing:
        mission = made(site, False)
        lost = position_loss_findings(mission, drift=False)
    if not lost:
        return mission
    asked, deepest = mission.solution.site.buffer_m, max(-f.clearance_m for f in lost)
    widened = False
    for _ in range(BERTH_TRIES if site.flight_wind is None else BERTH_TRIES_IN_WIND):
        need = berth_buffer_m(mission.solution.site.buffer_m, lost)
        if need is None:  # (there are findings: never)
            break
        try:
            wider = made(site.with_buffer(need), True)
        except InputError:  # home inside the wider buffer: the findings stay warnings
            break
        if wider.problems:
            break
        mission, lost, widened = wider, position_loss_findings(wider, drift=False), True
        if not lost:
            break
    if probing and not widened:  # no wider plan: the one kept is searched in full
        mission = made(site, False)
        lost = position_loss_findings(mission, drift=False)
        if not lost:
            return mission
    mission, lost, slowed = _coast_slowed(mission, lost)
    berth = Berth(asked, mission.solution.site.buffer_m, deepest, len(lost),
                  windy=mission.solution.site.flight_wind is not None, slowed=slowed,
                  autopilot=opt.autopilot)
    return dataclasses.replace(mission, position_loss_berth=berth)


def _coast_slowed(mission: Mission, lost: tuple[PositionLossFinding, ...]
                  ) -> tuple[Mission, tuple[PositionLossFinding, ...], tuple[Slowed, ...]]:
    """``mission`` laid out again with legs a finding of ``lost`` names commanded the speed
    whose coast stays out (:func:`validator.position_loss.position_loss_speed_cap_mps`, the
    one speed rule), the findings it has then, and each leg slowed (its item in the new plan,
    from and to m/s). Where the berth leaves a coast in reach, a slower leg keeps it out for
    seconds of cycle (airfield.yaml: the 258 m leg to the cycle's far end, 10 -> 9.5 m/s, 1.1 s
    for T = 240 s, 0.60 m deep into the CTR before). Every transit leg is slowed (it costs no
    service); cycle legs, cheapest first, while the cycle grows by no more than
    :data:`COAST_SLOWING_MAX` of T: a plan must still fly on time (realistic.yaml in 6 m/s
    from 270° asked an upwind leg down from 4.5 to 2.9 m/s, 45 s of a 160 s cycle). Kept
    only where the safety gate accepts it; unchanged without a cap."""
    from validator.flight import resolve_flight

    site = mission.solution.site
    legs = resolve_flight(mission.plan, site, "mission").legs
    first, closing = mission.cycle_items
    budget_s = COAST_SLOWING_MAX * site.period_s
    transit, cycle = [], []
    for f in sorted({f.leg: f for f in lost}.values(), key=lambda f: f.leg):
        if f.speed_cap_mps is None or not f.speed_cap_mps < f.speed_mps:
            continue
        leg = legs[f.leg]
        cap = (tuple(leg.start_xy_m), tuple(leg.end_xy_m), f.speed_cap_mps)
        if first <= f.item <= closing:
            cycle.append((leg.length_m * (1 / f.speed_cap_mps - 1 / f.speed_mps), cap))
        else:
            transit.append(cap)
    spent, caps = 0.0, list(transit)
    for cost_s, cap in sorted(cycle):
        if spent + cost_s > budget_s:
            break
        spent, caps = spent + cost_s, [*caps, cap]
    if not caps:
        return mission, lost, ()
    slower = build_mission(mission.solution,
                           dataclasses.replace(mission.options, leg_speed_caps=tuple(caps)))
    if slower.problems or cycle_duration_s(slower) - cycle_duration_s(mission) > budget_s:
        return mission, lost, ()
    flown = resolve_flight(slower.plan, site, "mission").legs
    was = {f.leg: f.speed_mps for f in lost}
    slowed = tuple(
        (leg.item, was[k], float(leg.speed_mps))
        for k, leg in enumerate(flown) if k in was and leg.speed_mps is not None
        and leg.speed_mps < was[k] - 1e-6)
    return slower, position_loss_findings(slower, drift=False), slowed


def position_loss_findings(mission: Mission, *, drift: bool = True
                           ) -> tuple[PositionLossFinding, ...]:
    """The legs of ``mission`` from which a GPS loss may coast into a zone, at its recommended
    parameters and by its autopilot's coast (the failsafe audit's position-loss part,
    :func:`validator.position_loss.audit_position_loss`). ``drift``: in the plan's wind the
    coast drifts downwind while the vehicle lands; without it, the coast a wider buffer can
    keep clear (the berth's)."""
    from validator.flight import resolve_flight

    site = mission.solution.site
    flight = resolve_flight(mission.plan, site, "mission")
    return tuple(audit_position_loss(flight, site, recommended_params(mission).values,
                                     drift=drift, autopilot=mission.options.autopilot))


def position_loss_drift_warning(mission: Mission) -> str | None:
    """One line when, in the plan's wind, a GPS loss on ``mission`` may drift into a zone
    while the failsafe (ArduCopter's EKF failsafe, PX4's Descend) lands without a position
    (:func:`validator.position_loss.drift_xy_m`), else None. No buffer keeps such a drift
    clear: it is the whole landing's worth of wind (about 250 m in 6 m/s from 30 m)."""
    wind = mission.solution.site.flight_wind
    if wind is None:
        return None
    drifting = [f for f in position_loss_findings(mission) if f.drift_m > 0.0]
    if not drifting:
        return None
    zones = ", ".join(sorted({f.zone for f in drifting}))
    legs = len({f.leg for f in drifting})
    return (f"a GPS loss in {wind.label()} drifts up to {max(f.drift_m for f in drifting):.0f} m "
            f"with the wind while {coast_rule(mission.options.autopilot).failsafe_name} "
            f"lands without a position: from "
            f"{legs} leg(s) it may enter {zones} (up to "
            f"{max(-f.clearance_m for f in drifting):.1f} m deep), and no buffer keeps that "
            f"clear; validate-mission --params --report lists the legs")


def _replayed_min_rate(mission: Mission) -> float:
    """The min rate (bps/Hz) along the replay of ``mission`` at its recommended parameters;
    -inf for a mission the safety gate refuses or whose replay has no complete cycle."""
    if mission.problems:
        return -math.inf
    rate = replay_mission(mission).replayed_min_rate_bps_hz
    return -math.inf if rate is None else rate


def speed_warning(site: Site, dynamics: str, autopilot: str = "ardupilot") -> str | None:
    """One line when the site's V is above the vehicle's real top speed
    (:func:`~validator.motion.speed_model.top_speed_mps`), else None."""
    top = top_speed_mps(site, autopilot)
    if site.max_speed_mps <= top:
        return None
    then = (f"planning at {top:.2f} m/s" if dynamics == "vehicle" else
            f"--dynamics none plans at {site.max_speed_mps:g} m/s as the paper does, so the "
            f"vehicle flies slower than planned")
    return (f"{site.name}: uav.max_speed {site.max_speed_mps:g} m/s is above the vehicle's "
            f"real top speed {top:.2f} m/s (lean limit with drag, at {site.altitude_m:g} m "
            f"above the ground); {then}")
