"""The planner's entry point: options checked, then the paper's model (:mod:`.bcd`) or the
vehicle-aware search built on it (:mod:`.flyable`)."""

from __future__ import annotations

import time

from mission_planner.optimize.bcd import (
    DYNAMICS,
    START_SCHEDULES,
    WIND_PATHS,
    PlannerOptions,
    Progress,
    plan_paper,
)
from mission_planner.optimize.flyable import plan_flyable
from mission_planner.optimize.retime import MIN_HOLD_S
from mission_planner.optimize.solution import SCHEMES, Solution
from validator.errors import InputError
from validator.site import Site
from validator.wind import check_flyable


def plan(
    site: Site,
    scheme: str = "proposed",
    *,
    options: PlannerOptions | None = None,
    progress: Progress | None = None,
) -> Solution:
    """Optimise a service cycle for ``site`` with the ``proposed``, ``conventional`` or
    ``tangent`` zone rule (:data:`~.solution.SCHEMES`; polygons: every leg under proposed and
    tangent, waypoints under conventional).

    Deterministic: the same site and options give the same solution. In the site's wind
    (``site.wind``, at the flight altitude) the top speed holds in the air frame; a wind at or
    above the vehicle's top airspeed is refused (:class:`InputError`).
    """
    if scheme not in SCHEMES:
        raise InputError(f"scheme: expected one of {', '.join(SCHEMES)}, got {scheme!r}")
    opt = options or PlannerOptions()
    if opt.eta_scale not in ("per-period", "literal"):
        raise InputError(f"eta_scale: expected 'per-period' or 'literal', got {opt.eta_scale!r}")
    if opt.dynamics not in DYNAMICS:
        raise InputError(f"dynamics: expected one of {', '.join(DYNAMICS)}, got {opt.dynamics!r}")
    if not opt.start_schedules or set(opt.start_schedules) - set(START_SCHEDULES):
        raise InputError(f"start_schedules: expected some of {', '.join(START_SCHEDULES)}, "
                         f"got {opt.start_schedules!r}")
    if not opt.wind_paths or set(opt.wind_paths) - set(WIND_PATHS):
        raise InputError(f"wind_paths: expected some of {', '.join(WIND_PATHS)}, "
                         f"got {opt.wind_paths!r}")
    if site.slots < site.num_gns:  # (9)-(10): one node per slot; a node without one gets 0
        raise InputError(f"uav.slots: {site.slots} slot(s) for {site.num_gns} ground nodes: "
                         f"the schedule serves one node per slot, so the min rate would be 0; "
                         f"give at least {site.num_gns}")
    wind = site.flight_wind
    if wind is not None:  # a wind the vehicle cannot fly against has no plan
        from validator.motion.speed_model import check_wind_flyable

        if opt.dynamics == "none":
            check_flyable(site.max_speed_mps, wind, "wind")
        else:
            check_wind_flyable(site, opt.autopilot)
    if opt.dynamics != "none" and site.period_s < MIN_HOLD_S:
        # Even a cycle that never leaves its first waypoint holds there this long, so no
        # speed fits and the search would have no overrun to slow down by.
        raise InputError(f"uav.period: {site.period_s:g} s is shorter than the {MIN_HOLD_S:g} s "
                         f"the vehicle holds at a waypoint at least; give at least "
                         f"{MIN_HOLD_S:g} s")
    started = time.perf_counter()
    if opt.dynamics == "none":
        return plan_paper(site, scheme, opt, progress, started)
    return plan_flyable(site, scheme, opt, progress, started)
