"""Where a vehicle that loses its position (GPS) can end up: the position-loss path from
every point of the mission, measured against every zone and its buffer. ArduCopter's coast is
described here; PX4's, the same shape with its own figures and a drift off the path before its
failsafe fires, in :mod:`validator.coast_rules` (where both autopilots' figures live).

No failsafe action steers a vehicle that does not know where it is. ArduCopter 4.5.6 flies on
in AUTO on its inertial estimate until EKF3 gives up on position aiding (``posRetryTimeNoVel_ms``
7000, a constant of AP_NavEKF3.h, no parameter) and ``ekf_check`` has seen it for 10 checks
at 10 Hz: the EKF failsafe then fires (FS_EKF_THRESH plays no part: it is the lost position,
not the variances, that fails the check). Its action, Land (FS_EKF_ACTION 1) or AltHold, levels
the vehicle without a position: it coasts on along its ground velocity while it descends, and
wanders as its unaided attitude drifts. Measured on ArduCopter 4.5.6 SITL (``validate-mission
--fault gps-loss``, report ``fault.coast``; 30 m mission altitude, Land's 4 s pause and
descent ~42 s):

======== ========== ======== =========
speed    delay      along    across
======== ========== ======== =========
10.2 m/s 8.1-8.2 s  30.0 m   7.4-7.8 m
5.3 m/s  8.1 s      21.3 m   7.7 m
1.9 m/s  8.1 s      -1.1 m   -9.5 m
======== ========== ======== =========

The model, fitted to cover every measurement: the vehicle carries on along the mission for
:data:`DETECTION_DELAY_S` (still on the mission's path, which the mission audit covers), then
ends within :data:`WANDER_M` of the point :data:`COAST_S` times its speed ahead along its
velocity; the path there stays within the convex hull of that disc and the point where the
failsafe fired. Over a leg the failsafe may fire anywhere, so the region is the hull of the
leg and the discs ahead of its two ends; at a corner the velocity turns from one leg to the
next, so the discs ahead of the corner sweep between the two directions.

**In wind** the levelled vehicle moves with the air for the whole landing: its pause, the
descent to LAND_ALT_LOW and the slow final metres
(:func:`~validator.autopilot.rules.failsafe_land_s`, 41.8 s from 30 m). Measured on the same
SITL (``--fault gps-loss --wind``, 30 m; report ``fault``,
``tests/data/failsafe/gps-loss-wind.json``): 146 m downwind in 4 m/s, 239 m in
6 m/s, 318 m in 8 m/s with 2 m/s turbulence, each over a 41-42 s landing. So the region is
swept downwind by the flight wind times that landing (:func:`drift_xy_m`; 167, 251 and 334 m
there). No buffer keeps such a drift clear and no leg speed shortens it, so the berth plans
against the still-air coast (``audit_position_loss(..., drift=False)``), and the drift is a
warning that names the wind, how far, and the zones.

**Dead reckoning** (EKF3 drag fusion: any of EK3_DRAG_BCOEF_X/Y, EK3_DRAG_MCOEF above 0, a
vehicle's own calibration) changes who acts but not how far it goes. EKF3 then keeps a
position from the drag and its wind estimate (``posRetryTimeUseVel_ms`` 10000: the failsafe
fires after 10.3-10.5 s), the dead-reckoning failsafe (FS_DR_ENABLE, ours Land) lands on that
estimate, and the estimate's error carries the vehicle instead of the wind. On the same SITL
in 6 m/s from 270° with turbulence 1 (``tests/data/failsafe/gps-loss-dead-reckoning.json``,
the simulator's suggested coefficients and ArduPilot's autotest's, FS_DR_TIMEOUT 60) it slid
84, 89 and 114 m *upwind* over a 41-42 s landing, the last (aimed here) 17.5 m into NFZ1,
where the free drift of the model ran 251 m downwind. So with drag fusion the still-air
region is swept by the drift's length in every direction (:func:`dead_reckons`): the
estimate's error taken as no faster than the wind (flown: a third to a half of its drift).

The region is judged against the zones themselves, not their buffers: the buffer is the
margin of the planned path, and the coast is what the vehicle does when that path is lost
(the model already holds the measured worst case). The speed of a leg is one rule
(:func:`position_loss_speed_cap_mps`): the fastest speed whose coast region stays out of every
zone; the wander alone (a vehicle losing its position while hovering) is no speed's doing,
and a leg whose wander reaches a zone is reported as needing a wider berth. The berth is one
rule too (:func:`berth_buffer_m`): the buffer a plan must keep for the deepest coast to stay
out; the planner plans again with it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from validator.autopilot.rules import default_speed_mps, failsafe_land_s, px4_descend_s
from validator.coast_rules import (
    ARDUCOPTER,
    ARDUCOPTER_DEAD_RECKONING_DELAY_S,
    CoastRule,
    coast_rule,
)
from validator.flight import Flight, Leg
from validator.geometry import segment_point_distance
from validator.item_numbers import item_label, item_number
from validator.site import Site
from validator.zones import point_clearance_m, polyline_clearance_m

# ArduCopter's figures (validator.coast_rules), by the names the model's tests know them by
DETECTION_DELAY_S = ARDUCOPTER.delay_s
DEAD_RECKONING_DELAY_S = ARDUCOPTER_DEAD_RECKONING_DELAY_S
COAST_S = ARDUCOPTER.coast_s
WANDER_M = ARDUCOPTER.wander_m
CORNER_STEPS = 8  # directions sampled between two legs' at a corner
MIN_SPEED_MPS = 1.0  # a cap below this is no cap: the leg needs a wider berth instead
BERTH_MARGIN_M = 0.5  # a wider berth clears the deepest coast by this much (m)


@dataclass(frozen=True)
class PositionLossFinding:
    """A leg from which a position loss may coast into a zone: the least clearance of its
    region at the leg's speed (negative), the site's buffer, the speed that would keep the
    zone out of reach (None: none does), and how far (m) the wind drifts the vehicle during
    the failsafe's landing (0 in still air)."""

    zone: str
    leg: int
    item: int
    speed_mps: float
    clearance_m: float
    buffer_m: float
    speed_cap_mps: float | None
    drift_m: float = 0.0
    dead_reckoning: bool = False  # the drift is the dead-reckoned estimate's, in any direction
    autopilot: str = "ardupilot"  # whose coast (validator.coast_rules)

    @property
    def message(self) -> str:
        rule = coast_rule(self.autopilot)
        reach = rule.reach_m
        where = f"may enter {self.zone} {-self.clearance_m:.2f} m deep"
        if self.speed_cap_mps is not None:
            fix = f"at most {self.speed_cap_mps:.1f} m/s on this leg keeps it out"
        elif self.drift_m > reach:
            descent = "MPC_LAND_SPEED" if self.autopilot == "px4" else "LAND_SPEED_HIGH"
            fix = ("no speed keeps it out (the drift alone reaches it; a lower altitude or "
                   f"a faster {descent} shortens it)")
        else:
            fix = (f"no speed keeps it out (the {reach:g} m wander alone reaches it): the "
                   f"leg needs a wider berth (a site buffer over the {reach:g} m wander)")
        if self.dead_reckoning:
            after = "the dead-reckoning failsafe (Land on EKF3's drag-fused estimate)"
            drift = (f", sliding up to {self.drift_m:.0f} m any way as it lands,"
                     if self.drift_m > 0 else "")
        else:
            after = rule.action.replace("ArduCopter's ", "the ")
            drift = f", drifting {self.drift_m:.0f} m as it lands," if self.drift_m > 0 else ""
        return (f"GPS loss: from the leg to {item_label(self.item)} at {self.speed_mps:.1f} m/s "
                f"the coast after {after}{drift} {where}; {fix}")

    def as_dict(self) -> dict[str, Any]:
        return {"zone": self.zone, "leg": self.leg, "item": item_number(self.item),
                "speed_mps": self.speed_mps, "clearance_m": self.clearance_m,
                "buffer_m": self.buffer_m, "speed_cap_mps": self.speed_cap_mps,
                "drift_m": self.drift_m, "dead_reckoning": self.dead_reckoning,
                "autopilot": self.autopilot, "message": self.message}


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64] | None:
    n = float(np.hypot(*v))
    return None if n < 1e-9 else v / n


