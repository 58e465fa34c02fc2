"""A flight sampled in time (:class:`Track`): flown by the model (:func:`replay`) or recorded
(:func:`track_from_samples`, :func:`track_from_geodetic`) and aligned with the flight's legs.

Times are seconds, positions metres east/north of the site origin, altitudes metres above home.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from validator.autopilot.rules import stored_hold_s
from validator.errors import InputError
from validator.flight import Flight
from validator.motion.fly import REPLAY_STEP_S, fly
from validator.motion.profile import Profile
from validator.site import Site


@dataclass(frozen=True)
class Track:
    """A flight sampled in time, modelled or recorded.

    Samples: ``t_s`` (n,) seconds; ``xy_m`` (n, 2); ``alt_m`` (n,) above home; ``speed_mps``
    (n,) horizontal; ``mission_seq`` (n,) the current mission item (0-based ``.plan`` item
    index; ArduPilot's wire sequence is one more) or -1 before the mission; ``leg`` (n,) the
    index into ``Flight.legs`` being flown, -1 before the mission. Per leg of the flight:
    ``leg_start_s`` motion toward it began, ``leg_reached_s`` its destination was reached,
    ``leg_done_s`` its item completed (hold over); NaN when it never happened.
    ``left_mission_s``: when a recorded vehicle left the mission mode on its own (a failsafe,
    a fence breach; None: it never did): the samples from then on are the autopilot's own
    flight, scored for clearance but not timed or measured against the legs.
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
    left_mission_s: float | None = None

    def item_reached_s(self, flight: Flight, item: int) -> NDArray[np.float64]:
        """Every time the destination of mission item ``item`` was reached (jumps repeat it)."""
        idx = [k for k, leg in enumerate(flight.legs) if leg.item == item]
        return np.asarray(self.leg_reached_s[idx], dtype=float)


def replay(flight: Flight, profile: Profile, *, dt_s: float = REPLAY_STEP_S) -> Track:
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
    left_mission_s: float | None = None,
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

    ``left_mission_s``: when the vehicle left the mission mode on its own (a failsafe, a fence
    breach). Its items are aligned on the samples before that only, as if the recording ended
    there: the item it was flying is not done when the return lands, so a return that passes
    the cycle's closing item is no cycle flown. The samples after it (while the autopilot
    reports an item) stay on the leg it was flying, so that clearances cover the return.
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
    # runs of equal seq, in the samples flown in the mission mode
    n = t.size if left_mission_s is None else int(np.searchsorted(t, left_mission_s))
    change = np.flatnonzero(np.diff(seq[:n])) + 1
    run_lo = np.concatenate([[0], change]) if n else np.zeros(0, dtype=np.int64)
    run_hi = np.concatenate([change, [n]]) if n else np.zeros(0, dtype=np.int64)
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
        end_t = float(t[hi]) if hi < n else math.nan  # the run ended: item done
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
            hold = stored_hold_s(leg.hold_s, "ardupilot")
            if not math.isnan(end_t) and leg.kind in ("waypoint", "loiter"):
                reached[g] = max(float(t[cursor]), end_t - hold)
            else:
                reached[g] = float(t[at]) if at is not None else end_t
            done[g] = end_t
            if math.isnan(end_t) and at is not None and t[n - 1] >= reached[g] + hold - 1e-6:
                done[g] = float(t[n - 1])  # the recording ends once the last item is complete
            prev_done = done[g]
        r += 1
        k = group[-1] + 1
    if 0 < n < t.size and leg_of[n - 1] >= 0:
        # the flight after it left the mission, still on the item it was flying as the
        # autopilot reports, so that its clearances are scored as the mission's are
        leg_of[n:] = np.where(seq[n:] >= 0, leg_of[n - 1], -1)
    items = np.array([leg.item for leg in flight.legs], dtype=np.int64)
    seq_out = np.where(leg_of >= 0, items[np.maximum(leg_of, 0)], -1)
    return Track(t, xy, alt, speed, seq_out, leg_of, start, reached, done, source,
                 left_mission_s)


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
    left_mission_s: float | None = None,
) -> Track:
    """:func:`track_from_samples` for a track in WGS84 degrees (e.g. GLOBAL_POSITION_INT)."""
    xy = site.frame.to_local(np.asarray(lat_deg, dtype=float), np.asarray(lon_deg, dtype=float))
    return track_from_samples(flight, t_s, xy, mission_seq, alt_m=alt_m, radius_m=radius_m,
                              stopped_mps=stopped_mps, source=source,
                              left_mission_s=left_mission_s)
