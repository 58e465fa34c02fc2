"""Recorded flights as files: the telemetry a vehicle sent, written as CSV and read back.

``validate-mission --sitl… --track OUT.csv`` keeps what the vehicle flew, so that a flight
can be scored again, plotted, or used to calibrate the replay without flying it again. One
row per position report (GLOBAL_POSITION_INT):

``t_s``
    seconds from the start of the takeoff (the replay's clock; negative before it);
``lat_deg``, ``lon_deg``
    WGS84 degrees;
``alt_m``
    metres above home;
``vn_mps``, ``ve_mps``, ``vd_mps``
    ground velocity north, east, down (m/s);
``item``
    the current mission item as a 0-based ``.plan`` index (ArduPilot's wire sequence minus
    one; PX4's as sent), -1 before the mission. The column keeps the index so that files
    already written read the same; what is shown to a person (the timeline, findings) is the
    item's number, index + 1 (:mod:`validator.item_numbers`);
``armed``, ``fence_breach``
    0 or 1;
``left_mission``
    1 from the first time the vehicle left its mission mode on its own (a failsafe, a fence
    action), else 0: the items after it are no cycle flown. Files written before this column
    read with 0 throughout.

``#`` lines at the top are comments (the vehicle, the plan). A ``.gz`` name is compressed.
"""

from __future__ import annotations

import gzip
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from validator.errors import InputError
from validator.fileio import write_atomic
from validator.flight import Flight
from validator.input_files import MAX_FILE_BYTES, read_text
from validator.replay import Track, track_from_geodetic
from validator.site import MAX_REACH_M, Site

COLUMNS = ("t_s", "lat_deg", "lon_deg", "alt_m", "vn_mps", "ve_mps", "vd_mps", "item",
           "armed", "fence_breach", "left_mission")
_BEFORE_LEFT_MISSION = COLUMNS[:-1]  # the header of files written before ``left_mission``


@dataclass(frozen=True)
class RecordedTrack:
    """A recorded flight, one entry per position report (see the module doc for the columns)."""

    t_s: NDArray[np.float64]
    lat_deg: NDArray[np.float64]
    lon_deg: NDArray[np.float64]
    alt_m: NDArray[np.float64]
    vel_ned_mps: NDArray[np.float64]  # (n, 3)
    item: NDArray[np.int64]
    armed: NDArray[np.bool_]
    fence_breach: NDArray[np.bool_]
    left_mission: NDArray[np.bool_] | None = None  # None: never left (or not recorded)

    @property
    def left_mission_s(self) -> float | None:
        """When the vehicle first left its mission mode on its own (s), None if it never did."""
        if self.left_mission is None or not self.left_mission.any():
            return None
        return float(self.t_s[int(np.argmax(self.left_mission))])

    def track(self, flight: Flight, site: Site, source: str = "recorded") -> Track:
        """The flight from the takeoff on, aligned with ``flight``: the climb before the
        vehicle reports an item past the mission's takeoff counts as that takeoff, and items
        are timed up to :attr:`left_mission_s` (a failsafe's return is no cycle flown)."""
        keep = self.t_s >= 0
        item = self.item[keep].copy()
        if flight.legs and flight.legs[0].kind == "takeoff":
            past = np.flatnonzero(item > flight.legs[0].item)
            item[: past[0] if past.size else item.size] = flight.legs[0].item
        return track_from_geodetic(flight, site, self.t_s[keep], self.lat_deg[keep],
                                   self.lon_deg[keep], item, alt_m=self.alt_m[keep],
                                   source=source, left_mission_s=self.left_mission_s)

    @property
    def disarmed_s(self) -> float:
        """First time (s) the vehicle reported disarmed after having been armed; NaN if never."""
        was = np.flatnonzero(self.armed)
        if not was.size:
            return math.nan
        after = np.flatnonzero(~self.armed[was[0]:])
        return float(self.t_s[was[0] + after[0]]) if after.size else math.nan