def _disc(p: NDArray[np.float64], radius_m: float = WANDER_M) -> shapely.Geometry:
    return shapely.Point(p).buffer(radius_m, quad_segs=16)


def drift_xy_m(site: Site, altitude_m: float, params: Mapping[str, float] | None,
               autopilot: str = "ardupilot") -> NDArray[np.float64]:
    """How far (east, north m) the wind carries a vehicle without a position from the
    failsafe, ``altitude_m`` above home, to touchdown: the site's flight wind (the layer at
    the flight altitude) times :func:`~validator.autopilot.rules.failsafe_land_s` at the
    parameters ``params``; zero in still air. Levelled without a position, the vehicle soon
    moves with the air: measured 146 m in 4 m/s and 239 m in 6 m/s over a 41.8 s landing
    (167 and 251 m here: it takes a few seconds to reach the wind's speed). PX4 (``autopilot``)
    descends for :func:`~validator.autopilot.rules.px4_descend_s` instead, levelled the same
    way (not flown in wind: the same physics assumed)."""
    wind = site.flight_wind
    if wind is None:
        return np.zeros(2)
    landing_s = (px4_descend_s(altitude_m, params) if autopilot == "px4"
                 else failsafe_land_s(altitude_m, params))
    return np.asarray(wind.vector_mps * landing_s, dtype=float)


