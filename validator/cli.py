"""``validate-mission``: audit a ``.plan`` against a site, optionally replay it in time.

    validate-mission PLAN --site SITE [--report OUT] [--replay]
                     [--autopilot ardupilot|px4 | --profile ideal]
                     [--params FILE [--force]] [--param NAME=VALUE ...] [--dt SECONDS]
                     [--flown TRACK.csv] [--html OUT.html [--html-map]]
                     [--wind SPEED@FROM[,TURB]] [--quiet]
                     [--sitl [--sitl-binary PATH | --connect URL [--sysid N]
                      [--signing-key FILE]] [--timeout S] [--fault KIND] ...]
                     [--at ISO-8601] [--authorised ZONE ...]

Prints a table on stdout; ``--report OUT`` also writes the full report atomically. Exit
status: :data:`validator.cli_common.EXIT_STATUS` (0 clear, 1 a violation (audit, replay or
flight), 2 bad input (one line on stderr, no output file), 130 interrupted).
``--autopilot``, ``--profile ideal`` or ``--param`` imply ``--replay``; the default flight model
follows the plan's firmware (PX4 -> ``px4``, otherwise ``arducopter``). ``--params FILE`` is the
parameter file the vehicle will fly with (``plan-mission`` writes one beside the plan): its
motion parameters feed the replay, it is set on the vehicle of a ``--sitl`` flight, a file that
leaves the geofence off or with a breach action that can cross another zone is flagged, and
the path of every failsafe it leaves is audited (:mod:`validator.failsafe`): one that crosses
a zone or its buffer fails the audit (exit 1) unless ``--force``. ``--at`` and
``--authorised`` re-decide the site's UAS zones (ED-269, ED-318) for the plan's flight from
that time: a leg in a zone active then is a violation (without ``--at`` every zone is taken as
active).

Everything here parses and prints around :func:`validator.validation.validate_mission`, which
notebooks can call (or :mod:`validator.api`).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path

from validator.autopilot.param_file import read_params
from validator.cli_common import (
    add_autopilot_arguments,
    add_deprecated,
    add_quiet_argument,
    command_parser,
    read_signing_key_arg,
    run_command,
)
from validator.errors import InputError
from validator.fileio import write_all_atomic
from validator.flight import Finding
from validator.item_numbers import item_label, item_number
from validator.mavlink.sitl_check import (
    add_sitl_arguments,
    fly_validation,
    progress_printer,
    split_sitl_url,
)
from validator.mavlink.vehicles import choose_vehicle
from validator.motion.fly import MIN_REPLAY_STEP_S, REPLAY_STEP_S
from validator.motion.profile import ProfileName, parse_param_overrides
from validator.output_paths import check_output_paths, output_path
from validator.plan_format import Autopilot
from validator.replay import TrackReport
from validator.site_airspace import site_inputs
from validator.track_file import write_track
from validator.uas_zones.applicability import AirspaceOptions, parse_at
from validator.validation import (
    Validation,
    default_profile_name,
    validate_mission,
    wind_label,
)
from validator.wind import parse_wind_arg
from validator.wind_track import buffer_share, extrapolation_warning

__all__ = ["Validation", "build_parser", "default_profile_name", "format_report",
           "validate_mission", "validate_mission_main"]

KEY_PARAMS = {  # shown in the table; the JSON report lists every parameter
    "ideal": ("SPEED", "VEHICLE_SPEED_MAX"),
    "arducopter": ("WPNAV_SPEED", "WPNAV_ACCEL", "WPNAV_JERK", "WPNAV_RADIUS", "VEHICLE_SPEED_MAX"),
    "px4": ("MPC_XY_CRUISE", "MPC_ACC_HOR", "MPC_JERK_AUTO", "NAV_ACC_RAD", "VEHICLE_SPEED_MAX"),
}


# --------------------------------------------------------------------------------------------
# the table


def _fmt(x: float | None, spec: str = ".2f") -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def _track_lines(title: str, rep: TrackReport) -> list[str]:
    lines = [title]
    if rep.nfz:
        lines.append(f"  {'NFZ':<10} {'flown clearance (m)':>20} {'t (s)':>9} {'item':>6}")
        for p in rep.nfz:
            lines.append(f"  {p.name:<10} {p.clearance_m:>20.2f} {p.t_s:>9.1f} "
                         f"{item_number(p.item):>6}")
    c = rep.cycle
    if c is not None:
        per = ""
        if len(c.flown_cycles_s) > 1:
            per = " (" + ", ".join(f"{x:.1f}" for x in c.flown_cycles_s) + ")"
        lines.append(
            f"  cycle ({c.cycles} x, {c.source}): planned {c.planned_period_s:.1f} s, "
            f"at commanded speeds {c.ideal_cycle_s:.1f} s, flown {c.flown_cycle_s:.1f} s{per} "
            f"= {c.ratio:.2f} x planned"
        )
    lags = [w for w in rep.waypoint_lag if w["lag_s"] is not None]
    worst = rep.worst_lag
    if worst is not None and worst["timed_by"] == "slots":
        line = (f"  lag behind the planner's slot times: max {rep.max_lag_s:.1f} s "
                f"(item {worst['item']})")
        if lags[-1]["timed_by"] == "commanded":  # the landing: no slot times it
            line += (f"; at the last waypoint {lags[-1]['lag_s']:.1f} s behind the commanded "
                     "speeds flown without acceleration")
        lines.append(line)
    elif worst is not None:
        lines.append(f"  lag behind the commanded speeds flown without acceleration: max "
                     f"{rep.max_lag_s:.1f} s (item {worst['item']}), at the last waypoint "
                     f"{lags[-1]['lag_s']:.1f} s")
    lines.append(f"  cross-track deviation from the legs: max {rep.cross_track_max_m:.2f} m, "
                 f"rms {rep.cross_track_rms_m:.2f} m; top speed {rep.speed_max_mps:.1f} m/s")
    tp = rep.throughput
    if tp is not None:
        lines.append(f"  {'GN':<10} {'planned (bps/Hz)':>17} {'flown (bps/Hz)':>15} {'ratio':>7}")
        for g, p, f in zip(tp.gn_names, tp.planned_bps_hz, tp.flown_bps_hz, strict=True):
            lines.append(f"  {g:<10} {p:>17.4f} {f:>15.4f} {_fmt(f / p if p > 0 else None):>7}")
        lines.append(f"  {'min':<10} {tp.planned_min:>17.4f} {tp.flown_min:>15.4f} "
                     f"{_fmt(tp.flown_min / tp.planned_min if tp.planned_min > 0 else None):>7}")
    return lines


def format_report(v: Validation) -> str:
    """The terminal table of a :class:`Validation`."""
    flight, rep, site = v.flight, v.audit, v.site
    kinds: dict[str, int] = {}
    for leg in flight.legs:
        kinds[leg.kind] = kinds.get(leg.kind, 0) + 1
    legs = ", ".join(f"{n} {k}" for k, n in kinds.items())
    lines = [
        f"validate-mission: {v.plan_path} on site {site.name} ({v.site_path})",
        f"  {len(v.plan.items)} items -> {len(flight.legs)} legs ({legs})",
    ]
    if flight.cycle is not None:
        c = flight.cycle
        lines.append(f"  service cycle: legs {c.start_leg}-{c.end_leg}, {c.cycles} cycle(s) "
                     f"({c.source})")
    if site.airspace.uas:
        lines += ["", *site.airspace.lines()]
    lines += ["", f"Audit: exact clearance of every straight leg from each NFZ "
              f"(m from the published radius; safety buffer {site.buffer_m:g} m)"]
    if rep.nfz:
        lines.append(f"  {'NFZ':<10} {'clearance (m)':>14} {'t (s)':>9}  leg")
        for z in rep.nfz:
            lines.append(f"  {z.name:<10} {z.clearance_m:>14.2f} {z.t_s:>9.1f}  "
                         f"{item_label(z.from_item)} -> {item_label(z.item)}")
    else:
        lines.append("  (the site has no NFZ)")
    lines.append(f"  fence: {len(v.plan.circles)} circle(s), {len(v.plan.polygons)} polygon(s), "
                 f"{len(v.plan.rally)} rally point(s)")
    if v.planned_wind is not None or v.flown_wind is not None:
        lines += ["", f"Wind: planned for {wind_label(v.planned_wind)}; flown in "
                  f"{wind_label(v.flown_wind)}"
                  + ("" if v.wind_as_planned else " (NOT the plan's wind: the cycle, clearance "
                     "and rates below are for the flown wind)")]
        share = buffer_share(site.buffer_m, v.flight_wind)
        lines.append(f"  the flown wind eats {share['track_deviation_m']:.2f} m of the "
                     f"{site.buffer_m:g} m buffer ({share['share_of_buffer']:.0%}; the flown "
                     f"track's extra closeness at the {share['deviation_quantile']:.0%} quantile "
                     "of SITL flights)")
        guessed = extrapolation_warning(v.flight_wind, px4=Autopilot.of(v.plan).key == "px4")
        if guessed:
            lines.append(f"  warning: {guessed}")
    if v.replay is not None and v.profile is not None:
        params = " ".join(f"{k}={v.profile.params[k]:g}" for k in KEY_PARAMS[v.profile.name])
        lines += ["", *_track_lines(f"Replay ({v.profile.name}, {1 / v.dt_s:g} Hz, "
                                    f"{v.replay.samples} samples): {params}", v.replay)]
    if v.sitl is not None:
        flown = v.extra.get("sitl_flight", {})
        who = (f"the built-in model vehicle ({flown.get('profile')} profile): a model, not an "
               "autopilot" if flown.get("builtin") else flown.get("vehicle", "a vehicle"))
        if "recorded_flight" in v.extra:
            who = f"the recorded flight {v.extra['recorded_flight']['file']}"
        lines += ["", *_track_lines(f"Flown by {who} ({v.sitl.source})", v.sitl)]
        if v.extra.get("sitl_wind"):
            lines.append(f"  {v.extra['sitl_wind']}")
    if "fault" in v.extra:
        from validator.mavlink.faults import fault_lines

        fault = v.extra["fault"]
        lines += ["", f"Fault: {fault['kind']}, the flight after it (from "
                  f"{fault['position_source']})"]
        lines += ([f"  {s}" for s in fault_lines(fault)] if fault["injected_xy_m"] is not None
                  else [f"  {fault['end_state']}"])
    if v.failsafe is not None:
        lines += ["", *_failsafe_lines(v)]
    findings = list(rep.findings) + list(v.param_findings) + _failsafe_summary(v)
    for r in (v.replay, v.sitl):
        if r is not None:
            findings += list(r.findings)
    if findings:
        lines += ["", "Findings:"]
        for f in findings:
            where = f"{item_label(f.item)}: " if f.item is not None else ""
            lines.append(f"  {f.severity.upper() if f.severity == 'violation' else f.severity:<9} "
                         f"{where}{f.message}")
    n = len(v.violations)
    lines += ["", f"Result: {'VIOLATION (' + str(n) + ')' if n else 'CLEAR'}"]
    return "\n".join(lines)


def _failsafe_lines(v: Validation) -> list[str]:
    fs = v.failsafe
    assert fs is not None
    lines = ["Failsafes: the path each action flies from every point of the mission "
             "(value from the file, else the firmware's default)",
             f"  {'failsafe':<28} {'parameter':<16} {'value':>6} {'from':<8} {'paths':<18} "
             "verdict"]
    # the path of the failsafe that fires after a GPS loss is a landing in place; the coast
    # before it stops is another matter (validator.position_loss: warnings, listed below)
    lost = fs.position_loss
    for c in fs.checks:
        bad = [f for f in fs.findings if f.param == c.param]
        verdict = "clear" if not bad else f"{len(bad)} path finding(s)"
        if c.param == fs.gps_loss_failsafe and lost:
            verdict += f"; its coast after a GPS loss: {len({f.leg for f in lost})} leg warning(s)"
        lines.append(f"  {c.trigger[:28]:<28} {c.param:<16} {c.value:>6g} {c.source:<8} "
                     f"{'+'.join(c.paths):<18} {verdict}")
    w = fs.worst_return
    if w is not None:
        lines.append(f"  a straight return comes closest to a zone from {item_label(w.item)} "
                     f"(x {w.xy_m[0]:.1f}, y {w.xy_m[1]:.1f} m): {w.clearance_m:.2f} m from "
                     f"{w.zone}, to {w.destination}")
    return lines


def _failsafe_summary(v: Validation) -> list[Finding]:
    """The failsafe findings for the table: per parameter and zone the deepest path, per zone
    the deepest coast after a GPS loss (the JSON report lists every leg)."""
    if v.failsafe is None:
        return []
    fs = v.failsafe
    paths, notes, coasts = v.failsafe_groups()
    return (_deepest(paths, [((f.param, f.zone), f.clearance_m) for f in fs.findings]) + notes
            + _deepest(coasts, [(f.zone, f.clearance_m) for f in fs.position_loss]))


def _deepest(findings: list[Finding], keyed: list[tuple[object, float]]) -> list[Finding]:
    """Of ``findings`` (each with its group key and clearance in ``keyed``), the deepest of
    each group, saying from how many more legs the group's other findings come."""
    worst: dict[object, int] = {}
    for i, (key, clearance_m) in enumerate(keyed):
        if key not in worst or clearance_m < keyed[worst[key]][1]:
            worst[key] = i
    out = []
    for key, i in worst.items():
        more = sum(1 for k, _ in keyed if k == key) - 1
        g = findings[i]
        out.append(Finding(g.severity, g.message + (f" (and from {more} more leg(s))"
                                                    if more else ""), g.item))
    return out


