"""A flown track (modelled or recorded) judged against the site and the plan's own timing.

:func:`score_track` reports (:class:`TrackReport`): the flown clearance to every NFZ (exact
along the straight chords between samples) with when and on which item it occurs, entries into
exclusion fences, the cycle time against the plan, the lag at every waypoint against the plan's
own timing (the ``ideal`` profile), the cross-track deviation from the planned legs, and, when
the plan carries the planner's metadata, the throughput each ground node gets along the flown
track next to the planned one (:mod:`validator.replay.throughput`).

Times are seconds, positions metres east/north of the site origin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal, TypedDict

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry.polygon import orient

from validator.audit import CLEARANCE_TOLERANCE_M
from validator.fence_geometry import local_fence
from validator.flight import Finding, Flight
from validator.geometry import segment_point_closest_fraction, segment_point_distance
from validator.item_numbers import item_label, item_number
from validator.motion.fly import model_findings
from validator.motion.limits import site_limits
from validator.motion.profile import Profile, make_profile
from validator.motion.px4_swing import swing_findings
from validator.plan_format import Plan
from validator.replay.throughput import Throughput, flown_rates, planned_leg_times
from validator.replay.track import Track, replay
from validator.site import Site
from validator.zones import PolygonZone, polyline_clearance_m


class WaypointLag(TypedDict):
    """When the track reached a waypoint against the plan (s from the cycle start), and what
    timed the plan there: the planner's own slot times (``"slots"``: the service cycle of a
    plan that carries them) or the commanded speeds with no acceleration (``"commanded"``:
    every leg of a plan without them, and the transit and landing after the cycle). ``item``
    is the waypoint's item number (:mod:`validator.item_numbers`), as the report gives it."""

    leg: int
    item: int
    planned_s: float
    flown_s: float | None  # None: never reached
    lag_s: float | None
    timed_by: Literal["slots", "commanded"]


