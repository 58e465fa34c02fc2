"""The exported plan read back as the vehicle receives it (every coordinate after MAVLink's
int32 1e-7° rounding) and interpreted by the validator's one resolver
(:func:`validator.flight.resolve_flight`): the legs it flies, one cycle's time at the
commanded speeds."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import NDArray

from validator.flight import resolve_flight
from validator.geodesy import round_e7
from validator.item_lists import GLOBAL_FRAMES
from validator.motion.ideal import ideal_leg_times
from validator.motion.limits import site_limits
from validator.motion.profile import make_profile
from validator.plan_format import MissionItem, Plan
from validator.site import Site


def _rounded(lat_deg: float, lon_deg: float) -> tuple[float, float]:
    return float(round_e7(lat_deg)), float(round_e7(lon_deg))


def as_received(plan: Plan) -> Plan:
    """``plan`` with the coordinates a vehicle stores as int32 1e-7° (MISSION_ITEM_INT x/y in
    a global frame: mission items, home, fence, rally and breach-return points) rounded so."""
    items = []
    for it in plan.items:
        p = list(it.params)
        if it.frame in GLOBAL_FRAMES and math.isfinite(p[4]) and math.isfinite(p[5]):
            p[4], p[5] = _rounded(p[4], p[5])
        items.append(MissionItem(it.command, p, it.frame, it.autocontinue))
    home = _rounded(plan.home_lat_deg, plan.home_lon_deg)
    circles = [dataclasses.replace(c, lat_deg=lat, lon_deg=lon) for c in plan.circles
               for lat, lon in [_rounded(c.lat_deg, c.lon_deg)]]
    polygons = [dataclasses.replace(g, vertices_deg=[_rounded(*v) for v in g.vertices_deg])
                for g in plan.polygons]
    rally = [(*_rounded(lat, lon), alt) for lat, lon, alt in plan.rally]
    back = plan.breach_return
    breach = None if back is None else (*_rounded(back[0], back[1]), back[2])
    return dataclasses.replace(plan, items=items, home_lat_deg=home[0], home_lon_deg=home[1],
                               circles=circles, polygons=polygons, rally=rally,
                               breach_return=breach)


def flown_legs(plan: Plan, site: Site, *, rounded: bool = True) -> NDArray[np.float64]:
    """Every straight leg the vehicle flies over ``site``, jumps repeated, as an (L, 2, 2)
    array of (start, end) points in metres; ``rounded``: the plan as the vehicle receives it."""
    path = resolve_flight(as_received(plan) if rounded else plan, site).path_xy_m
    return np.stack([path[:-1], path[1:]], axis=1)


def planned_cycle_s(plan: Plan, site: Site) -> float:
    """Duration (s) of one service cycle at the plan's own speeds and holds, every leg at its
    commanded speed throughout (the ``ideal`` profile's timing; an S-curve leg takes longer:
    see :func:`~mission_planner.mission.summary.cycle_duration_s`): the resolved flight's
    cycles (:class:`~validator.flight.CycleSpan`) over their number. NaN without a cycle."""
    flight = resolve_flight(plan, site)
    c = flight.cycle
    if c is None:
        return math.nan
    window = c.window_s(*ideal_leg_times(flight, make_profile("ideal", site_limits(site))))
    return math.nan if window is None else (window[1] - window[0]) / c.cycles
