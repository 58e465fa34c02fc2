"""UAS geographical zones (ED-269, ED-318): read as published files write them, decided per zone
(height band, time window, restriction, authorisation), selected by reach, merged and coarsened
outward only, and refused with one line naming the zone and field."""

from __future__ import annotations

import copy
import json
import math
import shutil
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import shapely
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from validator.airspace import read_airspace_file
from validator.errors import InputError
from validator.geodesy import LocalFrame
from validator.site import Site, load_site
from validator.uas_zones.applicability import AirspaceOptions, parse_at
from validator.uas_zones.selection import reach_area, within_reach, zone_index
from validator.zones import outward_simplified, point_clearance_m

DATA = Path(__file__).parents[1] / "data" / "airspace"
ED269 = json.loads((DATA / "zones-ed269.json").read_text())
ED318 = json.loads((DATA / "zones-ed318.geojson").read_text())
SITE = yaml.safe_load((DATA / "site.yaml").read_text())


def _site(tmp: Path, zones: Any = None, name: str = "zones.json", at: str | None = None,
          duration_s: float = 600.0, authorised: tuple[str, ...] = (), **site: Any) -> Site:
    """The test site with ``zones`` (default: the ED-269 file) as its airspace."""
    (tmp / name).write_text(json.dumps(ED269 if zones is None else zones))
    (tmp / "site.yaml").write_text(yaml.safe_dump({**SITE, "airspace": name, **site}))
    options = AirspaceOptions(parse_at(at) if at else None, duration_s, frozenset(authorised))
    return load_site(tmp / "site.yaml", options)


def _table(site: Site) -> dict[str, tuple[bool, str]]:
    return {d.zone.identifier: (d.taken, d.why) for d in site.airspace.table}


def _zone(doc: dict[str, Any], ident: str) -> dict[str, Any]:
    return next(z for z in doc["UASZoneList"] if z["identifier"] == ident)


def test_every_zone_within_reach_is_taken_or_says_why_not(tmp_path: Path) -> None:
    table = _table(_site(tmp_path, at="2026-12-02T10:00:00+01:00"))
    assert {k: v[0] for k, v in table.items()} == {
        "Z1": True, "Z2": True, "Z3": True, "Z4": False, "Z5": False, "Z6": False,
        "Z7": False, "Z8": False, "Z9": True}
    assert table["Z4"][1] == "above the ceiling"
    assert table["Z5"][1] == "below the floor"
    assert table["Z6"][1] == table["Z8"][1] == "inactive"
    assert table["Z7"][1] == "no restriction"
    assert '"Notify 24 h before"' in table["Z3"][1]  # the conditions, quoted
    assert "ZFAR" not in table  # 40 km away: not within reach


def test_the_zones_taken_are_the_zones_the_planner_avoids(tmp_path: Path) -> None:
    site = _site(tmp_path, at="2026-12-02T10:00:00+01:00")
    assert sorted(site.zone_names) == ["Z1", "Z2", "Z3", "Z9"]
    assert site.nfz_names == ("Z2",)  # the circle stays a circle
    assert site.nfz_radius_m[0] == pytest.approx(40.0, abs=1e-6)  # 131.2 ft


def test_ed318_says_the_same_as_ed269(tmp_path: Path) -> None:
    a = _site(tmp_path, at="2026-12-02T22:30:00+01:00")
    b = _site(tmp_path, ED318, "zones.geojson", at="2026-12-02T22:30:00+01:00")
    assert read_airspace_file(tmp_path / "zones.geojson").format == "ed318"
    assert {k: v[0] for k, v in _table(a).items()} == {k: v[0] for k, v in _table(b).items()}
    assert sorted(a.zone_names) == sorted(b.zone_names)
    for za, zb in zip(sorted(a.polygon_zones, key=lambda z: z.name),
                      sorted(b.polygon_zones, key=lambda z: z.name), strict=True):
        assert np.allclose(np.sort(za.vertices_xy_m, axis=0), np.sort(zb.vertices_xy_m, axis=0))