@dataclass(frozen=True)
class NfzPass:
    """Closest approach of a track to one NFZ: clearance (m, negative = inside), when, where;
    ``item`` is the 0-based index of the item then flown (:meth:`as_dict` gives its number)."""

    name: str
    clearance_m: float
    t_s: float
    item: int
    xy_m: tuple[float, float]

    def as_dict(self) -> dict[str, object]:
        return {"nfz": self.name, "clearance_m": self.clearance_m, "t_s": self.t_s,
                "item": item_number(self.item), "xy_m": list(self.xy_m)}


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

    def as_dict(self) -> dict[str, object]:
        return {
            "source": self.source, "cycles": self.cycles,
            "planned_period_s": self.planned_period_s, "ideal_cycle_s": self.ideal_cycle_s,
            "flown_cycle_s": self.flown_cycle_s, "flown_cycles_s": list(self.flown_cycles_s),
            "ratio_to_planned": self.ratio, "start_s": self.start_s, "end_s": self.end_s,
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
    waypoint_lag: tuple[WaypointLag, ...]
    cross_track_max_m: float
    cross_track_rms_m: float
    speed_max_mps: float
    throughput: Throughput | None
    findings: tuple[Finding, ...] = field(default=())

    @property
    def violations(self) -> list[Finding]:
        return [f for f in self.findings if f.severity == "violation"]

    @property
    def worst_lag(self) -> WaypointLag | None:
        """The waypoint the track lags the plan's timing most at, among those the planner's
        slot times time when there are any (the transit and landing after the cycle are timed
        only at commanded speeds, which no vehicle flies), else among every waypoint; None if
        none was reached."""
        lags = [w for w in self.waypoint_lag if w["lag_s"] is not None]
        slots = [w for w in lags if w["timed_by"] == "slots"]
        return max(slots or lags, key=lambda w: w["lag_s"] or 0.0, default=None)

    @property
    def max_lag_s(self) -> float:
        """:attr:`worst_lag`'s lag (s); NaN if no waypoint was reached."""
        worst = self.worst_lag
        return math.nan if worst is None or worst["lag_s"] is None else worst["lag_s"]

    def as_dict(self) -> dict[str, object]:
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


def zone_track_clearances(
    xy_m: NDArray[np.float64], site: Site
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """:func:`track_clearances` for every zone of ``site`` (``Site.zone_names`` order): the
    circles exactly, the polygons by :func:`validator.zones.polyline_clearance_m`."""
    clr, k, f = (track_clearances(xy_m, site.nfz_xy_m, site.nfz_radius_m) if site.num_nfzs
                 else (np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros(0)))
    poly = [polyline_clearance_m(z, xy_m) for z in site.polygon_zones]
    return (np.concatenate([clr, [p[0] for p in poly]]),
            np.concatenate([k, np.array([p[1] for p in poly], dtype=np.int64)]),
            np.concatenate([f, [p[2] for p in poly]]))


def _as_zone(poly: shapely.Polygon, j: int) -> PolygonZone:
    """A fence polygon as a zone, to measure how deep a track goes into it."""
    v = np.asarray(orient(poly, 1.0).exterior.coords, dtype=float)[:-1]
    return PolygonZone(f"exclusion fence polygon {j}", v, (v,))


def _cycle_window(flight: Flight, track: Track) -> tuple[float, float] | None:
    if flight.cycle is None:
        return None
    return flight.cycle.window_s(track.leg_start_s, track.leg_reached_s, track.leg_done_s)


def _clock_origins(flight: Flight, track: Track, reference: Track) -> tuple[float, float]:
    """The times (s) on ``track``'s and ``reference``'s clocks that the waypoint lags count
    from: where each starts the service cycle (the slot times' origin), whether or not it
    completes one; a track that never got there counts from its first sample, as if it had
    started with the reference."""
    r0 = float(reference.t_s[0])
    if flight.cycle is None:
        return float(track.t_s[0]), r0
    ref_start, start = (flight.cycle.start_s(tr.leg_start_s, tr.leg_reached_s, tr.leg_done_s)
                        for tr in (reference, track))
    if not math.isnan(ref_start):
        r0 = ref_start
    if math.isnan(start):
        return float(track.t_s[0]) + r0 - float(reference.t_s[0]), r0
    return start, r0


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
    """Distance (m) of each sample from the planned legs next to its current leg; NaN
    outside the mission (before it, and after the vehicle left it on its own)."""
    path = flight.path_xy_m
    n = len(flight.legs)
    leg = np.clip(track.leg, 0, n - 1)
    best = np.full(track.t_s.size, np.inf)
    for off in (-1, 0, 1):
        k = np.clip(leg + off, 0, n - 1)
        d = segment_point_distance(path[k], path[k + 1], track.xy_m)
        best = np.minimum(best, d)
    flying_mission = track.leg >= 0
    if track.left_mission_s is not None:
        flying_mission &= track.t_s < track.left_mission_s
    return np.where(flying_mission, best, np.nan)


def endurance_finding(flying_s: float, endurance_s: float | None,
                      windy: bool = False) -> Finding | None:
    """A violation when the vehicle flies the mission (``flying_s``, take-off to landing, s)
    longer than its endurance (``endurance_s``, the site's ``uav.endurance``, s; None: not
    checked): its low-battery failsafe would cut the mission short, or the reserve would go.
    ``windy``: the flight is in wind, which a calmer day would shorten."""
    if endurance_s is None or flying_s <= endurance_s:
        return None
    remedy = "fewer cycles or a calmer day" if windy else "fewer cycles or a shorter period"
    return Finding("violation", f"the mission flies {flying_s:.0f} s from take-off to landing, "
                   f"beyond the UAV's endurance of {endurance_s:g} s (uav.endurance): "
                   f"{remedy}", None)


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
        reference = replay(flight, make_profile("ideal", site_limits(site)))
    findings: list[Finding] = []
    flying = track.leg >= 0
    xy = track.xy_m[flying] if flying.any() else track.xy_m
    t = track.t_s[flying] if flying.any() else track.t_s
    seq = track.mission_seq[flying] if flying.any() else track.mission_seq
    passes: list[NfzPass] = []
    if site.zone_names:
        clr, k, f = zone_track_clearances(xy, site)
        k1 = np.minimum(k + 1, xy.shape[0] - 1)
        for m, name in enumerate(site.zone_names):
            at_t = float(t[k[m]] + f[m] * (t[k1[m]] - t[k[m]]))
            at_xy = xy[k[m]] + f[m] * (xy[k1[m]] - xy[k[m]])
            passes.append(NfzPass(name, float(clr[m]), at_t, int(seq[k[m]]),
                                  (float(at_xy[0]), float(at_xy[1]))))
            if clr[m] < -CLEARANCE_TOLERANCE_M:
                findings.append(Finding(
                    "violation", f"flown track enters {name} by {-clr[m]:.2f} m at "
                    f"t = {at_t:.1f} s ({item_label(int(seq[k[m]]))})", int(seq[k[m]])))
    fence: list[Finding] = []
    if plan is not None:
        local = local_fence(plan, site.frame)
        centres, radii = local.exclusion_circles()
        if radii.size:
            fclr, fk, _ = track_clearances(xy, centres, radii)
            for j in np.flatnonzero(fclr < -CLEARANCE_TOLERANCE_M):
                fence.append(Finding(
                    "violation", f"flown track enters exclusion fence circle {j} by "
                    f"{-fclr[j]:.2f} m (the autopilot's fence action would fire)",
                    int(seq[fk[j]])))
        excl_p = [poly for poly, inclusion in local.polygons if not inclusion]
        for jp, poly in enumerate(excl_p):
            depth, pk, _ = polyline_clearance_m(_as_zone(poly, jp), xy)
            if depth < -CLEARANCE_TOLERANCE_M:
                fence.append(Finding(
                    "violation", f"flown track enters exclusion fence polygon {jp} by "
                    f"{-depth:.2f} m (the autopilot's fence action would fire)", int(seq[pk])))
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

    t0, r0 = _clock_origins(flight, track, reference)
    # Inside the service cycle the planner's own slot times are the plan's timing when the
    # plan carries them; the ideal replay knows only commanded speeds, not S-curve timing.
    slot_times = planned_leg_times(flight, flight.service) if flight.service else None
    lags: list[WaypointLag] = []
    for li, leg in enumerate(flight.legs):
        flown_t = track.leg_reached_s[li] - t0
        timed_by: Literal["slots", "commanded"] = "commanded"
        if slot_times is not None and li in slot_times:
            plan_t, timed_by = slot_times[li], "slots"
        elif slot_times is not None and li > max(slot_times):  # after the cycle: ideal legs
            end = max(slot_times)
            plan_t = slot_times[end] + reference.leg_reached_s[li] - reference.leg_reached_s[end]
        else:
            plan_t = reference.leg_reached_s[li] - r0
        lag = None if math.isnan(flown_t) or math.isnan(plan_t) else float(flown_t - plan_t)
        lags.append({"leg": li, "item": item_number(leg.item), "planned_s": float(plan_t),
                     "flown_s": None if math.isnan(flown_t) else float(flown_t), "lag_s": lag,
                     "timed_by": timed_by})

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
    over = endurance_finding(float(t[-1] - t[0]), site.endurance_s,
                             site.flight_wind is not None)
    if over is not None:
        findings.append(over)
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


def score_replay(track: Track, flight: Flight, site: Site, plan: Plan | None,
                 profile: Profile) -> TrackReport:
    """:func:`score_track` of ``profile``'s replay ``track`` of ``flight``, with what the
    model knows that its track does not show: of its own timing
    (:func:`validator.motion.fly.model_findings`) and, for ``px4``, the corners PX4 swings out
    of where the replay rounds them inside (:func:`validator.motion.px4_swing.swing_findings`)."""
    report = score_track(track, flight, site, plan)
    found = model_findings(flight, profile)
    if profile.name == "px4":
        found += tuple(swing_findings(flight, site, profile.si("NAV_ACC_RAD"),
                                      CLEARANCE_TOLERANCE_M))
    return replace(report, findings=report.findings + found)
