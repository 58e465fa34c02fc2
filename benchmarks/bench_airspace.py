"""Country-scale UAS zones: reading and selecting a national ED-269 file, and what it costs a plan.

Run by hand (figures, not pass/fail):

    .venv/bin/python benchmarks/bench_airspace.py [--zones 2500] [--repeat 3]

Writes into a temporary folder a generated ED-269 file of ``--zones`` zones (about 70 %
polygons of 40 to 90 vertices, the rest circles; radii 0.2 to 5 km; restrictions, units,
references and schedules mixed, limits written as numbers, strings and null as published
files do) spread over a country-sized box round Switzerland, with the zones of
``samples/airspace-zones.json`` among them, and the sample site ``samples/airspace.yaml``
pointing at it. Prints
1. the file's size, zones and vertices; reading and selecting (``load_site``: parse, index,
   select, decide) the first time and again (the file kept read); target: at most 1 s;
2. planning (``plan_and_build``) that site against planning the same site with only the zones
   selected written natively in the site file (``no_fly_zones``), medians of ``--repeat`` runs
   interleaved (the cores are shared: load falls on both alike); target: within 10 %.
"""

from __future__ import annotations

import json
import math
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from mission_planner.mission import MissionOptions
from mission_planner.pipeline import plan_and_build
from validator import airspace as airspace_module
from validator.errors import CommandParser
from validator.site import Site, load_site
from validator.uas_zones.applicability import AirspaceOptions, parse_at

ROOT = Path(__file__).resolve().parents[1]
SAMPLE_SITE = ROOT / "samples" / "airspace.yaml"
SAMPLE_ZONES = ROOT / "samples" / "airspace-zones.json"
AT = "2026-12-02T10:00+01:00"
BOX = (45.8, 47.8, 5.9, 10.5)  # lat, lat, lon, lon: about 220 km x 350 km
KEEP_CLEAR_M = 8_000.0  # no generated zone this near the sample site
M_PER_DEG = 111_195.0


def generated_zone(i: int, rng: np.random.Generator, lat0: float, lon0: float) -> dict[str, Any]:
    """One random zone as a national file writes it."""
    radius_m = float(rng.uniform(200.0, 5000.0))
    k = math.cos(math.radians(lat0))
    uom = "FT" if rng.random() < 0.2 else "M"
    f = 1 / 0.3048 if uom == "FT" else 1.0
    upper: Any = rng.choice([120, "150", 99999, None, 300])
    lower: Any = rng.choice([None, 0, "0"]) if rng.random() < 0.8 else int(rng.uniform(60, 100))
    if isinstance(lower, int):
        lower, upper = int(lower * f), 99999  # a zone high above: no ceiling
    ref = "AMSL" if rng.random() < 0.3 else "AGL"
    if ref == "AMSL" and upper is not None and str(upper) != "99999":
        upper = int(float(upper) * f + 600)
    if rng.random() < 0.7:
        n = int(rng.integers(40, 91))
        t = np.sort(rng.uniform(0, 2 * np.pi, n))
        r = radius_m * (0.7 + 0.3 * rng.random(n))
        ring = [[round(lon0 + float(ri * np.cos(ti)) / (M_PER_DEG * k), 7),
                 round(lat0 + float(ri * np.sin(ti)) / M_PER_DEG, 7)]
                for ti, ri in zip(t, r, strict=True)]
        hp: dict[str, Any] = {"type": "Polygon", "coordinates": [ring + ring[:1]]}
    else:
        hp = {"type": "Circle", "center": [round(lon0, 7), round(lat0, 7)],
              "radius": round(radius_m * f, 1)}
    app: list[dict[str, Any]] = [{"permanent": "YES"}]
    if rng.random() < 0.2:
        app = [{"permanent": "NO", "startDateTime": "2026-01-01T00:00:00Z",
                "endDateTime": "2026-12-31T23:59:59Z",
                "dailyPeriod": [{"day": ["SAT", "SUN"], "startTime": "08:00:00+01:00",
                                 "endTime": "20:00:00+01:00"}]}]
    return {"identifier": f"G{i:05d}", "country": "CHE", "name": f"Generated zone {i}",
            "type": "COMMON",
            "restriction": str(rng.choice(["PROHIBITED", "REQ_AUTHORISATION", "CONDITIONAL",
                                           "NO_RESTRICTION"], p=[0.4, 0.3, 0.2, 0.1])),
            "reason": ["OTHER"], "applicability": app,
            "zoneAuthority": [{"name": "Generated", "purpose": "AUTHORIZATION"}],
            "geometry": [{"uomDimensions": uom, "lowerLimit": lower,
                          "lowerVerticalReference": ref, "upperLimit": upper,
                          "upperVerticalReference": ref, "horizontalProjection": hp}]}


