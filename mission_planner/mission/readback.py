"""The exported plan read back as the vehicle receives it: positions after int32 rounding, the
legs it flies, one cycle's time at the commanded speeds."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from validator.geodesy import LocalFrame, round_e7
from validator.plan_format import Cmd, Plan

NAV_POSITION_COMMANDS = (Cmd.NAV_TAKEOFF, Cmd.NAV_WAYPOINT, Cmd.NAV_LAND)


def nav_positions(plan: Plan, frame: LocalFrame, *, rounded: bool = True
                  ) -> tuple[list[int], NDArray[np.float64]]:
    """Item indices and local positions (m) of every positional mission item, in item order.

    ``rounded`` first puts the coordinates through MAVLink's int32 1e-7° representation.
    """
    idx = [i for i, it in enumerate(plan.items) if it.command in NAV_POSITION_COMMANDS]
    lat = np.array([plan.items[i].lat_deg for i in idx])
    lon = np.array([plan.items[i].lon_deg for i in idx])
    if rounded:
        lat, lon = round_e7(lat), round_e7(lon)
    return idx, frame.to_local(lat, lon).reshape(-1, 2)


def flown_legs(plan: Plan, frame: LocalFrame, cycle_items: tuple[int, int] | None = None, *,
               rounded: bool = True) -> tuple[list[tuple[int, int]], NDArray[np.float64]]:
    """Every straight leg the vehicle flies: consecutive positional items, plus, when the plan
    repeats its cycle with DO_JUMP, the leg from the cycle's last waypoint back to its first
    position. Returns (from item, to item) pairs and the legs as an (L, 2, 2) array in metres.
    """
    idx, xy = nav_positions(plan, frame, rounded=rounded)
    pairs = list(zip(idx[:-1], idx[1:], strict=True))
    legs = [np.array([xy[k], xy[k + 1]]) for k in range(len(idx) - 1)]
    has_jump = any(it.command == Cmd.DO_JUMP for it in plan.items)
    if cycle_items is not None and has_jump:
        first, last = cycle_items
        targets = [k for k, i in enumerate(idx) if i >= first]
        if targets and last in idx:
            k0, k1 = targets[0], idx.index(last)
            pairs.append((last, idx[k0]))
            legs.append(np.array([xy[k1], xy[k0]]))
    return pairs, np.array(legs).reshape(-1, 2, 2)


def planned_cycle_s(plan: Plan, frame: LocalFrame, cycle_items: tuple[int, int]) -> float:
    """Duration (s) of one service cycle at the plan's own speeds and holds, every leg at its
    commanded speed throughout (an S-curve leg takes longer: see :func:`cycle_duration_s`).

    Walks items ``first..last``: each positional item adds the leg from the previous position
    at the speed in force (the last DO_CHANGE_SPEED before it) plus its hold (param1). The
    cycle starts at the position before its first item (the end of the outbound transit).
    """
    first, last = cycle_items
    speed = math.nan
    pos: NDArray[np.float64] | None = None
    for it in plan.items[:first]:
        if it.command == Cmd.DO_CHANGE_SPEED:
            speed = it.params[1]
        elif it.command in NAV_POSITION_COMMANDS:
            pos = frame.to_local(it.lat_deg, it.lon_deg)
    total = 0.0
    for it in plan.items[first:last + 1]:
        if it.command == Cmd.DO_CHANGE_SPEED:
            speed = it.params[1]
        elif it.command in NAV_POSITION_COMMANDS:
            here = frame.to_local(it.lat_deg, it.lon_deg)
            length = float(np.hypot(*(here - pos))) if pos is not None else 0.0
            if length > 0:
                total += length / speed
            total += it.params[0] if it.command == Cmd.NAV_WAYPOINT else 0.0
            pos = here
    return total
