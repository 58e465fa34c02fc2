"""Time-domain replay of a mission, and the audit of any flown track (modelled or recorded).

Two entry points share one scorer, so a modelled flight and a SITL or real telemetry track are
judged the same way:

- :func:`replay` flies a resolved :class:`~validator.flight.Flight` with a
  :class:`~validator.dynamics.Profile` and returns a :class:`Track` (default 20 Hz).
- :func:`track_from_samples` (local metres) and :func:`track_from_geodetic` (lat/lon) turn a
  recorded track with its current mission item per sample into a :class:`Track`.

:func:`score_track` then reports (:class:`TrackReport`): the flown clearance to every NFZ
(exact along the straight chords between samples) with when and on which item it occurs,
entries into exclusion fences, the cycle time against the plan, the lag at every waypoint
against the plan's own timing (the ``ideal`` profile), the cross-track deviation from the
planned legs, and, when the plan carries the planner's metadata, the throughput each ground
node gets along the flown track next to the planned one.

Times are seconds, positions metres east/north of the site origin, altitudes metres above
home; rates are spectral efficiencies in bps/Hz averaged over time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from validator.audit import CLEARANCE_TOLERANCE_M
from validator.channel import spectral_efficiency
from validator.dynamics import Profile, fly, make_profile
from validator.errors import InputError
from validator.fence_geometry import local_fence
from validator.flight import Finding, Flight, ServicePlan
from validator.geometry import segment_point_closest_fraction, segment_point_distance
from validator.plan_format import Plan
from validator.site import Site

STATIONARY_M = 0.05  # a planned slot shorter than this is a hover (as the exporter merges them)
SLOT_MATCH_M = 0.1  # planned slot end points and mission waypoints agree this closely


@dataclass(frozen=True)
class Track:
    """A flight sampled in time, modelled or recorded.

    Samples: ``t_s`` (n,) seconds; ``xy_m`` (n, 2); ``alt_m`` (n,) above home; ``speed_mps``
    (n,) horizontal; ``mission_seq`` (n,) the current mission item (0-based ``.plan`` item
    index; ArduPilot's wire sequence is one more) or -1 before the mission; ``leg`` (n,) the
    index into ``Flight.legs`` being flown, -1 before the mission. Per leg of the flight:
    ``leg_start_s`` motion toward it began, ``leg_reached_s`` its destination was reached,
    ``leg_done_s`` its item completed (hold over); NaN when it never happened.
    """

    t_s: NDArray[np.float64]
    xy_m: NDArray[np.float64]
    alt_m: NDArray[np.float64]
    speed_mps: NDArray[np.float64]
    mission_seq: NDArray[np.int64]
    leg: NDArray[np.int64]
    leg_start_s: NDArray[np.float64]
    leg_reached_s: NDArray[np.float64]
    leg_done_s: NDArray[np.float64]
    source: str = "replay"

    def item_reached_s(self, flight: Flight, item: int) -> NDArray[np.float64]:
        """Every time the destination of mission item ``item`` was reached (jumps repeat it)."""
        idx = [k for k, leg in enumerate(flight.legs) if leg.item == item]
        return np.asarray(self.leg_reached_s[idx], dtype=float)


def replay(flight: Flight, profile: Profile, *, dt_s: float = 0.05) -> Track:
    """Fly ``flight`` with ``profile`` in time; samples every ``dt_s`` seconds (default 20 Hz).

    The same model drives the SITL vehicle (``validator.mavlink``), so a mission flown there
    and replayed here should agree.
    """
    path = fly(flight, profile, dt_s=dt_s)
    seq = np.array([leg.item for leg in flight.legs], dtype=np.int64)[path.leg]
    return Track(
        t_s=path.t_s,
        xy_m=path.xyz_m[:, :2],
        alt_m=path.xyz_m[:, 2],
        speed_mps=np.hypot(path.vel_mps[:, 0], path.vel_mps[:, 1]),
        mission_seq=seq,
        leg=path.leg,
        leg_start_s=path.start_s,
        leg_reached_s=path.reached_s,
        leg_done_s=path.done_s,
        source=f"replay:{profile.name}",
    )


# --------------------------------------------------------------------------------------------
# recorded tracks


def track_from_samples(
    flight: Flight,
    t_s: ArrayLike,
    xy_m: ArrayLike,
    mission_seq: ArrayLike,
    *,
    alt_m: ArrayLike | None = None,
    radius_m: float = 2.0,
    stopped_mps: float = 0.3,
    source: str = "telemetry",
) -> Track:
    """A recorded track (local metres) aligned with ``flight``'s legs.

    ``mission_seq`` is the current mission item per sample as a 0-based ``.plan`` item index
    (subtract 1 from ArduPilot's MISSION_CURRENT seq); values that are not items, such as -1,
    mean "not flying the mission". Legs are matched in order to the runs of their item, and
    arrivals are timed as the autopilot times them: an item is done when its run ends (the
    autopilot moved on), and its destination was reached its hold earlier (ArduCopter starts
    the hold timer on arrival and stores whole seconds), so a pass-through waypoint is reached
    when the next item starts. Only where the run has no end in the recording does position
    decide (the first sample within ``radius_m`` of the destination), and for the approach of
    a LAND or RTL, which shares its item's run, position and speed (the first sample there
    slower than ``stopped_mps``, else the first there); a recording that ends on an item's run
    after its hold time counts that item as done at the last sample.
    """
    t = np.asarray(t_s, dtype=float).reshape(-1)
    xy = np.asarray(xy_m, dtype=float).reshape(-1, 2)
    seq = np.asarray(mission_seq, dtype=np.int64).reshape(-1)
    if not (t.size == xy.shape[0] == seq.size) or t.size < 2:
        raise InputError(f"{source}: t_s, xy_m and mission_seq need the same length >= 2")
    if np.any(np.diff(t) < 0):
        raise InputError(f"{source}: t_s must not decrease")
    alt = (np.full(t.size, np.nan) if alt_m is None
           else np.asarray(alt_m, dtype=float).reshape(-1))
    speed = np.zeros(t.size)
    dt = np.diff(t)
    v = np.divide(np.diff(xy, axis=0), dt[:, None], out=np.zeros((t.size - 1, 2)),
                  where=dt[:, None] > 0)
    speed[1:] = np.hypot(v[:, 0], v[:, 1])

    def arrival(lo: int, hi: int, end_xy: NDArray[np.float64], stop: bool) -> int | None:
        """First sample in [lo, hi) at the destination: within radius_m (and, with ``stop``,
        stopped if it stops there); None when none is."""
        d = np.hypot(*(xy[lo:hi] - end_xy).T)
        near = d <= radius_m
        if not near.any():
            return None
        still = np.flatnonzero(near & (speed[lo:hi] <= stopped_mps)) if stop else np.zeros(0)
        return lo + int(still[0] if still.size else np.flatnonzero(near)[0])

    n_legs = len(flight.legs)
    start = np.full(n_legs, np.nan)
    reached = np.full(n_legs, np.nan)
    done = np.full(n_legs, np.nan)
    leg_of = np.full(t.size, -1, dtype=np.int64)
    # runs of equal seq
    change = np.flatnonzero(np.diff(seq)) + 1
    run_lo = np.concatenate([[0], change])
    run_hi = np.concatenate([change, [t.size]])
    r = 0
    prev_done = math.nan
    k = 0
    while k < n_legs:
        item = flight.legs[k].item
        group = [k]  # RTL and LAND give consecutive legs of one item: they share its run
        while group[-1] + 1 < n_legs and flight.legs[group[-1] + 1].item == item:
            group.append(group[-1] + 1)
        while r < run_lo.size and seq[run_lo[r]] != item:
            r += 1
        if r >= run_lo.size:
            break
        lo, hi = int(run_lo[r]), int(run_hi[r])
        end_t = float(t[hi]) if hi < t.size else math.nan  # the run ended: item done
        cursor = lo
        for g in group:
            leg = flight.legs[g]
            start[g] = t[cursor] if math.isnan(prev_done) else prev_done
            at = arrival(cursor, hi, leg.end_xy_m, stop=g != group[-1])
            if g != group[-1]:
                stop = at if at is not None else hi - 1
                leg_of[cursor:stop + 1] = g
                reached[g] = done[g] = prev_done = float(t[stop])
                cursor = min(stop + 1, hi - 1)
                continue
            leg_of[cursor:hi] = g
            hold = math.floor(leg.hold_s + 1e-9)  # as ArduCopter stores it
            if not math.isnan(end_t) and leg.kind in ("waypoint", "loiter"):
                reached[g] = max(float(t[cursor]), end_t - hold)
            else:
                reached[g] = float(t[at]) if at is not None else end_t
            done[g] = end_t
            if math.isnan(end_t) and at is not None and t[-1] >= reached[g] + hold - 1e-6:
                done[g] = float(t[-1])  # the recording ends once the last item is complete
            prev_done = done[g]
        r += 1
        k = group[-1] + 1
    items = np.array([leg.item for leg in flight.legs], dtype=np.int64)
    seq_out = np.where(leg_of >= 0, items[np.maximum(leg_of, 0)], -1)
    return Track(t, xy, alt, speed, seq_out, leg_of, start, reached, done, source)


def track_from_geodetic(
    flight: Flight,
    site: Site,
    t_s: ArrayLike,
    lat_deg: ArrayLike,
    lon_deg: ArrayLike,
    mission_seq: ArrayLike,
    *,
    alt_m: ArrayLike | None = None,
    radius_m: float = 2.0,
    stopped_mps: float = 0.3,
    source: str = "telemetry",
) -> Track:
    """:func:`track_from_samples` for a track in WGS84 degrees (e.g. GLOBAL_POSITION_INT)."""
    xy = site.frame.to_local(np.asarray(lat_deg, dtype=float), np.asarray(lon_deg, dtype=float))
    return track_from_samples(flight, t_s, xy, mission_seq, alt_m=alt_m, radius_m=radius_m,
                              stopped_mps=stopped_mps, source=source)


# --------------------------------------------------------------------------------------------
# scoring


@dataclass(frozen=True)
class NfzPass:
    """Closest approach of a track to one NFZ: clearance (m, negative = inside), when, where."""

    name: str
    clearance_m: float
    t_s: float
    item: int
    xy_m: tuple[float, float]

    def as_dict(self) -> dict[str, Any]:
        return {"nfz": self.name, "clearance_m": self.clearance_m, "t_s": self.t_s,
                "item": self.item, "xy_m": list(self.xy_m)}


@dataclass(frozen=True)
class CycleTiming:
    """Service-cycle time: planned period, the plan's own timing, and the flown one (s)."""

    source: str
    cycles: int
    planned_period_s: float  # T from the planner's metadata, else the ideal timing
    ideal_cycle_s: float  # commanded speeds and holds, no dynamics
    flown_cycle_s: float  # mean over the cycles
    flown_cycles_s: tuple[float, ...]  # each cycle, when the cycles can be told apart
    start_s: float
    end_s: float

    @property
    def ratio(self) -> float:
        return self.flown_cycle_s / self.planned_period_s if self.planned_period_s > 0 else math.nan

    def as_dict(self) -> dict[str, Any]:
        return {
            "source": self.source, "cycles": self.cycles,
            "planned_period_s": self.planned_period_s, "ideal_cycle_s": self.ideal_cycle_s,
            "flown_cycle_s": self.flown_cycle_s, "flown_cycles_s": list(self.flown_cycles_s),
            "ratio_to_planned": self.ratio, "start_s": self.start_s, "end_s": self.end_s,
        }


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

    def as_dict(self) -> dict[str, Any]:
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
class TrackReport:
    """What :func:`score_track` finds. ``findings`` holds violations, warnings and notes."""

    source: str
    samples: int
    duration_s: float
    nfz: tuple[NfzPass, ...]
    fence_entries: tuple[Finding, ...]
    cycle: CycleTiming | None
    waypoint_lag: tuple[dict[str, Any], ...]
    cross_track_max_m: float
    cross_track_rms_m: float
    speed_max_mps: float
    throughput: Throughput | None
    findings: tuple[Finding, ...] = field(default=())

    @property
    def violations(self) -> list[Finding]:
        return [f for f in self.findings if f.severity == "violation"]

    @property
    def max_lag_s(self) -> float:
        lags = [w["lag_s"] for w in self.waypoint_lag if w["lag_s"] is not None]
        return max(lags, default=math.nan)

    def as_dict(self) -> dict[str, Any]:
        return {
            "source": self.source,
            "samples": self.samples,
            "duration_s": self.duration_s,
            "nfz": [p.as_dict() for p in self.nfz],
            "cycle": self.cycle.as_dict() if self.cycle else None,
            "waypoint_lag": list(self.waypoint_lag),
            "max_lag_s": None if math.isnan(self.max_lag_s) else self.max_lag_s,
            "cross_track_max_m": self.cross_track_max_m,
            "cross_track_rms_m": self.cross_track_rms_m,
            "speed_max_mps": self.speed_max_mps,
            "throughput": self.throughput.as_dict() if self.throughput else None,
            "findings": [f.as_dict() for f in self.findings],
        }


def track_clearances(
    xy_m: NDArray[np.float64], centres_m: NDArray[np.float64], radii_m: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """Per circle: least clearance (m) of the polyline through the samples, the chord index
    where it occurs and the fraction along that chord."""
    centres = np.asarray(centres_m, dtype=float).reshape(-1, 2)
    if xy_m.shape[0] == 1:
        xy_m = np.vstack([xy_m, xy_m])
    a, b = xy_m[:-1, None, :], xy_m[1:, None, :]
    d = segment_point_distance(a, b, centres[None, :, :]) - np.asarray(radii_m)[None, :]
    k = np.argmin(d, axis=0)
    cols = np.arange(centres.shape[0])
    frac = segment_point_closest_fraction(xy_m[k], xy_m[k + 1], centres)
    return d[k, cols], k.astype(np.int64), np.asarray(frac, dtype=float)


def _cycle_window(flight: Flight, track: Track) -> tuple[float, float] | None:
    c = flight.cycle
    if c is None:
        return None
    if c.start_at_arrival:
        start = track.leg_reached_s[c.start_leg]
    else:
        start = track.leg_done_s[c.start_leg - 1] if c.start_leg > 0 else track.leg_start_s[0]
    end = track.leg_done_s[c.end_leg]
    if math.isnan(start) or math.isnan(end) or end <= start:
        return None
    return float(start), float(end)


def _per_cycle(flight: Flight, track: Track, start: float, end: float) -> tuple[float, ...]:
    """Each cycle's duration, when the closing item occurs once per cycle."""
    c = flight.cycle
    assert c is not None
    closing = flight.legs[c.end_leg].item
    ends = [track.leg_done_s[k] for k in range(c.start_leg, c.end_leg + 1)
            if flight.legs[k].item == closing]
    if len(ends) != c.cycles or any(math.isnan(e) for e in ends):
        return ()
    bounds = [start, *ends]
    return tuple(float(b - a) for a, b in zip(bounds[:-1], bounds[1:], strict=True))


def _cross_track(flight: Flight, track: Track) -> NDArray[np.float64]:
    """Distance (m) of each sample from the planned legs next to its current leg."""
    path = flight.path_xy_m
    n = len(flight.legs)
    leg = np.clip(track.leg, 0, n - 1)
    best = np.full(track.t_s.size, np.inf)
    for off in (-1, 0, 1):
        k = np.clip(leg + off, 0, n - 1)
        d = segment_point_distance(path[k], path[k + 1], track.xy_m)
        best = np.minimum(best, d)
    return np.where(track.leg >= 0, best, np.nan)


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
            return f"item {legs[first].item} is not at the planned start point q[0]"
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
                    return f"slot {n} leaves the leg to item {leg.item}"
            if not reached:
                return f"the planned slots do not end at item {leg.item}"
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


def score_track(
    track: Track,
    flight: Flight,
    site: Site,
    plan: Plan | None = None,
    *,
    reference: Track | None = None,
) -> TrackReport:
    """Audit a flown track against the site and the plan's own timing.

    ``reference`` is the plan's timing (default: the ``ideal`` replay of ``flight``); ``plan``
    adds its exclusion fences to the checks.
    """
    if reference is None:
        reference = replay(flight, make_profile("ideal", site))
    findings: list[Finding] = []
    flying = track.leg >= 0
    xy = track.xy_m[flying] if flying.any() else track.xy_m
    t = track.t_s[flying] if flying.any() else track.t_s
    seq = track.mission_seq[flying] if flying.any() else track.mission_seq
    passes: list[NfzPass] = []
    if site.num_nfzs:
        clr, k, f = track_clearances(xy, site.nfz_xy_m, site.nfz_radius_m)
        k1 = np.minimum(k + 1, xy.shape[0] - 1)
        for m, name in enumerate(site.nfz_names):
            at_t = float(t[k[m]] + f[m] * (t[k1[m]] - t[k[m]]))
            at_xy = xy[k[m]] + f[m] * (xy[k1[m]] - xy[k[m]])
            passes.append(NfzPass(name, float(clr[m]), at_t, int(seq[k[m]]),
                                  (float(at_xy[0]), float(at_xy[1]))))
            if clr[m] < -CLEARANCE_TOLERANCE_M:
                findings.append(Finding(
                    "violation", f"flown track enters {name} by {-clr[m]:.2f} m at "
                    f"t = {at_t:.1f} s (item {int(seq[k[m]])})", int(seq[k[m]])))
    fence: list[Finding] = []
    if plan is not None:
        centres, radii = local_fence(plan, site.frame).exclusion_circles()
        if radii.size:
            fclr, fk, _ = track_clearances(xy, centres, radii)
            for j in np.flatnonzero(fclr < -CLEARANCE_TOLERANCE_M):
                fence.append(Finding(
                    "violation", f"flown track enters exclusion fence circle {j} by "
                    f"{-fclr[j]:.2f} m (the autopilot's fence action would fire)",
                    int(seq[fk[j]])))
    findings += fence

    window = _cycle_window(flight, track)
    ref_window = _cycle_window(flight, reference)
    cycle: CycleTiming | None = None
    if window and ref_window and flight.cycle is not None:
        c = flight.cycle
        ideal = (ref_window[1] - ref_window[0]) / c.cycles
        planned = flight.service.period_s if flight.service else ideal
        flown = (window[1] - window[0]) / c.cycles
        cycle = CycleTiming(c.source, c.cycles, planned, ideal, flown,
                            _per_cycle(flight, track, *window), window[0], window[1])
    elif flight.cycle is not None:
        findings.append(Finding("warning", "the track does not cover the service cycle", None))

    t0 = window[0] if window else float(track.t_s[0])
    r0 = ref_window[0] if ref_window else float(reference.t_s[0])
    # Inside the service cycle the planner's own slot times are the plan's timing when the
    # plan carries them; the ideal replay knows only commanded speeds, not S-curve timing.
    slot_times = planned_leg_times(flight, flight.service) if flight.service else None
    lags = []
    for li, leg in enumerate(flight.legs):
        flown_t = track.leg_reached_s[li] - t0
        if slot_times is not None and li in slot_times:
            plan_t = slot_times[li]
        elif slot_times is not None and li > max(slot_times):  # after the cycle: ideal legs
            end = max(slot_times)
            plan_t = slot_times[end] + reference.leg_reached_s[li] - reference.leg_reached_s[end]
        else:
            plan_t = reference.leg_reached_s[li] - r0
        lag = None if math.isnan(flown_t) or math.isnan(plan_t) else float(flown_t - plan_t)
        lags.append({"leg": li, "item": leg.item, "planned_s": float(plan_t),
                     "flown_s": None if math.isnan(flown_t) else float(flown_t), "lag_s": lag})

    xt = _cross_track(flight, track)
    xt_ok = xt[~np.isnan(xt)]
    throughput: Throughput | None = None
    if window is not None:
        scored = flown_rates(flight, track, site, window)
        if isinstance(scored, str):
            findings.append(Finding("note", scored, None))
        else:
            throughput = scored
    elif flight.service is not None:
        findings.append(Finding("note", "throughput not scored: no complete cycle", None))
    return TrackReport(
        source=track.source,
        samples=int(track.t_s.size),
        duration_s=float(track.t_s[-1] - track.t_s[0]),
        nfz=tuple(passes),
        fence_entries=tuple(fence),
        cycle=cycle,
        waypoint_lag=tuple(lags),
        cross_track_max_m=float(np.max(xt_ok)) if xt_ok.size else 0.0,
        cross_track_rms_m=float(np.sqrt(np.mean(xt_ok**2))) if xt_ok.size else 0.0,
        speed_max_mps=float(np.max(track.speed_mps)),
        throughput=throughput,
        findings=tuple(findings),
    )