# --------------------------------------------------------------------------------------------
# the command


def build_parser() -> argparse.ArgumentParser:
    """The ``validate-mission`` argument parser.

    ``--sitl [URL]`` (fly the mission on a MAVLink vehicle and score its telemetry into
    ``Validation.sitl``) belongs to :mod:`validator.mavlink` and is added here by it.
    """
    p = command_parser(
        "validate-mission",
        "Prove a mission's continuous-path NFZ clearance: exact audit of every straight leg "
        "and the geofence, and a time-domain replay of how a multicopter flies it.",
    )
    p.add_argument("plan", help="QGroundControl .plan file")
    p.add_argument("--site", required=True, help="site YAML file")
    p.add_argument("--report", type=output_path, metavar="OUT",
                   help="also write the full report as JSON (as plan-mission --report)")
    add_deprecated(p, "--json", "--report", dest="report", type=output_path, metavar="OUT")
    p.add_argument("--replay", action="store_true", help="fly the mission in time")
    add_autopilot_arguments(
        p, help="replay with this autopilot's flight model (default: by the plan's firmware); "
                "implies --replay",
        profile="replay with the kinematic model instead (top speed only); implies --replay")
    p.add_argument("--params", metavar="FILE",
                   help="the parameter file the vehicle flies with (as plan-mission writes "
                        "beside the plan): feeds the replay, is set on a --sitl vehicle, "
                        "a geofence it leaves off is flagged, and every failsafe path it "
                        "leaves (its values, else the firmware's defaults) is audited")
    p.add_argument("--force", action="store_true",
                   help="report failsafe paths that cross a zone or its buffer as warnings: "
                        "they do not fail the audit")
    p.add_argument("--param", action="append", metavar="NAME=VALUE",
                   help="profile parameter in the autopilot's units, e.g. WPNAV_ACCEL=500 "
                        "(repeatable); implies --replay")
    p.add_argument("--wind", metavar="SPEED@FROM",
                   help="fly the replay (and ArduCopter SITL) in this wind: m/s and the "
                        "direction it blows from, degrees true, e.g. 8@270; SPEED@FROM,TURB "
                        "adds turbulence (m/s); 0 for still air (default: the wind the plan "
                        "was made for); implies --replay")
    p.add_argument("--dt", type=float, default=REPLAY_STEP_S, metavar="SECONDS",
                   help=f"replay sample interval (default {REPLAY_STEP_S:g} = "
                        f"{1 / REPLAY_STEP_S:g} Hz; {MIN_REPLAY_STEP_S:g} to {REPLAY_STEP_S:g})")
    p.add_argument("--at", metavar="ISO-8601",
                   help="when the plan flies, with its time zone: the site's UAS zones are "
                        "decided for then and the flight's duration (default: every zone "
                        "taken as active)")
    p.add_argument("--authorised", action="append", default=[], metavar="ZONE",
                   help="identifier of a REQ_AUTHORISATION or CONDITIONAL zone the flight is "
                        "authorised for (repeatable)")
    p.add_argument("--flown", metavar="TRACK.csv",
                   help="a recorded flight of this plan (as --track writes it; .gz too): "
                        "scored like a flight and drawn in --html")
    p.add_argument("--html", type=output_path, metavar="OUT.html",
                   help="also write an interactive view (one self-contained HTML page: "
                        "zones, fence, legs, waypoints, the replay and the flown track on a "
                        "time slider); implies --replay")
    p.add_argument("--html-map", action="store_true",
                   help="with --html, draw the view on OpenStreetMap tiles (fetched by the "
                        "browser when the page opens, so online only; default: local metres)")
    add_quiet_argument(p, "no flight progress on stderr (shown only on a terminal; warnings, "
                          "errors and the table still print)")
    add_sitl_arguments(p)
    return p


