"""The waypoint radius a mission is flown with: one rule for the planner's timing of its
corners and the parameter file the exporter writes.

Autopilots round a corner inside this radius, and the rounded track leaves the planned legs
by up to about the radius, on the inside of the turn. The planned legs keep the full safety
buffer from each zone and the exclusion fence sits the fence margin (by default half the
buffer) outside the zone, so a radius of at most the slack between them keeps rounded
corners off the fence.
"""

from __future__ import annotations

from validator.autopilot.rules import ACCEPTANCE_RADIUS_PARAM, acceptance_radius_m
from validator.autopilot.tables import param_table
from validator.site import Site


def fence_margin_m(site: Site, chosen_m: float | None = None) -> float:
    """The fence margin (m) outside each zone: ``chosen_m``, else half the site's buffer."""
    return site.buffer_m / 2.0 if chosen_m is None else float(chosen_m)


def waypoint_radius_m(site: Site, fence_margin_m: float) -> float:
    """Waypoint (acceptance) radius (m) for a site: buffer − fence margin, within [0.05, 2].

    Never above the autopilot's default 2 m (wider corners save little time) nor below its
    5 cm minimum (:func:`validator.autopilot.rules.acceptance_radius_m`).
    """
    return acceptance_radius_m(site.buffer_m - fence_margin_m)


def radius_params(site: Site, autopilot: str, chosen_fence_margin_m: float | None = None
                  ) -> dict[str, float]:
    """The autopilot's acceptance-radius parameter (WPNAV_RADIUS in cm, NAV_ACC_RAD in m) at
    :func:`waypoint_radius_m`, in the autopilot's own units."""
    name = ACCEPTANCE_RADIUS_PARAM[autopilot]
    radius = waypoint_radius_m(site, fence_margin_m(site, chosen_fence_margin_m))
    return {name: round(param_table(autopilot)[name].from_si(radius), 6)}