def test_plain_geojson_is_still_plain(tmp_path: Path) -> None:
    site = load_site(Path(__file__).parents[2] / "samples" / "airfield.yaml")
    assert "PRISON" in site.zone_names and not site.airspace.uas


def test_a_schedule_past_midnight_and_a_zone_that_starts_during_the_flight(tmp_path) -> None:
    night = _table(_site(tmp_path, at="2026-12-03T05:50:00+01:00", duration_s=300))
    assert night["Z6"][0]  # Wednesday's 22:00-06:00 reaches Thursday morning
    assert not _table(_site(tmp_path, at="2026-12-05T23:00:00+01:00"))["Z6"][0]  # Saturday
    # Z8 starts at 10:30Z: a flight from 11:25 (+01:00) for 10 minutes meets it, 5 minutes not
    assert _table(_site(tmp_path, at="2026-12-02T11:25:00+01:00", duration_s=600))["Z8"][0]
    assert not _table(_site(tmp_path, at="2026-12-02T11:25:00+01:00",
                            duration_s=240))["Z8"][0]


def test_without_a_time_every_zone_is_taken_as_active(tmp_path: Path) -> None:
    site = _site(tmp_path)
    table = _table(site)
    assert table["Z6"][0] and table["Z8"][0]
    assert any("no --at" in n for d in site.airspace.table for n in d.as_dict()["notes"])


def test_height_band_follows_altitude_buffer_and_ground_elevation(tmp_path: Path) -> None:
    # Z4's floor is 150 m AGL: taken once the band (altitude + buffer) reaches it
    assert _table(_site(tmp_path, uav={**SITE["uav"], "altitude": 148.0}))["Z4"][0]
    assert not _table(_site(tmp_path, uav={**SITE["uav"], "altitude": 147.9}))["Z4"][0]
    # Z9 starts 440 m AMSL: 40 m above a 400 m ground (in the 52 m band), 60 m above a 380 m
    # one; Z5 ends 350 m AMSL: under a 400 m ground, 50 m above a 300 m one
    assert _table(_site(tmp_path, origin={**SITE["origin"], "alt": 380.0}))["Z9"] == (
        False, "above the ceiling")
    assert _table(_site(tmp_path, origin={**SITE["origin"], "alt": 300.0}))["Z5"][0]


def test_feet_and_open_ceilings(tmp_path: Path) -> None:
    site = _site(tmp_path)
    by_id = {d.zone.identifier: d.zone for d in site.airspace.table}
    assert by_id["Z2"].volumes[0].upper.value_m == pytest.approx(300 * 0.3048)
    assert math.isinf(by_id["Z4"].volumes[0].upper.value_m)  # 99999 is no ceiling
    assert math.isinf(by_id["Z9"].volumes[0].upper.value_m)  # null is no ceiling
    assert by_id["Z1"].volumes[0].lower.value_m == 0.0  # null is the surface
    assert by_id["Z1"].volumes[0].upper.value_m == 120.0  # "120", a string


def test_authorised_lifts_only_the_zones_it_names(tmp_path: Path) -> None:
    table = _table(_site(tmp_path, authorised=("Z2", "Z3")))
    assert table["Z2"] == (False, "authorised") and table["Z3"] == (False, "authorised")
    assert table["Z1"][0]
    with pytest.raises(InputError, match=r"--authorised Z1: .*PROHIBITED"):
        _site(tmp_path, authorised=("Z1",))
    with pytest.raises(InputError, match=r"--authorised NOPE: no zone"):
        _site(tmp_path, authorised=("NOPE",))