def dumps_track(rec: RecordedTrack, comments: tuple[str, ...] = ()) -> str:
    """The CSV text of ``rec`` (see the module doc)."""
    out = io.StringIO()
    for c in comments:
        out.write(f"# {c}\n")
    out.write(",".join(COLUMNS) + "\n")
    left = np.zeros(rec.t_s.size, bool) if rec.left_mission is None else rec.left_mission
    for k in range(rec.t_s.size):
        vn, ve, vd = rec.vel_ned_mps[k]
        out.write(f"{rec.t_s[k]:.3f},{rec.lat_deg[k]:.8f},{rec.lon_deg[k]:.8f},"
                  f"{rec.alt_m[k]:.3f},{vn:.2f},{ve:.2f},{vd:.2f},{int(rec.item[k])},"
                  f"{int(rec.armed[k])},{int(rec.fence_breach[k])},{int(left[k])}\n")
    return out.getvalue()


def write_track(path: str | Path, rec: RecordedTrack, comments: tuple[str, ...] = ()) -> None:
    """Write ``rec`` to ``path`` atomically (gzip-compressed when the name ends in ``.gz``)."""
    text = dumps_track(rec, comments)
    data = gzip.compress(text.encode(), mtime=0) if str(path).endswith(".gz") else text
    write_atomic(path, data)


# Column, name and the largest magnitude a sample may have: a latitude of 91 had been scored
# as 5,127 km of cross-track error and a CLEAR flight; altitudes and items within a mission's
# reach (validator.site.MAX_REACH_M) and MAVLink's uint16 item numbers.
_BOUNDS = ((1, "lat_deg", 90.0), (2, "lon_deg", 180.0), (3, "alt_m", MAX_REACH_M),
           (7, "item", 65535.0))


def read_track(path: str | Path) -> RecordedTrack:
    """Read a track file written by :func:`write_track`; :class:`InputError` naming the file
    and the line for anything else."""
    p = Path(path)
    if p.suffix == ".gz":
        try:
            with gzip.open(p, "rb") as f:
                raw = f.read(MAX_FILE_BYTES + 1)
        except FileNotFoundError as err:
            raise InputError(f"{p}: cannot read track file ({err.strerror})") from None
        except (OSError, EOFError) as err:
            raise InputError(f"{p}: not a gzip-compressed track file ({err})") from None
        if len(raw) > MAX_FILE_BYTES:
            raise InputError(f"{p}: track file too large (over {MAX_FILE_BYTES} bytes)")
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError:
            raise InputError(f"{p}: track file is not UTF-8 text") from None
    else:
        text = read_text(p, "track")
    lines = [(n, line) for n, line in enumerate(text.splitlines(), 1)
             if line.strip() and not line.startswith("#")]
    header = tuple(lines[0][1].strip().split(",")) if lines else ()
    if header not in (COLUMNS, _BEFORE_LEFT_MISSION):
        raise InputError(f"{p}: not a track file (expected the header {','.join(COLUMNS)})")
    rows: list[list[float]] = []
    for n, line in lines[1:]:
        fields = line.split(",")
        try:
            row = [float(f) for f in fields]
        except ValueError:
            row = []
        if len(row) != len(header) or not all(math.isfinite(x) for x in row):
            raise InputError(f"{p}: line {n}: expected {len(header)} finite numbers")
        rows.append(row)
    if not rows:
        raise InputError(f"{p}: no samples")
    a = np.asarray(rows, dtype=float)
    line_of = [n for n, _ in lines[1:]]
    for col, name, bound in _BOUNDS:
        out = np.flatnonzero(~(np.abs(a[:, col]) <= bound))
        if out.size:
            raise InputError(f"{p}: line {line_of[out[0]]}: {name} {a[out[0], col]:g} beyond "
                             f"±{bound:g}")
    odd = np.flatnonzero(a[:, 7] != np.round(a[:, 7]))
    if odd.size:
        raise InputError(f"{p}: line {line_of[odd[0]]}: item {a[odd[0], 7]:g} is no item index "
                         "(the column holds 0-based indices)")
    if np.any(np.diff(a[:, 0]) < 0):
        raise InputError(f"{p}: t_s must not decrease")
    if len(header) > 10 and np.any(np.diff(a[:, 10]) < 0):
        raise InputError(f"{p}: left_mission must not go back to 0 once it is 1")
    return RecordedTrack(a[:, 0], a[:, 1], a[:, 2], a[:, 3], a[:, 4:7],
                         a[:, 7].astype(np.int64), a[:, 8] != 0, a[:, 9] != 0,
                         a[:, 10] != 0 if len(header) > 10 else None)


__all__ = ["COLUMNS", "RecordedTrack", "dumps_track", "read_track", "write_track"]
