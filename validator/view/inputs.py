"""What a mission view shows (:class:`ViewInputs`): a plan on its site, the flights that flew
it, and the layers other checks know about when they ran (failsafe paths, wind).

Every layer past the plan and the site is optional, so a feature adds its layer by filling
one field, and the view draws only what it is given. Positions are metres east/north of the
site origin, times seconds from the takeoff, speeds m/s.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from validator.flight import Flight
from validator.plan_format import Plan
from validator.replay import Track
from validator.site import Site
from validator.validation import Validation


@dataclass(frozen=True)
class TrackLayer:
    """A flight in time: the model's replay or a flown track (SITL, a recorded flight).
    ``name`` is its legend entry, e.g. ``"replay (arducopter)"``."""

    name: str
    track: Track


@dataclass(frozen=True)
class FailsafePath:
    """A path the vehicle would fly on a failsafe (an RTL from some point, a fence breach
    return), as a failsafe audit checked it: ``xy_m`` (P, 2); ``ok`` False when it failed."""

    name: str
    xy_m: NDArray[np.float64]
    ok: bool = True
    note: str = ""


@dataclass(frozen=True)
class Wind:
    """The wind a plan was checked against: ``speed_mps`` blowing FROM ``from_deg`` (degrees
    clockwise from north, as a forecast gives it)."""

    speed_mps: float
    from_deg: float
    note: str = ""


@dataclass(frozen=True)
class ViewInputs:
    """Everything one view draws. ``flight`` is the plan resolved on the site
    (:func:`validator.flight.resolve_flight`); ``tracks`` are drawn in order and the first one
    leads the time slider's node and rate read-outs."""

    plan: Plan
    site: Site
    flight: Flight
    tracks: tuple[TrackLayer, ...] = ()
    failsafe_paths: tuple[FailsafePath, ...] = ()
    wind: Wind | None = None
    title: str = ""


def validation_inputs(v: Validation, title: str = "") -> ViewInputs:
    """A :class:`~validator.validation.Validation`'s view: its plan and site, its replay and
    the flown track of its flight (SITL or a recorded one), when it has them."""
    tracks = []
    if v.replay_track is not None and v.profile is not None:
        tracks.append(TrackLayer(f"replay ({v.profile.name})", v.replay_track))
    if v.recorded is not None:
        who = v.extra.get("sitl_flight", {}).get("kind", "recorded")
        if "recorded_flight" in v.extra:
            who = f"recorded, {Path(v.extra['recorded_flight']['file']).name}"
        tracks.append(TrackLayer(f"flown ({who})", v.recorded.track(v.flight, v.site)))
    return ViewInputs(v.plan, v.site, v.flight, tuple(tracks),
                      title=title or f"{v.site.name}: {Path(v.plan_path).name}")
