"""How a mission is laid out: :class:`MissionOptions`, their checks, the autopilots served."""

from __future__ import annotations

from dataclasses import dataclass

from mission_planner.transit import DEFAULT_ARC_STEP_DEG
from validator.autopilot.rules import ARDUPILOT_MIN_SPEED_MPS, STATIONARY_M
from validator.autopilot.waypoint_radius import fence_margin_m, waypoint_radius_m
from validator.errors import InputError
from validator.geodesy import E7_ROUNDING_MARGIN_M
from validator.plan_format import Autopilot
from validator.site import MAX_REACH_M, Site

AUTOPILOTS = {a.key: a for a in (Autopilot.ARDUPILOTMEGA, Autopilot.PX4)}  # --autopilot
OPERATING_AREAS = ("polygon", "circle")
# A leg capped by position (a resolved plan's legs come back from MAVLink's 1e-7° grid, about
# a centimetre off the layout's points; no two of a mission's legs share both ends this close)
LEG_MATCH_M = 0.1
LegCap = tuple[tuple[float, float], tuple[float, float], float]
__all__ = ["AUTOPILOTS", "LEG_MATCH_M", "OPERATING_AREAS", "LegCap", "MissionOptions",
           "check_options", "corner_margin_m", "fence_margin_for", "leg_margin_m",
           "waypoint_radius_m"]


@dataclass(frozen=True)
class MissionOptions:
    """How to lay out the mission; every length in metres, speed in m/s, time in seconds.

    ``fence_margin_m`` None means half the site's safety buffer. ``operating_area`` None, or
    "polygon" (buffered convex hull) / "circle" (bounding circle) around everything flown,
    ``operating_area_margin_m`` outside it. ``transit_speed_mps`` None means the site's V.
    ``merge_legs`` False keeps one waypoint per moving slot (the paper's layout); otherwise
    straight runs merge within ``merge_angle_deg`` (degrees), ``merge_speed_rel`` (fraction)
    and ``merge_offset_m`` (see :func:`merge_straight_steps`). ``leg_speed_caps``: legs, each
    ``((x0, y0), (x1, y1), cap_mps)`` from start to end in site metres, commanded no faster
    than ``cap_mps`` (where a GPS loss's coast needs it: ``plan_and_build``); a leg is matched
    within :data:`LEG_MATCH_M` of both ends.
    """

    autopilot: str = "ardupilot"
    cycles: int = 1
    fence_margin_m: float | None = None
    operating_area: str | None = None
    operating_area_margin_m: float = 20.0
    transit_speed_mps: float | None = None
    export_margin_m: float = E7_ROUNDING_MARGIN_M
    max_nudge_m: float = 0.05
    stationary_tol_m: float = STATIONARY_M
    min_speed_mps: float = ARDUPILOT_MIN_SPEED_MPS
    speed_tol_mps: float = 1e-3
    arc_step_deg: float = DEFAULT_ARC_STEP_DEG
    merge_legs: bool = True
    merge_angle_deg: float = 1.0
    merge_speed_rel: float = 0.01
    merge_offset_m: float = 0.05
    leg_speed_caps: tuple[LegCap, ...] = ()


def check_options(site: Site, options: MissionOptions) -> None:
    """Refuse option values that cannot give a sensible mission (:class:`InputError`)."""
    if options.autopilot not in AUTOPILOTS:
        raise InputError(
            f"autopilot: expected one of {', '.join(AUTOPILOTS)}, got {options.autopilot!r}")
    if options.cycles < 1:
        raise InputError(f"cycles: must be >= 1, got {options.cycles}")
    margin = fence_margin_for(site, options)
    if not margin >= 0:  # (NaN too: it compared false with the buffer and planned on)
        raise InputError(f"fence_margin_m: must be >= 0, got {margin:g}")
    if margin > site.buffer_m:
        raise InputError(
            f"fence_margin_m: {margin:g} m is larger than the planned clearance (safety buffer "
            f"{site.buffer_m:g} m): the planned legs would breach the fence"
        )
    if options.operating_area not in (None, *OPERATING_AREAS):
        raise InputError(
            f"operating_area: expected one of {', '.join(OPERATING_AREAS)}, "
            f"got {options.operating_area!r}")
    if not 0 < options.operating_area_margin_m <= MAX_REACH_M:  # no mission reaches further
        raise InputError(f"operating_area_margin_m: must be > 0 and <= {MAX_REACH_M:g} m, "
                         f"got {options.operating_area_margin_m:g}")
    if options.transit_speed_mps is not None and not (
        0 < options.transit_speed_mps <= site.max_speed_mps
    ):
        raise InputError(
            f"transit_speed_mps: must be in (0, {site.max_speed_mps:g}], "
            f"got {options.transit_speed_mps:g}")
    if not 0 <= options.min_speed_mps < site.max_speed_mps:
        raise InputError(f"min_speed_mps: must be in [0, V), got {options.min_speed_mps:g}")
    for name in ("export_margin_m", "max_nudge_m", "stationary_tol_m", "speed_tol_mps",
                 "arc_step_deg", "merge_angle_deg", "merge_speed_rel", "merge_offset_m"):
        if not getattr(options, name) >= 0:
            raise InputError(f"{name}: must be >= 0, got {getattr(options, name)}")
    for _, _, cap in options.leg_speed_caps:
        if not 0 < cap <= site.max_speed_mps:
            raise InputError(f"leg_speed_caps: a cap must be in (0, {site.max_speed_mps:g}] "
                             f"m/s, got {cap:g}")


def fence_margin_for(site: Site, options: MissionOptions) -> float:
    """The fence margin (m) outside each NFZ radius: the option, else half the buffer
    (:func:`validator.autopilot.waypoint_radius.fence_margin_m`)."""
    return fence_margin_m(site, options.fence_margin_m)


def leg_margin_m(site: Site, options: MissionOptions) -> float:
    """How far (m) exported legs clear every buffered zone: the export margin, plus the part
    of the minimum waypoint radius the buffer cannot absorb (:func:`corner_margin_m`)."""
    return options.export_margin_m + corner_margin_m(site, fence_margin_for(site, options))


def corner_margin_m(site: Site, fence_margin_m: float) -> float:
    """How far (m) legs must clear the buffered zones so that corners cut inside the waypoint
    radius (:func:`waypoint_radius_m`) stay outside the fence: nothing while the radius fits in
    the buffer's slack, else the part of the autopilot's minimum radius that does not (a site
    without a buffer still has 5 cm corners)."""
    return max(0.0, waypoint_radius_m(site, fence_margin_m) - (site.buffer_m - fence_margin_m))
