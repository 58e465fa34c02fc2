"""The planner's slots matched to a flown track: the throughput each ground node gets along it
next to the planned one (rates are spectral efficiencies in bps/Hz averaged over time)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from validator.autopilot.rules import STATIONARY_M  # a shorter slot is a hover, as exported
from validator.channel import spectral_efficiency
from validator.flight import Flight, ServicePlan
from validator.geometry import segment_point_closest_fraction, segment_point_distance
from validator.item_numbers import item_label
from validator.replay.track import Track
from validator.site import Site

SLOT_MATCH_M = 0.1  # planned slot end points and mission waypoints agree this closely

@dataclass(frozen=True)
class Throughput:
    """Average rate per ground node (bps/Hz): planned (paper model, over T) and flown."""

    gn_names: tuple[str, ...]
    planned_bps_hz: NDArray[np.float64]
    flown_bps_hz: NDArray[np.float64]
    flown_time_s: float

    @property
    def planned_min(self) -> float:
        return float(np.min(self.planned_bps_hz))

    @property
    def flown_min(self) -> float:
        return float(np.min(self.flown_bps_hz))

    def as_dict(self) -> dict[str, object]:
        return {
            "per_gn": [
                {"gn": g, "planned_bps_hz": float(p), "flown_bps_hz": float(f),
                 "ratio": float(f / p) if p > 0 else None}
                for g, p, f in zip(self.gn_names, self.planned_bps_hz, self.flown_bps_hz,
                                   strict=True)
            ],
            "planned_min_bps_hz": self.planned_min,
            "flown_min_bps_hz": self.flown_min,
            "flown_time_s": self.flown_time_s,
        }


@dataclass(frozen=True)
class SlotMap:
    """Planned slots flown on each leg of the service span.

    ``moving[k]``: (slot, s0_m, s1_m) intervals along leg k from its start; ``hold[k]``: (slot,
    h0_s, h1_s) intervals of its planned hold. Slots are 0-based (slot n+1 in the paper).
    """

    moving: dict[int, NDArray[np.float64]]
    hold: dict[int, NDArray[np.float64]]


def slot_map(flight: Flight, service: ServicePlan) -> SlotMap | str:
    """Match the planner's slots to the flight's legs; a reason string when they disagree.

    Walking the service span, a leg that moves consumes the slots whose end points lie along
    it until one ends at its destination (within :data:`SLOT_MATCH_M`); then every leg
    consumes the slots that stay put at its destination (moving less than
    :data:`STATIONARY_M`) as its hold. After the last slot the next cycle starts at slot 1.
    """
    c = flight.cycle
    if c is None:
        return "the mission's service cycle could not be located"
    q = service.trajectory_m
    nslots = service.slots
    step = np.hypot(*(q[1:] - q[:-1]).T)
    legs = flight.legs
    moves: dict[int, list[tuple[float, float, float]]] = {}
    holds: dict[int, list[tuple[float, float, float]]] = {}
    n = 0
    cycle = 0

    def take_holds(k: int) -> None:
        nonlocal n
        acc = 0.0
        out = holds.setdefault(k, [])
        end = legs[k].end_xy_m
        while (n < nslots and step[n] <= STATIONARY_M
               and np.hypot(*(q[n + 1] - end)) <= SLOT_MATCH_M):
            out.append((n, acc, acc + service.delta_s[n]))
            acc += service.delta_s[n]
            n += 1

    first = c.start_leg
    if c.start_at_arrival:
        if np.hypot(*(legs[first].end_xy_m - q[0])) > SLOT_MATCH_M:
            return f"{item_label(legs[first].item)} is not at the planned start point q[0]"
        take_holds(first)
        first += 1
    for k in range(first, c.end_leg + 1):
        if n == nslots and cycle + 1 < service.cycles:
            n, cycle = 0, cycle + 1
        leg = legs[k]
        if leg.length_m > STATIONARY_M:  # as the exporter: longer slots move, shorter hold
            out = moves.setdefault(k, [])
            s = 0.0
            reached = False
            while n < nslots:
                b = q[n + 1]
                out.append((n, s, s + step[n]))
                s += step[n]
                n += 1
                gap = np.hypot(*(b - leg.end_xy_m))
                if gap <= SLOT_MATCH_M:
                    # A slow final approach (the end of an S-curve) may end several slots
                    # within the tolerance: the leg takes them while they close in.
                    while (n < nslots and step[n] > STATIONARY_M
                           and np.hypot(*(q[n + 1] - leg.end_xy_m)) < gap):
                        gap = np.hypot(*(q[n + 1] - leg.end_xy_m))
                        out.append((n, s, s + step[n]))
                        s += step[n]
                        n += 1
                    reached = True
                    break
                if segment_point_distance(leg.start_xy_m, leg.end_xy_m, b) > SLOT_MATCH_M:
                    return f"slot {n} leaves the leg to {item_label(leg.item)}"
            if not reached:
                return f"the planned slots do not end at {item_label(leg.item)}"
        take_holds(k)
    if n != nslots or cycle + 1 != service.cycles:
        return (f"the mission covers {cycle * nslots + n} slots, the plan "
                f"{service.cycles * nslots}")
    return SlotMap(
        moving={k: np.asarray(v, dtype=float).reshape(-1, 3) for k, v in moves.items()},
        hold={k: np.asarray(v, dtype=float).reshape(-1, 3) for k, v in holds.items()},
    )


def planned_leg_times(flight: Flight, service: ServicePlan) -> dict[int, float] | None:
    """Planned arrival (s after the cycle's start) at each leg of the service span, from the
    planner's slot lengths; None when the slots cannot be matched to the legs."""
    sm = slot_map(flight, service)
    if isinstance(sm, str) or flight.cycle is None:
        return None
    delta = service.delta_s
    out: dict[int, float] = {}
    t = 0.0
    for k in range(flight.cycle.start_leg, flight.cycle.end_leg + 1):
        if k in sm.moving:
            t += float(np.sum(delta[sm.moving[k][:, 0].astype(int)]))
        out[k] = t
        if k in sm.hold:
            t += float(np.sum(delta[sm.hold[k][:, 0].astype(int)]))
    return out


def planned_rates(service: ServicePlan, site: Site) -> NDArray[np.float64]:
    """Average rate (bps/Hz over T) of each GN in the paper's model: slot n's rate at q[n]."""
    k = service.schedule
    served = k >= 0
    r = spectral_efficiency(service.trajectory_m[1:][served], site.gn_xy_m[k[served]],
                            site.altitude_m, service.power_w[served], site.beta0, site.noise_w)
    out = np.zeros(site.num_gns)
    np.add.at(out, k[served], service.delta_s[served] * r)
    return out / service.period_s


def _sample_slots(
    flight: Flight, track: Track, smap: SlotMap, window: tuple[float, float]
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Planned slot of every sample (-1 outside the span) and each sample's time weight (s)."""
    t = track.t_s
    start, end = window
    slot = np.full(t.size, -1, dtype=np.int64)
    for k in set(smap.moving) | set(smap.hold):
        sel = np.flatnonzero((track.leg == k) & (t >= start) & (t <= end))
        if sel.size == 0:
            continue
        leg = flight.legs[k]
        reached, done = track.leg_reached_s[k], track.leg_done_s[k]
        in_hold = t[sel] >= reached
        mv = smap.moving.get(k)
        hd = smap.hold.get(k)
        if mv is not None and mv.size:
            f = segment_point_closest_fraction(leg.start_xy_m, leg.end_xy_m, track.xy_m[sel])
            # The move ends where the autopilot counted the waypoint reached: on it for
            # ArduCopter, up to the acceptance radius short of it for PX4, whose hold starts
            # there. The plan laid the move's slots out to that moment, so the flown move is
            # measured to the same point.
            at_reach = f[~in_hold][-1] if np.any(~in_hold) and np.any(in_hold) else 1.0
            if 0.5 < at_reach < 1.0:
                f = np.minimum(f / at_reach, 1.0)
            s = f * mv[-1, 2]
            j = np.clip(np.searchsorted(mv[:, 2], s, side="right"), 0, mv.shape[0] - 1)
            slot[sel] = mv[j, 0].astype(np.int64)
        if hd is not None and hd.size:
            h = sel[in_hold]
            span = done - reached
            plan_h = hd[-1, 2]
            x = (t[h] - reached) / span * plan_h if span > 0 else np.zeros(h.size)
            j = np.clip(np.searchsorted(hd[:, 2], x, side="right"), 0, hd.shape[0] - 1)
            slot[h] = hd[j, 0].astype(np.int64)
            if mv is None or not mv.size:
                # a zero-length leg before its hold starts: the first hold slot
                slot[sel[~in_hold]] = int(hd[0, 0])
    # time weights: each sample stands for half the gap to each neighbour, within the window
    tc = np.clip(t, start, end)
    mids = np.concatenate([[tc[0]], (tc[1:] + tc[:-1]) / 2.0, [tc[-1]]])
    weight = np.diff(mids)
    return slot, weight


def flown_rates(
    flight: Flight, track: Track, site: Site, window: tuple[float, float]
) -> Throughput | str:
    """Average rate per GN along the flown track over the flown cycles (bps/Hz)."""
    service = flight.service
    if service is None:
        return "no planner metadata (nfzMission) in the plan: throughput not scored"
    smap = slot_map(flight, service)
    if isinstance(smap, str):
        return f"throughput not scored: {smap}"
    slot, weight = _sample_slots(flight, track, smap, window)
    use = slot >= 0
    k = np.where(use, service.schedule[np.maximum(slot, 0)], -1)
    served = use & (k >= 0)
    alt = np.where(np.isnan(track.alt_m), site.altitude_m, track.alt_m)
    uav = np.column_stack([track.xy_m[served], alt[served]])
    gn = np.column_stack([site.gn_xy_m[k[served]], np.zeros(int(served.sum()))])
    r = spectral_efficiency(uav, gn, 0.0, service.power_w[slot[served]], site.beta0,
                            site.noise_w)
    bits = np.zeros(site.num_gns)
    np.add.at(bits, k[served], r * weight[served])
    span = window[1] - window[0]
    planned = planned_rates(service, site)
    return Throughput(site.gn_names, planned, bits / span, span)




def served_samples(
    flight: Flight, track: Track, site: Site
) -> tuple[NDArray[np.int64], NDArray[np.float64]] | str:
    """Per sample of ``track`` over its flown service cycles: the GN served (-1: none, or
    outside the cycles) and its instantaneous rate (bps/Hz) at the planned power, the terms
    :func:`flown_rates` averages; a reason string when the slots cannot be matched."""
    service = flight.service
    if service is None or flight.cycle is None:
        return "no planner metadata (nfzMission) in the plan"
    smap = slot_map(flight, service)
    if isinstance(smap, str):
        return smap
    window = flight.cycle.window_s(track.leg_start_s, track.leg_reached_s, track.leg_done_s)
    if window is None:
        return "the track does not fly a whole service cycle"
    slot, _ = _sample_slots(flight, track, smap, window)
    gn = np.where(slot >= 0, service.schedule[np.maximum(slot, 0)], -1)
    served = gn >= 0
    alt = np.where(np.isnan(track.alt_m), site.altitude_m, track.alt_m)
    rate = np.zeros(track.t_s.size)
    rate[served] = spectral_efficiency(
        np.column_stack([track.xy_m[served], alt[served]]),
        np.column_stack([site.gn_xy_m[gn[served]], np.zeros(int(served.sum()))]),
        0.0, service.power_w[slot[served]], site.beta0, site.noise_w)
    return gn.astype(np.int64), rate
