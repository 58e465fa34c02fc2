"""Small hand-made sites and plans for the validator tests (local metres in, .plan out)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from validator.item_numbers import item_number
from validator.plan_format import Cmd, FenceCircle, Frame, MissionItem, Plan
from validator.site import Site, parse_site

ALT_M = 30.0


def make_site(
    nfz: Sequence[tuple[float, float, float]] = ((100.0, 0.0, 20.0),),
    gns: Sequence[tuple[float, float]] = ((0.0, 50.0), (200.0, 50.0)),
    *,
    max_speed: float = 10.0,
    buffer_m: float = 2.0,
    **uav: Any,
) -> Site:
    """A site at a fixed origin; ``nfz`` as (x, y, radius) metres, ``gns`` as (x, y)."""
    data = {
        "name": "test-site",
        "origin": {"lat": 37.5585, "lon": 126.999, "alt": 40.0},
        "uav": {"altitude": ALT_M, "max_speed": max_speed, "period": 60.0, "slots": 10, **uav},
        "radio": {"p_avg_dbm": 20.0, "p_peak_dbm": 26.0206, "beta0_db": -30.0,
                  "noise_dbm": -70.0},
        "ground_nodes": [{"name": f"GN{i + 1}", "x": x, "y": y} for i, (x, y) in enumerate(gns)],
        "no_fly_zones": [{"name": f"NFZ{i + 1}", "x": x, "y": y, "radius": r}
                         for i, (x, y, r) in enumerate(nfz)],
        "safety": {"buffer_m": buffer_m},
    }
    return parse_site(data, "test-site")


def nav(site: Site, cmd: int, xy: ArrayLike, alt: float = ALT_M, p1: float = 0.0) -> MissionItem:
    lat, lon = site.frame.to_geodetic(np.asarray(xy, dtype=float))
    return MissionItem(int(cmd), [p1, 0.0, 0.0, float("nan"), float(lat), float(lon), alt],
                       int(Frame.GLOBAL_RELATIVE_ALT))


def speed(v: float) -> MissionItem:
    return MissionItem(int(Cmd.DO_CHANGE_SPEED), [1.0, v, -1.0, 0, 0, 0, 0], int(Frame.MISSION))


def jump(target_item: int, repeats: int) -> MissionItem:
    return MissionItem(int(Cmd.DO_JUMP),
                       [float(item_number(target_item)), float(repeats), 0, 0, 0, 0, 0],
                       int(Frame.MISSION))


def fence_for(site: Site, margin_m: float = 0.0) -> list[FenceCircle]:
    out = []
    for (x, y), r in zip(site.nfz_xy_m, site.nfz_radius_m, strict=True):
        lat, lon = site.frame.to_geodetic(np.array([x, y]))
        out.append(FenceCircle(float(lat), float(lon), float(r + margin_m), inclusion=False))
    return out


def plan_of(site: Site, items: list[MissionItem], *, fence: bool = True,
            extra: dict[str, Any] | None = None,
            rally: Sequence[tuple[float, float]] = ()) -> Plan:
    lat, lon = site.frame.to_geodetic(site.home_xy_m)
    rally_pts = []
    for xy in rally:
        rl, rn = site.frame.to_geodetic(np.asarray(xy, dtype=float))
        rally_pts.append((float(rl), float(rn), ALT_M))
    return Plan(items=items, home_lat_deg=float(lat), home_lon_deg=float(lon),
                home_alt_m=site.frame.alt0_m, circles=fence_for(site) if fence else [],
                rally=rally_pts, extra=extra)


def waypoint_plan(site: Site, points: Sequence[tuple[float, float]], *, v: float = 5.0,
                  end: str = "land", **kw: Any) -> Plan:
    """Takeoff at home, DO_CHANGE_SPEED v, a waypoint at each point, then LAND at home or RTL."""
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(v)]
    items += [nav(site, Cmd.NAV_WAYPOINT, p) for p in points]
    if end == "land":
        items.append(nav(site, Cmd.NAV_LAND, site.home_xy_m, 0.0))
    elif end == "rtl":
        items.append(MissionItem(int(Cmd.NAV_RETURN_TO_LAUNCH), [0.0] * 7, int(Frame.MISSION)))
    return plan_of(site, items, **kw)


def service_plan(
    site: Site,
    q: ArrayLike,
    delta_s: ArrayLike,
    power_w: ArrayLike,
    schedule: Sequence[str | None],
    *,
    cycles: int = 1,
    transit_speed: float = 5.0,
) -> Plan:
    """A plan laid out like the exporter's: takeoff, transit to q[0], one waypoint per moving
    slot with DO_CHANGE_SPEED (length / δ), stationary slots merged into holds, DO_JUMP for
    the other cycles, transit home and LAND; with the nfzMission metadata."""
    q = np.asarray(q, dtype=float)
    delta = np.asarray(delta_s, dtype=float)
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(transit_speed),
             nav(site, Cmd.NAV_WAYPOINT, q[0])]
    first = len(items)
    lead = 0.0
    n = 1
    while n < len(q) and np.hypot(*(q[n] - q[0])) < 1e-6:
        lead += delta[n - 1]
        n += 1
    if lead:
        items.append(nav(site, Cmd.NAV_WAYPOINT, q[0], p1=lead))
    while n < len(q):
        length = float(np.hypot(*(q[n] - q[n - 1])))
        hold = 0.0
        m = n + 1
        while m < len(q) and np.hypot(*(q[m] - q[n])) < 1e-6:
            hold += delta[m - 1]
            m += 1
        items.append(speed(length / delta[n - 1]))
        items.append(nav(site, Cmd.NAV_WAYPOINT, q[n], p1=hold))
        n = m
    closing = len(items) - 1
    if cycles > 1:
        items.append(jump(first, cycles - 1))
    items.append(speed(transit_speed))
    items.append(nav(site, Cmd.NAV_LAND, site.home_xy_m, 0.0))
    extra = {
        "format": 1, "site": site.name, "scheme": "proposed", "trajectory_m": q.tolist(),
        "delta_s": delta.tolist(), "power_w": np.asarray(power_w, dtype=float).tolist(),
        "schedule": list(schedule), "cycle_items": [first, closing], "cycles": cycles,
    }
    return plan_of(site, items, extra=extra)