def validate_mission_main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``validate-mission``; returns the exit status."""
    return run_command("validate-mission", lambda: _validate(build_parser().parse_args(
        split_sitl_url(sys.argv[1:] if argv is None else argv))))


def _validate(args: argparse.Namespace) -> int:
    flying = bool(args.sitl or args.sitl_binary or args.connect)
    if args.html_map and not args.html:
        raise InputError("--html-map: only with --html")
    if args.flown and flying:
        raise InputError("--flown: a recorded flight, or a flight now (--sitl…), not both")
    check_output_paths(
        [out for out in (args.report, args.html, args.track) if out is not None],
        {"the plan": args.plan, **site_inputs(args.site), "the --params file": args.params,
         "the --flown track": args.flown, "the --signing-key file": args.signing_key,
         "the --sitl-defaults file": args.sitl_defaults, "the --sitl-binary": args.sitl_binary})
    if args.track and not flying:
        raise InputError("--track: only a flight has a track (add --sitl, --sitl-binary "
                         "or --connect)")
    params = parse_param_overrides(args.param)
    vehicle_params = read_params(args.params) if args.params else None
    wind = parse_wind_arg(args.wind) if args.wind is not None else None
    autopilot: Autopilot | None = args.autopilot
    profile: ProfileName | None = args.profile or (
        autopilot.profile_name if autopilot is not None else None)
    v = validate_mission(args.plan, args.site,
                         replay_flight=args.replay or bool(args.html) or wind is not None,
                         profile=profile, params=params or None, dt_s=args.dt,
                         vehicle_params=vehicle_params, flown_track=args.flown, wind=wind,
                         airspace=AirspaceOptions(parse_at(args.at) if args.at else None,
                                                  authorised=frozenset(args.authorised)),
                         force=args.force)
    if flying:
        choice = choose_vehicle(v.plan, url=args.connect, binary=args.sitl_binary,
                                speedup_x=args.sitl_speedup, defaults=args.sitl_defaults,
                                sysid=args.sysid,
                                signing_key=read_signing_key_arg(args.signing_key))
        flown = fly_validation(v, choice, vehicle_params=vehicle_params, overrides=params,
                               fault=args.fault, timeout_s=args.timeout,
                               time_limit_s=args.sitl_time_limit,
                               progress=progress_printer("validate-mission", args.quiet))
        if flown.wind_note is not None:
            v.extra["sitl_wind"] = flown.wind_note
        v.extra["sitl_flight"] = flown.as_dict()
        if args.track and v.recorded is not None:
            write_track(args.track, v.recorded,
                        (f"plan {args.plan}", f"vehicle {flown.vehicle}"))
    files: dict[Path, str | bytes] = {}
    if args.report:
        files[Path(args.report)] = json.dumps(v.as_dict(), indent=1, allow_nan=False) + "\n"
    if args.html:
        from validator.view import validation_inputs, view_html

        files[Path(args.html)] = view_html(validation_inputs(v), map_background=args.html_map)
    write_all_atomic(files)
    print(format_report(v))
    return v.exit_status


if __name__ == "__main__":  # pragma: no cover
    sys.exit(validate_mission_main())
