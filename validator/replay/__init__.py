"""Time-domain replay of a mission, and the audit of any flown track (modelled or recorded).

Two ways to a :class:`Track` share one scorer, so a modelled flight and a SITL or real
telemetry track are judged the same way:

- :mod:`.track`: :func:`replay` flies a resolved :class:`~validator.flight.Flight` with a
  :class:`~validator.motion.profile.Profile` (default 20 Hz); :func:`track_from_samples` (local
  metres) and :func:`track_from_geodetic` (lat/lon) align a recorded track, with its current
  mission item per sample, with the flight's legs;
- :mod:`.score`: :func:`score_track` judges a track against the site and the plan's own
  timing (:class:`TrackReport`: NFZ clearance, fence entries, cycle time, waypoint lag,
  cross-track deviation); :func:`score_replay` adds what a model knows of its own timing;
- :mod:`.throughput`: the planner's slots matched to the flown track, and the rate each ground
  node gets along it next to the planned one.

Times are seconds, positions metres east/north of the site origin, altitudes metres above
home; rates are spectral efficiencies in bps/Hz averaged over time.
"""

from validator.replay.score import (
    CycleTiming,
    NfzPass,
    TrackReport,
    score_replay,
    score_track,
    track_clearances,
)
from validator.replay.throughput import (
    SLOT_MATCH_M,
    STATIONARY_M,
    SlotMap,
    Throughput,
    flown_rates,
    planned_leg_times,
    planned_rates,
    served_samples,
    slot_map,
)
from validator.replay.track import Track, replay, track_from_geodetic, track_from_samples

__all__ = [
    "SLOT_MATCH_M",
    "STATIONARY_M",
    "CycleTiming",
    "NfzPass",
    "SlotMap",
    "Throughput",
    "Track",
    "TrackReport",
    "flown_rates",
    "planned_leg_times",
    "planned_rates",
    "replay",
    "score_replay",
    "score_track",
    "served_samples",
    "slot_map",
    "track_clearances",
    "track_from_geodetic",
    "track_from_samples",
]