def dead_reckons(params: Mapping[str, float] | None, autopilot: str = "ardupilot") -> bool:
    """Whether ArduCopter at ``params`` dead reckons through a GPS loss: EKF3 fuses drag (any
    of EK3_DRAG_BCOEF_X, EK3_DRAG_BCOEF_Y, EK3_DRAG_MCOEF above 0; all 0 by default). PX4's
    coast (``autopilot``) is modelled without EKF2's drag fusion (EKF2_DRAG_CTRL, off)."""
    return autopilot != "px4" and any(float((params or {}).get(name, 0.0)) > 0.0
               for name in ("EK3_DRAG_BCOEF_X", "EK3_DRAG_BCOEF_Y", "EK3_DRAG_MCOEF"))


def coasting_failsafe(autopilot: str, params: Mapping[str, float] | None) -> str:
    """The parameter of the failsafe that acts after a GPS loss: ArduCopter's EKF failsafe
    (FS_EKF_ACTION), or with drag fusion the dead-reckoning one (FS_DR_ENABLE,
    :func:`dead_reckons`); PX4's navigation loss (COM_POSCTL_NAVL's row: its fallback chain
    ends in Descend, :mod:`validator.coast_rules`)."""
    if autopilot == "px4":
        return coast_rule("px4").failsafe
    return "FS_DR_ENABLE" if dead_reckons(params) else "FS_EKF_ACTION"


