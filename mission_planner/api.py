"""The planner's front door: the calls a notebook or script makes to plan a mission.

Load a site, optimise its service cycle (the paper's Algorithm 1), lay it out as an autopilot
mission, replay it with the validator's model of the autopilot, and write the files
``plan-mission`` writes. The validator's calls to audit, replay, fly and score a plan from
any source are :mod:`validator.api`; the ones a planning script needs are re-exported here so
one import serves. Units: metres, seconds, m/s, degrees; rates in bps/Hz.

    from mission_planner import api
    site = api.load_site("samples/realistic.yaml")
    mission = api.plan_mission(site)                  # Mission: plan, solution, verdict
    flight = api.replay_mission(mission)              # FlightCheck: the modelled flight
    written = api.write_mission(mission, "out/mission.plan", flight=flight,
                                report="out/report.json")
    audit = api.audit_plan(mission.plan, site)        # the validator's own judgement

Bad input raises :class:`~validator.errors.InputError` (one line naming the file and field);
a mission the safety gate refuses raises :class:`UnsafeMission` from :func:`write_mission`
unless ``force``. The optimiser (cvxpy) is imported only when a site is planned.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mission_planner.autopilot_params import AutopilotParams, recommended_params
from mission_planner.flight_report import FlightCheck, refusals, replay_mission
from mission_planner.mission import Mission, MissionOptions, build_mission
from mission_planner.optimize.solution import Solution
from mission_planner.pipeline import (
    check_output_paths,
    output_files,
    params_path,
    plan_and_build,
    plan_solution,
    write_outputs,
)
from validator.api import (
    Flown,
    Replayed,
    VehicleChoice,
    Wind,
    audit_plan,
    choose_vehicle,
    fly_plan,
    load_site,
    read_plan,
    replay_plan,
    score_recorded,
    write_track,
)
from validator.site import Site

__all__ = [
    "AutopilotParams", "FlightCheck", "Flown", "Mission", "MissionOptions", "Replayed",
    "Solution", "UnsafeMission", "VehicleChoice", "Wind", "Written", "audit_plan", "build_mission",
    "choose_vehicle", "fly_plan", "load_site", "plan_mission", "plan_solution", "read_plan",
    "recommended_params", "replay_mission", "replay_plan", "score_recorded", "write_mission",
    "write_track",
]

Progress = Callable[[int, float], None]  # (iteration, objective) after each BCD iteration


class UnsafeMission(Exception):
    """The safety gate refuses the mission (``problems``: one line each); nothing written."""

    def __init__(self, problems: tuple[str, ...]) -> None:
        super().__init__(f"{len(problems)} problem(s), first: {problems[0]}" if problems
                         else "unsafe")
        self.problems = problems


def plan_mission(
    site: Site,
    scheme: str = "proposed",
    options: MissionOptions | None = None,
    *,
    dynamics: str = "vehicle",
    pass_through_corners: bool = True,
    second_start: bool = False,
    progress: Progress | None = None,
    wind_buffer: bool = True,
    position_loss_berth: bool = True,
) -> Mission:
    """Optimise ``site``'s service cycle and lay out its mission, as ``plan-mission`` does.

    ``scheme``: "proposed" (whole leg outside every zone), "conventional" (waypoints only) or
    "tangent". ``options`` lays out the mission (autopilot, cycles, fence; default
    :class:`MissionOptions`). ``dynamics`` "vehicle" keeps speed changes within the site's
    acceleration and jerk (default), "none" is the paper's kinematic model.
    ``pass_through_corners`` False stops at every waypoint; ``second_start`` also starts the
    optimiser from equal schedule shares and keeps the better plan (twice the time).
    ``progress(iteration, objective)`` is called after each iteration. In wind (``site.wind``,
    or ``load_site(path, wind="7@300")`` for a forecast; :mod:`validator.wind`) the plan
    keeps the top speed in the air, and with ``wind_buffer`` its buffer grows by how much
    closer the flown track comes in that wind. With ``position_loss_berth`` a vehicle
    plan (ArduCopter's or PX4's) from which a GPS loss could coast into a zone is planned
    again with a buffer wide enough (``Mission.position_loss_berth`` says so). Deterministic; the
    safety verdict is ``Mission.problems`` (empty: safe). :func:`plan_solution` followed by
    :func:`build_mission` is the same without the berth's second plan and, for PX4, without
    the comparison with a plan that stops at every waypoint.
    """
    return plan_and_build(site, scheme, options, dynamics=dynamics, progress=progress,
                          pass_through_corners=pass_through_corners, second_start=second_start,
                          wind_buffer=wind_buffer, position_loss_berth=position_loss_berth)


@dataclass(frozen=True)
class Written:
    """What :func:`write_mission` wrote: every ``files`` path (the mission first), and the
    ``mission`` and parameter file (``params``) among them."""

    files: tuple[Path, ...]
    mission: Path
    params: Path


def write_mission(
    mission: Mission,
    out: str | Path,
    *,
    fmt: str | None = None,
    params: str | Path | None = None,
    autopilot_params: AutopilotParams | None = None,
    flight: FlightCheck | None = None,
    report: str | Path | None = None,
    geojson: str | Path | None = None,
    plot: str | Path | None = None,
    html: str | Path | None = None,
    html_map: bool = False,
    force: bool = False,
) -> Written:
    """Write the mission and the files beside it, all or none, as ``plan-mission`` does.

    ``fmt`` "plan" (QGroundControl) or "waypoints" (QGC WPL 110 with ``.fence``/``.rally``
    files beside it); default by ``out``'s suffix. The autopilot parameter file goes to
    ``params`` (default: ``out`` with suffix ``.param``) with ``autopilot_params`` (default
    :func:`recommended_params`). ``flight`` (:func:`replay_mission`) adds the replay to the
    ``report`` (JSON) and its track to the ``html`` view (``html_map``: on OpenStreetMap
    tiles; the view also draws the wind and the failsafe paths of the parameter file);
    ``geojson`` and ``plot`` (PNG, the paper's Fig. 3) are optional too.
    Raises :class:`UnsafeMission` for a mission the safety gate refuses, or whose ``flight``
    has violations (:attr:`FlightCheck.problems`), unless ``force``, and
    :class:`~validator.errors.InputError` for paths that collide or whose folder is missing.
    """
    out = Path(out)
    kind = fmt or ("waypoints" if out.suffix == ".waypoints" else "plan")
    if params is None:  # its name is derived from the output's, which must be a file
        check_output_paths([out])
    param_file = Path(params) if params is not None else params_path(out)
    extras = [Path(p) for p in (report, geojson, plot, html) if p is not None]
    paths = [out, param_file, *extras]
    if kind == "waypoints":
        from validator.waypoints_format import sidecar_paths

        paths += list(sidecar_paths(out))
    check_output_paths(paths)
    problems = refusals(mission, flight)
    if problems and not force:
        raise UnsafeMission(problems)
    files = output_files(mission, out, fmt=kind, report=report, geojson=geojson, plot=plot,
                         params=param_file, autopilot_params=autopilot_params, flight=flight,
                         html=html, html_map=html_map)
    write_outputs(files)
    return Written(tuple(files), out, param_file)