def test_a_node_inside_an_applicable_zone_is_refused_naming_it(tmp_path: Path) -> None:
    nodes = [*SITE["ground_nodes"], {"name": "GN5", "x": 80.0, "y": 0.0}]  # inside Z1
    with pytest.raises(InputError, match=r"ground_nodes\[4\] \(GN5\): lies inside Z1"):
        _site(tmp_path, ground_nodes=nodes)
    nodes[-1] = {"name": "GN5", "x": 0.0, "y": 100.0}  # inside Z4, which is above the band
    assert "GN5" in _site(tmp_path, ground_nodes=nodes).gn_names


def test_overlapping_zones_merge_into_one_that_holds_both(tmp_path: Path) -> None:
    doc = copy.deepcopy(ED269)
    z = copy.deepcopy(_zone(doc, "Z1"))
    z["identifier"] = "Z1B"
    ring = z["geometry"][0]["horizontalProjection"]["coordinates"][0]
    z["geometry"][0]["horizontalProjection"]["coordinates"][0] = [[p[0] + 0.0005, p[1] + 0.0002]
                                                                  for p in ring]
    doc["UASZoneList"].append(z)
    site = _site(tmp_path, doc)
    merged = next(p for p in site.polygon_zones if p.name == "Z1+Z1B")
    for ident in ("Z1", "Z1B"):
        lonlat = np.asarray(_zone(doc, ident)["geometry"][0]["horizontalProjection"]
                            ["coordinates"][0], dtype=float)
        xy = site.frame.to_local(lonlat[:, 1], lonlat[:, 0])
        assert np.all(point_clearance_m(merged, xy) <= 1e-6)  # every corner inside or on it


def test_a_large_zone_is_coarsened_outward_only(tmp_path: Path) -> None:
    doc = copy.deepcopy(ED269)
    frame = LocalFrame(47.0, 8.0, 400.0)
    t = np.linspace(0.0, 2 * np.pi, 400, endpoint=False)
    r = 60.0 + 15.0 * np.sin(9 * t)
    xy = np.column_stack([r * np.cos(t) - 120.0, r * np.sin(t) - 300.0])
    lat, lon = frame.to_geodetic(xy)
    z = copy.deepcopy(_zone(doc, "Z1"))
    z["identifier"] = "STAR"
    ring = [[float(b), float(a)] for a, b in zip(lat, lon, strict=True)]
    z["geometry"][0]["horizontalProjection"]["coordinates"] = [ring + ring[:1]]
    doc["UASZoneList"].append(z)
    star = next(p for p in _site(tmp_path, doc).polygon_zones if p.name == "STAR")
    assert len(star.vertices_xy_m) <= 64
    assert star.shape.buffer(1e-6).covers(shapely.Polygon(frame.to_local(lat, lon)))


def test_the_index_finds_what_a_full_scan_finds() -> None:
    zones = read_airspace_file(DATA / "zones-ed269.json").uas
    assert zones is not None
    frame = LocalFrame(47.0, 8.0, 400.0)
    rng = np.random.default_rng(5)
    for _ in range(20):
        pts = rng.uniform(-3000, 3000, size=(3, 2))
        area = reach_area(pts)
        scan = [i for i, z in enumerate(zones.zones)
                if within_reach(zone_index([z]), frame, area)]
        assert within_reach(zones, frame, area) == scan


def test_an_empty_daily_period_beside_permanent_yes_is_permanent(tmp_path: Path) -> None:
    """The public Swiss ED-269 sample writes ``permanent: YES`` with a daily period of no day
    and null times: a placeholder, so the zone applies at every time."""
    doc = copy.deepcopy(ED269)
    _zone(doc, "Z1")["applicability"] = [{
        "permanent": "YES", "startDateTime": None, "endDateTime": None,
        "dailyPeriod": [{"day": [], "startTime": None, "endTime": None}]}]
    for at in ("2026-12-02T10:00+01:00", "2026-12-06T03:00+01:00"):
        assert _table(_site(tmp_path, doc, at=at))["Z1"][0]


