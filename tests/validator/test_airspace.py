"""GeoJSON airspace: zones from a FeatureCollection, and one clean error per bad input."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from tests.validator.test_site import _base
from validator.airspace import load_airspace, parse_airspace
from validator.errors import InputError
from validator.site import load_site

RING = [[127.0005, 37.5565], [127.0015, 37.5565], [127.001, 37.557], [127.0005, 37.5565]]


def _fc(*features: dict[str, Any]) -> dict[str, Any]:
    return {"type": "FeatureCollection", "features": list(features)}


def _feature(geometry: dict[str, Any], **props: Any) -> dict[str, Any]:
    return {"type": "Feature", "properties": props, "geometry": geometry}


def test_polygons_multipolygon_parts_and_circles_are_zones():
    zones = parse_airspace(_fc(
        _feature({"type": "Polygon", "coordinates": [RING]}, name="PRISON"),
        _feature({"type": "MultiPolygon", "coordinates": [[RING], [RING]]}, name="R1"),
        _feature({"type": "Point", "coordinates": [126.9985, 37.5605]}, name="MAST", radius_m=20),
        _feature({"type": "Polygon", "coordinates": [RING]}),
    ), "a.geojson")
    assert [z.name for z in zones] == ["PRISON", "R1/1", "R1/2", "MAST", "features[3]"]
    assert zones[0].lat_lon_deg[1].tolist() == [37.5565, 127.0015]  # GeoJSON is [lon, lat]
    assert zones[3].radius_m == 20.0 and zones[0].radius_m is None


@pytest.mark.parametrize("data, words", [
    ({"type": "Feature"}, "expected a GeoJSON FeatureCollection"),
    (_fc(_feature({"type": "LineString", "coordinates": RING}, name="L")),
     "features[0] (L).geometry: a LineString cannot be a zone"),
    (_fc(_feature({"type": "Polygon", "coordinates": [RING, RING]}, name="H")),
     "holes are not supported"),
    (_fc(_feature({"type": "Point", "coordinates": [127.0, 37.5]}, name="P")),
     "features[0] (P).properties.radius_m"),
    (_fc(_feature({"type": "Polygon", "coordinates": [[[127.0, 95.0], [127.1, 37.0],
                                                        [127.0, 37.1]]]}, name="B")),
     "is not a WGS84 [lon, lat]"),
    (_fc(_feature({"type": "Polygon", "coordinates": [[["a", 1], [2, 3], [4, 5]]]})),
     "expected a position"),
    (_fc(_feature({"type": "Polygon", "coordinates": [RING]}, name=3)), "properties.name"),
])
def test_bad_airspace_is_one_line_naming_the_feature(data, words):
    with pytest.raises(InputError) as err:
        parse_airspace(data, "a.geojson")
    msg = str(err.value)
    assert msg.startswith("a.geojson: ") and words in msg and "\n" not in msg


def _site_with_airspace(tmp_path: Path, airspace: Any, **extra: Any) -> Path:
    (tmp_path / "zones.geojson").write_text(json.dumps(airspace))
    data = _base() | {"airspace": "zones.geojson"} | extra
    site = tmp_path / "site.yaml"
    site.write_text(yaml.safe_dump(data))
    return site


def test_a_site_reads_its_airspace_beside_it(tmp_path):
    site = load_site(_site_with_airspace(tmp_path, _fc(
        _feature({"type": "Polygon", "coordinates": [RING]}, name="PRISON"),
        _feature({"type": "Point", "coordinates": [126.9985, 37.5605]}, name="MAST",
                 radius_m=20))))
    assert site.zone_names == ("NFZ1", "MAST", "PRISON")
    (prison,) = site.polygon_zones
    # 0.001° of longitude at 37.56° N is 88.3 m: the triangle's base, in the local frame
    assert np.ptp(prison.vertices_xy_m[:, 0]) == pytest.approx(88.3, abs=0.2)
    assert site.nfz_radius_m.tolist() == [30.0, 20.0]


def test_an_airspace_zone_overlapping_a_site_zone_names_both(tmp_path):
    ring = [[127.0007, 37.5603], [127.0009, 37.5603], [127.0008, 37.5604], [127.0007, 37.5603]]
    path = _site_with_airspace(tmp_path, _fc(
        _feature({"type": "Polygon", "coordinates": [ring]}, name="IN")))
    with pytest.raises(InputError, match=r"zones.geojson: features\[0\] \(IN\): overlaps NFZ1"):
        load_site(path)


def test_airspace_outside_the_site_folder_is_refused(tmp_path):
    (tmp_path / "sub").mkdir()
    path = _site_with_airspace(tmp_path / "sub", _fc())
    text = path.read_text().replace("zones.geojson", "../zones.geojson")
    path.write_text(text)
    with pytest.raises(InputError, match="airspace.*outside"):
        load_site(path)


def test_unreadable_airspace_names_the_file(tmp_path):
    (tmp_path / "zones.geojson").write_bytes(b"\xff\xfe{")
    site = tmp_path / "site.yaml"
    site.write_text(yaml.safe_dump(_base() | {"airspace": "zones.geojson"}))
    with pytest.raises(InputError, match="zones.geojson: airspace file is not UTF-8"):
        load_site(site)
    with pytest.raises(InputError, match="cannot read airspace file"):
        load_airspace(tmp_path / "missing.geojson")


def test_every_airspace_file_of_a_site_is_one_of_its_inputs(tmp_path):
    from validator.site_airspace import site_inputs

    site = tmp_path / "site.yaml"
    site.write_text(yaml.safe_dump(_base() | {"airspace": ["a.geojson", "b.json"]}))
    assert site_inputs(site) == {"the site file": site,
                                 "the site's airspace[0] file": tmp_path / "a.geojson",
                                 "the site's airspace[1] file": tmp_path / "b.json"}
