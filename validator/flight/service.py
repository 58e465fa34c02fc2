"""The planner's metadata a plan carries (``Plan.extra`` under ``nfzMission``, format 1): its
slots, schedule, powers and where the service cycle sits among the items, and the wind it was
made for (``wind``, optional: :class:`validator.wind.WindModel`), read and checked against the
site.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from pydantic import ValidationError

from validator.channel import dbm_to_w
from validator.errors import InputError
from validator.flight.bounds import MAX_MISSION_S
from validator.site import MAX_DB, MAX_REACH_M, Site
from validator.wind import Wind, WindModel


@dataclass(frozen=True)
class ServicePlan:
    """The planner's metadata carried in the plan under ``nfzMission`` (format 1).

    Slot n (1..N) flies ``trajectory_m[n-1] -> trajectory_m[n]`` in ``delta_s[n-1]`` seconds,
    serving ground node ``schedule[n-1]`` (an index into the site's GNs, -1 for none) at
    ``power_w[n-1]``. ``cycle_items`` are 0-based item indices: the first item of the first
    service cycle and the NAV_WAYPOINT closing the last one; ``cycles`` cycles in between.
    """

    site_name: str
    scheme: str
    trajectory_m: NDArray[np.float64]  # (N+1, 2)
    delta_s: NDArray[np.float64]  # (N,)
    power_w: NDArray[np.float64]  # (N,)
    schedule: NDArray[np.int64]  # (N,), GN index or -1
    cycle_items: tuple[int, int]
    cycles: int
    wind: Wind | None = None  # the wind the plan was made for (absent: still air)

    @property
    def period_s(self) -> float:
        return float(np.sum(self.delta_s))

    @property
    def slots(self) -> int:
        return int(self.delta_s.size)


MAX_POWER_W = dbm_to_w(MAX_DB)  # the site's own bound on a radio's power (W)
_SERVICE_KEYS = {
    "format", "site", "scheme", "trajectory_m", "delta_s", "power_w", "schedule", "cycle_items",
    "cycles", "wind",
}


def _float_array(value: object, where: str, shape_hint: str) -> NDArray[np.float64]:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{where}: expected {shape_hint}") from None
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{where}: expected finite numbers")
    return arr


def parse_service(extra: object, site: Site, source: str = "plan") -> ServicePlan | None:
    """Validate the planner metadata of a plan (``Plan.extra``); None when absent.

    Raises :class:`InputError` naming the field when it is present but malformed, or names
    a ground node the site does not have.
    """
    if extra is None:
        return None
    where = f"{source}.nfzMission"
    if not isinstance(extra, dict):
        raise InputError(f"{where}: expected a JSON object")
    unknown = sorted(set(extra) - _SERVICE_KEYS)
    if unknown:
        raise InputError(f"{where}.{unknown[0]}: unknown key")
    missing = sorted(_SERVICE_KEYS - {"site", "scheme", "wind"} - set(extra))
    if missing:
        raise InputError(f"{where}.{missing[0]}: missing field")
    if extra["format"] != 1:
        raise InputError(f"{where}.format: expected 1, got {extra['format']!r}")
    traj = _float_array(extra["trajectory_m"], f"{where}.trajectory_m", "[[x, y], ...]")
    if traj.ndim != 2 or traj.shape[1] != 2 or traj.shape[0] < 2:
        raise InputError(f"{where}.trajectory_m: expected N+1 >= 2 points [x, y]")
    n = traj.shape[0] - 1
    delta = _float_array(extra["delta_s"], f"{where}.delta_s", f"{n} numbers")
    power = _float_array(extra["power_w"], f"{where}.power_w", f"{n} numbers")
    for name, arr in (("delta_s", delta), ("power_w", power)):
        if arr.shape != (n,):
            raise InputError(f"{where}.{name}: expected {n} numbers (one per slot), got {arr.size}")
    far = np.hypot(traj[:, 0], traj[:, 1]) > MAX_REACH_M
    if np.any(far):
        raise InputError(f"{where}.trajectory_m[{int(np.argmax(far))}]: beyond the "
                         f"{MAX_REACH_M / 1000:g} km a mission reaches from the site's origin")
    if np.any(delta <= 0):
        raise InputError(f"{where}.delta_s[{int(np.argmax(delta <= 0))}]: must be > 0")
    if float(np.sum(delta)) > MAX_MISSION_S:
        raise InputError(f"{where}.delta_s: a period of {float(np.sum(delta)):.3g} s, beyond a "
                         f"day ({MAX_MISSION_S:g} s)")
    if np.any(power < 0) or np.any(power > MAX_POWER_W):
        bad = int(np.argmax((power < 0) | (power > MAX_POWER_W)))
        raise InputError(f"{where}.power_w[{bad}]: must be within 0-{MAX_POWER_W:g} W")
    sched_raw = extra["schedule"]
    if not isinstance(sched_raw, list) or len(sched_raw) != n:
        raise InputError(f"{where}.schedule: expected {n} ground-node names or nulls")
    index = {name: k for k, name in enumerate(site.gn_names)}
    schedule = np.full(n, -1, dtype=np.int64)
    for i, name in enumerate(sched_raw):
        if name is None:
            continue
        if not isinstance(name, str) or name not in index:
            raise InputError(f"{where}.schedule[{i}]: ground node {name!r} is not in the site")
        schedule[i] = index[name]
    ci = extra["cycle_items"]
    if (
        not isinstance(ci, list)
        or len(ci) != 2
        or not all(isinstance(v, int) and not isinstance(v, bool) for v in ci)
        or not 0 <= ci[0] <= ci[1]
    ):
        raise InputError(f"{where}.cycle_items: expected [first, last] item indices, first <= last")
    cycles = extra["cycles"]
    if not isinstance(cycles, int) or isinstance(cycles, bool) or cycles < 1:
        raise InputError(f"{where}.cycles: expected an integer >= 1")
    return ServicePlan(
        site_name=str(extra.get("site", "")),
        scheme=str(extra.get("scheme", "")),
        trajectory_m=traj,
        delta_s=delta,
        power_w=power,
        schedule=schedule,
        cycle_items=(int(ci[0]), int(ci[1])),
        cycles=int(cycles),
        wind=_wind(extra.get("wind"), f"{where}.wind"),
    )


def _wind(value: object, where: str) -> Wind | None:
    """The ``wind`` a plan was made for (:class:`validator.wind.WindModel`), None if absent."""
    if value is None:
        return None
    try:
        return Wind.from_model(WindModel.model_validate(value))
    except ValidationError as err:
        e = err.errors()[0]
        loc = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in e["loc"])
        msg = "unknown key" if e["type"] == "extra_forbidden" else str(e["msg"])
        raise InputError(f"{where}{loc}: {msg}") from None