@pytest.mark.parametrize(("path", "value", "message"), [
    (("geometry", 0, "upperLimit"), "high", r"\(Z1\)\.geometry\[0\]\.upperLimit: 'high' is not"),
    (("geometry", 0, "lowerVerticalReference"), "QNH", r"lowerVerticalReference: 'QNH'"),
    (("geometry", 0, "uomDimensions"), "KM", r"uomDimensions: 'KM' is not a unit"),
    (("restriction",), "FORBIDDEN", r"\(Z1\)\.restriction: 'FORBIDDEN'"),
    (("applicability",), [{"permanent": "NO", "startDateTime": "2026-12-02T10:00:00"}],
     r"startDateTime: .* has no time zone"),
    (("applicability",), [{"permanent": "NO", "dailyPeriod": [
        {"day": ["MON"], "startTime": "08:00", "endTime": "10:00Z"}]}],
     r"dailyPeriod\[0\]\.startTime: '08:00' has no time zone"),
    (("applicability",), [{"permanent": "YES", "dailyPeriod": [
        {"day": ["MON"], "startTime": "08:00Z", "endTime": "10:00Z"}]}], r"which is meant"),
])
def test_ambiguous_fields_are_refused_naming_zone_and_field(tmp_path: Path, path: tuple,
                                                            value: Any, message: str) -> None:
    doc = copy.deepcopy(ED269)
    node = _zone(doc, "Z1")
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    with pytest.raises(InputError, match=message) as err:
        _site(tmp_path, doc)
    assert "\n" not in str(err.value) and str(err.value).startswith(str(tmp_path))


def test_at_needs_its_time_zone() -> None:
    with pytest.raises(InputError, match="--at: .* no time zone"):
        parse_at("2026-12-02T10:00")
    assert parse_at("2026-12-02T10:00Z") == datetime.fromisoformat("2026-12-02T10:00+00:00")


def test_a_site_can_name_several_airspace_files(tmp_path: Path) -> None:
    shutil.copy(Path(__file__).parents[2] / "samples" / "airfield-airspace.geojson", tmp_path)
    site = _site(tmp_path, ED318, "zones.geojson")
    both = {**SITE, "airspace": ["zones.geojson", "airfield-airspace.geojson"]}
    (tmp_path / "both.yaml").write_text(yaml.safe_dump(both))
    combined = load_site(tmp_path / "both.yaml")
    assert set(combined.zone_names) == set(site.zone_names) | {"PRISON"}


def test_a_bare_zone_list_with_extra_fields_and_an_empty_schedule_is_read(tmp_path) -> None:
    """As a national feed serves it: no wrapper, a zoneId beyond the model, schedule: []."""
    zones = [{**copy.deepcopy(z), "zoneId": f"uuid-{i}"}
             for i, z in enumerate(ED269["UASZoneList"])]
    _zone({"UASZoneList": zones}, "Z8")["applicability"][0]["schedule"] = []
    site = _site(tmp_path, zones, at="2026-12-02T11:25:00+01:00", duration_s=600)
    assert read_airspace_file(tmp_path / "zones.json").format == "ed269"
    assert _table(site)["Z8"][0]  # an empty schedule: all day within its dates


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.integers(8, 300), st.integers(4, 40), st.floats(0.05, 0.6), st.integers(0, 2**31))
def test_outward_simplified_never_shrinks_and_keeps_its_vertex_budget(
        n: int, budget: int, wobble: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0.0, 2 * np.pi, n))
    t = t[np.concatenate([[True], np.diff(t) > 1e-3])]
    r = 100.0 * (1.0 - wobble * rng.random(len(t)))
    poly = shapely.Polygon(np.column_stack([r * np.cos(t), r * np.sin(t)]))
    if not poly.is_valid or len(t) < 3:
        return
    out = outward_simplified(np.asarray(poly.exterior.coords)[:-1], 1.0, budget)
    held = shapely.Polygon(out)
    assert len(out) <= max(budget, len(t)) and held.is_valid
    assert len(out) <= budget or len(t) <= budget
    assert held.buffer(1e-6).covers(poly)
