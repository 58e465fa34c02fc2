"""A site's ``airspace:`` files as the zones the site takes, and the table of what was decided.

Plain GeoJSON zones always apply, as before. UAS zones (ED-269, ED-318) within reach of the
site (:func:`validator.uas_zones.selection.reach_area` round its home and nodes) are each
decided (:func:`validator.uas_zones.applicability.decide`); the volumes that apply become
zones (merged where they overlap, coarsened outward only), and every zone within reach is a row
of the table: taken, or why not.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from validator.airspace import read_airspace_file
from validator.errors import InputError
from validator.geodesy import LocalFrame
from validator.input_files import MAX_SITE_BYTES, parse_yaml, read_text, resolve_referenced_path
from validator.uas_zones.applicability import (
    AirspaceOptions,
    Band,
    ZoneDecision,
    check_authorised,
    decide,
)
from validator.uas_zones.model import UasZone
from validator.uas_zones.selection import (
    ZoneShape,
    merged,
    reach_area,
    volume_shape,
    within_reach,
)


@dataclass(frozen=True)
class SiteAirspace:
    """The zones a site takes from its airspace files (``shapes``), the decision on every UAS
    zone within reach (``table``, file order) and the options they were decided under."""

    shapes: tuple[ZoneShape, ...] = ()
    table: tuple[ZoneDecision, ...] = ()
    options: AirspaceOptions = field(default_factory=AirspaceOptions)
    uas: bool = False  # whether any file holds UAS zones (ED-269 / ED-318)
    reach_m: shapely.Polygon | None = None  # where UAS zones were looked for (local metres)

    def report(self) -> dict[str, object]:
        """The report's ``"airspace"`` section."""
        window = self.options.window
        return {
            "at": None if window is None else window[0].isoformat(timespec="seconds"),
            "until": None if window is None else window[1].isoformat(timespec="seconds"),
            "authorised": sorted(self.options.authorised),
            "zones": [d.as_dict() for d in self.table],
            "taken": [s.name for s in self.shapes],
        }

    def lines(self) -> list[str]:
        """The table for a terminal: a line per UAS zone within reach, taken or why not."""
        if not self.uas:
            return []
        window = self.options.window
        head = ("airspace: every zone taken as active (no --at)" if window is None else
                f"airspace from {window[0].isoformat(timespec='seconds')} to "
                f"{window[1].isoformat(timespec='seconds')}")
        out = [f"{head}: {sum(d.taken for d in self.table)} of {len(self.table)} zones "
               "within reach taken"]
        for d in self.table:
            out.append(f"  zone {d.zone.identifier} ({d.zone.restriction}): "
                       + ("taken, " if d.taken else "not taken: ") + d.why)
        return out


def airspace_paths(names: str | Sequence[str] | None, base_file: str | Path | None,
                   source: str) -> list[Path]:
    """The files a site's ``airspace:`` names (one or a list), resolved from the site file's
    folder: the one rule for the loader and for the commands that must not write over them
    (:func:`site_inputs`)."""
    listed = [names] if isinstance(names, str) else list(names or [])
    if not listed:
        return []
    if base_file is None:
        raise InputError(f"{source}: airspace: only a site file read from disk may name an "
                         "airspace file (it is found relative to the site file)")
    return [resolve_referenced_path(base_file, a, field="airspace") for a in listed]


def site_inputs(path: str | Path) -> dict[str, Path]:
    """Every file a command that reads the site at ``path`` reads, by what it is to the user:
    the site file and the airspace files it names, for
    :func:`validator.output_paths.check_output_paths` (an output there would replace the
    site's zones with a plan). A site that cannot be read here names only itself: loading it
    reports why, by the loader's rules."""
    inputs = {"the site file": Path(path)}
    try:
        data: Any = parse_yaml(read_text(Path(path), "site", MAX_SITE_BYTES), str(path))
        names = data.get("airspace") if isinstance(data, dict) else None
        if not isinstance(names, str | list | None):
            return inputs
        files = airspace_paths(names, path, str(path))
    except (InputError, OSError):
        return inputs
    for i, f in enumerate(files):
        inputs["the site's airspace" + (f"[{i}]" if len(files) > 1 else "") + " file"] = f
    return inputs


def site_airspace(paths: Sequence[str | Path], frame: LocalFrame,
                  points_m: NDArray[np.float64], band: Band,
                  options: AirspaceOptions | None = None) -> SiteAirspace:
    """The zones the site at ``frame`` (home and nodes ``points_m``, flying in ``band``) takes
    from the airspace files ``paths``, under ``options`` (time, duration, authorisations)."""
    options = options or AirspaceOptions()
    files = [read_airspace_file(p) for p in paths]
    shapes: list[ZoneShape] = []
    for f in files:
        for a in f.plain:
            if a.radius_m is not None:
                shapes.append(ZoneShape(a.name, a.where, frame.to_local(*a.lat_lon_deg[0]),
                                        a.radius_m))
            else:
                shapes.append(ZoneShape(a.name, a.where, vertices_m=frame.to_local(
                    a.lat_lon_deg[:, 0], a.lat_lon_deg[:, 1])))
    indexes = [f.uas for f in files if f.uas is not None]
    if not indexes:
        if options.authorised:
            raise InputError(f"--authorised {sorted(options.authorised)[0]}: the site names no "
                             "UAS zones (ED-269 or ED-318 airspace)")
        return SiteAirspace(tuple(shapes), (), options, False)
    every = _unique([z for ix in indexes for z in ix.zones])
    check_authorised(every, options.authorised)
    area = reach_area(points_m)
    table: list[ZoneDecision] = []
    pieces: list[ZoneShape] = []
    for ix in indexes:
        for i in within_reach(ix, frame, area):
            zone = ix.zones[i]
            d = decide(zone, band, options)
            table.append(d)
            for k in d.volumes:
                name = zone.identifier if len(d.volumes) == 1 else f"{zone.identifier}/{k + 1}"
                shape = volume_shape(zone, k, frame)
                v = zone.volumes[k]
                if v.radius_m is not None:
                    pieces.append(ZoneShape(name, zone.where, np.array([shape.x, shape.y]),
                                            v.radius_m))
                else:
                    pieces.append(ZoneShape(name, zone.where, vertices_m=np.asarray(
                        shape.exterior.coords, dtype=float)[:-1]))
    return SiteAirspace(tuple(shapes + merged(pieces)), tuple(table), options, True, area)


def _unique(zones: list[UasZone]) -> list[UasZone]:
    seen: dict[str, str] = {}
    for z in zones:
        if z.identifier in seen:
            raise InputError(f"{z.where}: duplicate zone identifier (also {seen[z.identifier]})")
        seen[z.identifier] = z.where
    return zones