def country_file(folder: Path, zones: int) -> tuple[Path, int]:
    """The generated file (with the sample's zones) and its vertex count."""
    rng = np.random.default_rng(28)
    site = yaml.safe_load(SAMPLE_SITE.read_text())
    lat_s, lon_s = site["origin"]["lat"], site["origin"]["lon"]
    out = json.loads(SAMPLE_ZONES.read_text())["features"]
    while len(out) < zones:
        lat0, lon0 = rng.uniform(*BOX[:2]), rng.uniform(*BOX[2:])
        d = math.hypot((lat0 - lat_s) * M_PER_DEG,
                       (lon0 - lon_s) * M_PER_DEG * math.cos(math.radians(lat_s)))
        if d > KEEP_CLEAR_M:
            out.append(generated_zone(len(out), rng, lat0, lon0))
    vertices = sum(len(g["horizontalProjection"].get("coordinates", [[]])[0])
                   for z in out for g in z["geometry"])
    path = folder / "country-ed269.json"
    path.write_text(json.dumps({"UASZoneList": out, "formatVersion": "1.0"}))
    return path, vertices


def native_site(site_file: Path, site: Site, folder: Path) -> Path:
    """The same site with only the zones ``site`` took, written natively (local metres)."""
    data = yaml.safe_load(site_file.read_text())
    data.pop("airspace")
    data["no_fly_zones"] = [
        {"name": n, "x": float(x), "y": float(y), "radius": float(r)}
        for n, (x, y), r in zip(site.nfz_names, site.nfz_xy_m, site.nfz_radius_m, strict=True)
    ] + [{"name": z.name, "polygon": [{"x": float(x), "y": float(y)} for x, y in z.vertices_xy_m]}
         for z in site.polygon_zones]
    path = folder / "native.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def plan_s(sites: tuple[Site, Site], repeat: int) -> list[tuple[list[float], float]]:
    """Each site planned ``repeat`` times, the two interleaved so that the machine's load
    (shared cores) falls on both alike: the times (s) and the min rate of each."""
    out: list[tuple[list[float], float]] = [([], math.nan), ([], math.nan)]
    for _ in range(repeat):
        for k, site in enumerate(sites):
            t0 = time.perf_counter()
            mission = plan_and_build(site, "proposed", MissionOptions())
            out[k][0].append(time.perf_counter() - t0)
            out[k] = (out[k][0], mission.solution.min_rate_bps_hz)
    return out


def main() -> None:
    ap = CommandParser(description=__doc__.splitlines()[0])
    ap.add_argument("--zones", type=int, default=2500)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    options = AirspaceOptions(parse_at(AT), 600.0)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        zones_file, vertices = country_file(folder, args.zones)
        site_file = folder / "site.yaml"
        data = yaml.safe_load(SAMPLE_SITE.read_text()) | {"airspace": zones_file.name}
        site_file.write_text(yaml.safe_dump(data))
        size = zones_file.stat().st_size
        print(f"file: {args.zones} zones, {vertices} polygon vertices, {size / 2**20:.1f} MiB")
        airspace_module._READ.clear()
        t0 = time.perf_counter()
        site = load_site(site_file, options)
        cold = time.perf_counter() - t0
        t0 = time.perf_counter()
        load_site(site_file, options)
        warm = time.perf_counter() - t0
        print(f"read + select (load_site): first {cold:.3f} s, again {warm:.3f} s "
              f"(target <= 1 s); {len(site.airspace.table)} zones within reach, "
              f"{len(site.zone_names)} taken: {', '.join(site.zone_names)}")
        native = load_site(native_site(site_file, site, folder))
        (big, big_rate), (nat, nat_rate) = plan_s((site, native), args.repeat)
        big_s, nat_s = statistics.median(big), statistics.median(nat)
        print(f"plan (median of {args.repeat}, interleaved): with the country file {big_s:.2f} s "
              f"(min rate {big_rate:.4f}; runs {', '.join(f'{t:.2f}' for t in big)}), selected "
              f"zones written natively {nat_s:.2f} s (min rate {nat_rate:.4f}; runs "
              f"{', '.join(f'{t:.2f}' for t in nat)}): {100 * (big_s / nat_s - 1):+.1f} % "
              "(target within 10 %)")


if __name__ == "__main__":
    main()