def coast_region(start: NDArray[np.float64], end: NDArray[np.float64], speed_mps: float,
                 next_end: NDArray[np.float64] | None = None,
                 drift_m: NDArray[np.float64] | None = None,
                 any_direction: bool = False, rule: CoastRule = ARDUCOPTER) -> shapely.Geometry:
    """Where a position loss on the leg start→end, flown at ``speed_mps``, can take the
    vehicle under ``rule`` (its coast and wander, and the whole region widened by its drift
    off the path before the failsafe: PX4's); with ``next_end``, the corner at ``end`` into
    the next leg too; with
    ``drift_m`` (east, north m, :func:`drift_xy_m`), swept that far downwind (each convex
    part with its copy moved by the drift: their hull is the sum with the drift's segment),
    or with ``any_direction`` (a dead-reckoning vehicle, :func:`dead_reckons`) its length
    in every direction."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    u = _unit(end - start)
    reach = rule.coast_s * speed_mps
    w = rule.wander_m
    if u is None:  # a vertical leg: it hovers, the wander only
        parts = [shapely.convex_hull(shapely.union(_disc(end, w), shapely.Point(start)))]
    else:
        parts = [shapely.convex_hull(shapely.union_all(
            [shapely.MultiPoint([start, end]), _disc(start + reach * u, w),
             _disc(end + reach * u, w)]))]
        nxt = None if next_end is None else _unit(np.asarray(next_end, float) - end)
        if nxt is not None:
            a0, a1 = math.atan2(u[1], u[0]), math.atan2(nxt[1], nxt[0])
            turn = (a1 - a0 + math.pi) % (2 * math.pi) - math.pi
            fan = [shapely.Point(end)] + [
                _disc(end + reach * np.array([math.cos(a0 + turn * k / CORNER_STEPS),
                                              math.sin(a0 + turn * k / CORNER_STEPS)]), w)
                for k in range(CORNER_STEPS + 1)]
            parts.append(shapely.convex_hull(shapely.union_all(fan)))
    if drift_m is not None and any_direction and float(np.hypot(*drift_m)) > 0.0:
        reach_m = float(np.hypot(*drift_m))
        parts = [shapely.buffer(part, reach_m, quad_segs=16) for part in parts]
    elif drift_m is not None and float(np.hypot(*drift_m)) > 0.0:
        dx, dy = float(drift_m[0]), float(drift_m[1])
        parts = [shapely.convex_hull(shapely.union(
            part, shapely.transform(part, lambda xy: xy + (dx, dy)))) for part in parts]
    if rule.offpath_m > 0.0:
        parts = [shapely.buffer(part, rule.offpath_m, quad_segs=16) for part in parts]
    return shapely.union_all(parts)


def region_clearances(site: Site, region: shapely.Geometry) -> NDArray[np.float64]:
    """Signed clearance of ``region`` from every zone (``Site.zone_names`` order; negative:
    how deep, for a polygon the depth of the region's boundary inside it)."""
    out = []
    for c, r in zip(site.nfz_xy_m, site.nfz_radius_m, strict=True):
        d = float(shapely.distance(shapely.Point(c), region)) - float(r)
        if d <= -float(r):  # the centre inside the region: as deep as the far side
            d = -float(r)
        out.append(d)
    ring = np.asarray(shapely.get_coordinates(shapely.boundary(region)), dtype=float)
    for z in site.polygon_zones:
        d = float(shapely.distance(z.shape, region))
        out.append(d if d > 0 else min(0.0, polyline_clearance_m(z, ring)[0]))
    return np.array(out, dtype=float)


def _leg_speed_mps(leg: Leg, default_speed_mps: float) -> float:
    """The leg's commanded speed, else the autopilot's WPNAV_SPEED or MPC_XY_CRUISE
    (``default_speed_mps``)."""
    return leg.speed_mps if leg.speed_mps is not None else default_speed_mps


def _leg_region(flight: Flight, k: int, speed_mps: float,
                drift_m: NDArray[np.float64] | None = None,
                any_direction: bool = False, rule: CoastRule = ARDUCOPTER) -> shapely.Geometry:
    leg = flight.legs[k]
    nxt = flight.legs[k + 1].end_xy_m if k + 1 < len(flight.legs) and leg.pass_through else None
    return coast_region(leg.start_xy_m, leg.end_xy_m, speed_mps, nxt, drift_m, any_direction,
                        rule)


def _leg_drift_m(flight: Flight, k: int, site: Site, params: Mapping[str, float] | None,
                 autopilot: str = "ardupilot") -> NDArray[np.float64]:
    leg = flight.legs[k]
    return drift_xy_m(site, max(leg.start_alt_m, leg.end_alt_m), params, autopilot)


def position_loss_speed_cap_mps(flight: Flight, k: int, site: Site, speed_mps: float,
                                drift_m: NDArray[np.float64] | None = None,
                                any_direction: bool = False, rule: CoastRule = ARDUCOPTER
                                ) -> float | None:
    """The fastest speed, up to ``speed_mps``, at which a position loss on leg ``k`` (drifting
    ``drift_m`` while it lands, in ``any_direction`` when it dead reckons: :func:`coast_region`)
    stays out of every zone (to 0.1 m/s); None when none at or
    above :data:`MIN_SPEED_MPS` does (the wander, or the drift, alone reaches a zone). The
    one speed rule of position loss: the exporter writes it, the audit checks it."""
    def clear(v: float) -> bool:
        return not site.zone_names or bool(np.all(
            region_clearances(site, _leg_region(flight, k, v, drift_m, any_direction, rule))
            >= 0.0))

    if clear(speed_mps):
        return speed_mps
    if not clear(MIN_SPEED_MPS):
        return None
    lo, hi = MIN_SPEED_MPS, speed_mps
    while hi - lo > 0.05:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if clear(mid) else (lo, mid)
    return math.floor(lo * 10) / 10


def audit_position_loss(flight: Flight, site: Site, params: Mapping[str, float] | None, *,
                        drift: bool = True, autopilot: str = "ardupilot"
                        ) -> list[PositionLossFinding]:
    """Every leg whose position-loss region enters a zone, at the parameters ``params`` of
    ``autopilot`` (its coast: :mod:`validator.coast_rules`; a leg without a commanded speed
    flies WPNAV_SPEED or MPC_XY_CRUISE; the landing's length sets the drift). ``drift``: in
    the site's wind, the region drifts downwind for the whole failsafe landing
    (:func:`drift_xy_m`); without it, the coast as in still air (what a wider buffer can keep
    clear: :func:`berth_buffer_m`). A vehicle that dead reckons
    (:func:`dead_reckons`) may slide the drift's length any way instead."""
    out: list[PositionLossFinding] = []
    if not site.zone_names:
        return out
    rule = coast_rule(autopilot)
    default = default_speed_mps(params, autopilot)
    reckons = dead_reckons(params, autopilot)
    for k, leg in enumerate(flight.legs):
        v = _leg_speed_mps(leg, default)
        d = _leg_drift_m(flight, k, site, params, autopilot) if drift else None
        clr = region_clearances(site, _leg_region(flight, k, v, d, reckons, rule))
        bad = [m for m in range(len(clr)) if clr[m] < 0.0]
        if not bad:
            continue
        cap = position_loss_speed_cap_mps(flight, k, site, v, d, reckons, rule)
        drift_m = 0.0 if d is None else float(np.hypot(*d))
        for m in bad:
            out.append(PositionLossFinding(site.zone_names[m], k, leg.item, v, float(clr[m]),
                                           site.buffer_m, cap, drift_m, reckons, autopilot))
    return out


def _sampled_leg_clearance_m(site: Site, start: NDArray[np.float64], end: NDArray[np.float64],
                             speed_mps: float, step_m: float, drift_m: NDArray[np.float64],
                             any_direction: bool = False, rule: CoastRule = ARDUCOPTER
                             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Points every ``step_m`` along a leg and, for each, the least clearance (m) from any zone
    of the coast's wander disc (``rule``'s, widened by its drift off the path) ahead of it,
    carried ``drift_m`` downwind, or its length any way (``any_direction``) (negative: how
    deep)."""
    wander_m = rule.reach_m
    u = _unit(end - start)
    n = max(2, int(math.ceil(float(np.hypot(*(end - start))) / step_m)) + 1)
    pts = start + np.linspace(0.0, 1.0, n)[:, None] * (end - start)
    centres = pts + (rule.coast_s * speed_mps * u if u is not None else 0.0)
    if any_direction:
        reach_m = wander_m + float(np.hypot(*drift_m))
        clr = np.full(n, np.inf)
        for c, r in zip(site.nfz_xy_m, site.nfz_radius_m, strict=True):
            clr = np.minimum(clr, np.hypot(*(centres - c).T) - float(r) - reach_m)
        for z in site.polygon_zones:
            clr = np.minimum(clr, point_clearance_m(z, centres) - reach_m)
        return pts, clr
    drifted = centres + drift_m
    clr = np.full(n, np.inf)
    for c, r in zip(site.nfz_xy_m, site.nfz_radius_m, strict=True):
        clr = np.minimum(clr, segment_point_distance(centres, drifted, c) - float(r) - wander_m)
    steps = max(1, int(math.ceil(float(np.hypot(*drift_m)) / step_m)))
    for z in site.polygon_zones:
        for t in np.linspace(0.0, 1.0, steps + 1):
            clr = np.minimum(clr, point_clearance_m(z, centres + t * drift_m) - wander_m)
    return pts, clr


def worst_position_loss_point(flight: Flight, site: Site, params: Mapping[str, float] | None,
                              step_m: float = 1.0, autopilot: str = "ardupilot"
                              ) -> tuple[NDArray[np.float64], float] | None:
    """Where to lose the position for the coast of ``autopilot`` (drifting downwind in the
    site's wind while it lands) to come closest to a zone, and that least clearance (m) of the
    wander disc: the failsafe fires its rule's delay after the loss (ArduCopter's
    :data:`DETECTION_DELAY_S`, a dead-reckoning one :data:`DEAD_RECKONING_DELAY_S`), so the
    point is that much flying (and holding) before the worst place for the coast to start,
    along the mission's legs. None without a zone or a horizontal leg."""
    if not site.zone_names:
        return None
    rule = coast_rule(autopilot)
    default = default_speed_mps(params, autopilot)
    reckons = dead_reckons(params, autopilot)
    best: tuple[float, int, NDArray[np.float64]] | None = None
    for k, leg in enumerate(flight.legs):
        if leg.length_m < 1e-6:
            continue
        v = _leg_speed_mps(leg, default)
        pts, clr = _sampled_leg_clearance_m(
            site, leg.start_xy_m, leg.end_xy_m, v, step_m,
            _leg_drift_m(flight, k, site, params, autopilot), reckons, rule)
        i = int(np.argmin(clr))
        if best is None or clr[i] < best[0]:
            best = (float(clr[i]), k, pts[i])
    if best is None:
        return None
    clearance, k, p = best
    left_s = DEAD_RECKONING_DELAY_S if reckons else rule.delay_s
    while True:
        leg = flight.legs[k]
        v = _leg_speed_mps(leg, default)
        back = leg.start_xy_m - p
        flown_s = float(np.hypot(*back)) / max(v, 1e-9)
        if flown_s >= left_s:
            return p + back * (left_s / flown_s), clearance
        left_s -= flown_s
        if k == 0:
            return np.asarray(leg.start_xy_m, dtype=float), clearance
        k -= 1
        left_s -= flight.legs[k].hold_s
        p = np.asarray(flight.legs[k].end_xy_m, dtype=float)
        if left_s <= 0.0:
            return p, clearance


def berth_buffer_m(buffer_m: float, findings: list[PositionLossFinding] |
                   tuple[PositionLossFinding, ...]) -> float | None:
    """The next safety buffer (m) to plan with for every finding's coast to stay out of its
    zone, where the plan keeps ``buffer_m``; None without findings. The one berth rule of
    position loss: the planner plans with it, and again with the next one while findings
    remain.

    ``buffer_m`` plus the deepest reach and :data:`BERTH_MARGIN_M` (a leg pushed out by the
    difference carries its coast region with it), but at first no more than the wander's
    :data:`WANDER_M` and the margin (PX4: its wander and its drift off the path): a coast
    deeper than the wander runs along a leg toward its zone, and a plan kept that far out
    takes another path rather than the same one further out (realistic.yaml in 4 m/s from
    270°: 16.5 m deep at 3.36 m; at 12.5 m no finding is left, and 1.58 bps/Hz against 1.29
    at the 28.8 m the depth asks for)."""
    if not findings:
        return None
    deep = float(buffer_m) + max(-f.clearance_m for f in findings) + BERTH_MARGIN_M
    rule = coast_rule(findings[0].autopilot)
    wander = rule.reach_m + BERTH_MARGIN_M
    return deep if buffer_m >= wander else min(deep, wander)


Slowed = tuple[int, float, float]  # a leg slowed for its coast: its item index, from, to m/s


@dataclass(frozen=True)
class Berth:
    """A plan's buffer widened for position loss: ``site_buffer_m`` the buffer asked for,
    ``buffer_m`` the one planned with, ``deepest_m`` how deep the coast reached a zone at the
    buffer asked for, ``left`` the findings the widest plan still has (0: every coast clear).
    ``windy``: the plan is made for a wind, whose drift during the landing the berth leaves
    out (no buffer covers it: :func:`drift_xy_m`). ``slowed``: the legs commanded slower
    where the widest plan still left a coast in reach (:func:`position_loss_speed_cap_mps`).
    ``autopilot``: whose coast."""

    site_buffer_m: float
    buffer_m: float
    deepest_m: float
    left: int
    windy: bool = False
    slowed: tuple[Slowed, ...] = ()
    autopilot: str = "ardupilot"  # whose coast (validator.coast_rules)

    @property
    def message(self) -> str:
        failsafe = coast_rule(self.autopilot).failsafe_name
        coast = (f"a GPS loss at {self.site_buffer_m:g} m could coast {self.deepest_m:.2f} m into "
                 f"a zone after {failsafe}")
        slowed = "".join(f", the leg to {item_label(item)} slowed from {was:.1f} to {now:.1f} m/s"
                         for item, was, now in self.slowed)
        clear = ("every coast now stays clear, but for the wind's drift while it lands"
                 if self.windy else "every coast now stays clear")
        then = (clear if not self.left else
                f"{self.left} leg finding(s) remain, see validate-mission --params")
        if self.buffer_m <= self.site_buffer_m:
            return (f"{coast}, and no wider buffer could be planned (home inside it, or the "
                    f"safety gate refused the plan){slowed}: "
                    + (then if slowed else f"{self.left} leg finding(s), see validate-mission "
                       f"--params"))
        return (f"buffer widened from {self.site_buffer_m:g} m to {self.buffer_m:.1f} m"
                f"{slowed}: {coast}; {then}")

    def as_dict(self) -> dict[str, object]:
        return {"site_buffer_m": self.site_buffer_m, "buffer_m": self.buffer_m,
                "deepest_m": self.deepest_m, "findings_left": self.left,
                "slowed_legs": [{"item": item_number(item), "from_mps": was, "to_mps": now}
                                for item, was, now in self.slowed],
                "message": self.message}
