"""Planning among UAS zones that change with time: the zones of the mission's own window.

A zone applies when it is active at any instant of [at, at + the mission's duration], and the
duration is known only once the mission is planned and replayed. :func:`plan_for_time` decides
the zones for an estimate (:func:`duration_estimate_s`), plans, and takes the replayed
duration: when the mission flies longer than the window it was planned for and that longer
window takes other zones, it plans again for it (a bounded number of times, each window longer
than the last, so it ends); where it takes the same zones the plan stands, and
:func:`with_airspace` makes its report name the longer window.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TypeVar

import numpy as np

from mission_planner.mission import Mission
from validator.errors import InputError
from validator.site import Site, load_site
from validator.site_airspace import SiteAirspace
from validator.uas_zones.applicability import AirspaceOptions

T = TypeVar("T")
MAX_REPLANS = 3
WINDOW_MARGIN = 1.10  # a window replanned for is the flown duration plus this share
TAKE_OFF_AND_LANDING_S = 60.0  # climb, descent and settling, beyond the legs


def duration_estimate_s(site: Site, cycles: int) -> float:
    """The mission's duration before it is planned (s): ``cycles`` service periods, the way
    out to the farthest node and back at top speed, and a minute for take-off and landing."""
    far_m = float(np.max(np.linalg.norm(site.gn_xy_m - site.home_xy_m, axis=1)))
    return cycles * site.period_s + 2.0 * far_m / site.max_speed_mps + TAKE_OFF_AND_LANDING_S


def plan_for_time(site_path: str | Path, options: AirspaceOptions, cycles: int,
                  plan: Callable[[Site], T], duration_s: Callable[[T], float],
                  buffer_m: float | None = None) -> tuple[Site, T]:
    """The site decided for the mission's window and what ``plan`` made of it.

    ``plan`` plans a site; ``duration_s`` gives the flown duration of what it made (the
    replay's). Without a time (``options.at`` None) every zone is active and one plan is made.
    ``buffer_m`` overrides the site's safety buffer.
    """
    def load(duration: float) -> Site:
        site = load_site(site_path, replace(options, duration_s=duration, buffer_m=buffer_m))
        return site if buffer_m is None else site.with_buffer(buffer_m)

    site = load(0.0)
    if options.at is None or not site.airspace.uas:
        return site, plan(site)
    window = duration_estimate_s(site, cycles)
    site = load(window)
    for _ in range(MAX_REPLANS):
        made = plan(site)
        flown = duration_s(made)
        if flown <= window:
            return site, made
        window = max(flown * WINDOW_MARGIN, window * WINDOW_MARGIN)
        longer = load(window)
        if longer.zone_names == site.zone_names:
            return longer, made
        site = longer
    raise InputError(f"--at: the mission kept flying longer than the window it was planned for "
                     f"({window:.0f} s) and meeting other zones; plan fewer --cycles")


def with_airspace(mission: Mission, airspace: SiteAirspace) -> Mission:
    """``mission`` with ``airspace`` as its site's zone decision: the same zones, decided over
    the longer window :func:`plan_for_time` settled on, which the mission's report then names
    (it named the window the plan was first made for, shorter than the replayed mission)."""
    site = replace(mission.solution.site, airspace=airspace)
    return replace(mission, solution=replace(mission.solution, site=site))
