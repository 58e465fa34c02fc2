"""The site file: what it accepts, and one test per input it must reject (naming the field)."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from validator.errors import InputError
from validator.site import load_site, parse_site, site_to_dict

SAMPLE = Path(__file__).resolve().parents[2] / "samples" / "paper-default.yaml"


def _base() -> dict[str, Any]:
    return {
        "name": "t",
        "origin": {"lat": 37.5585, "lon": 126.999, "alt": 40.0},
        "home": {"x": 0.0, "y": 0.0},
        "uav": {"altitude": 30.0, "max_speed": 30.0, "period": 50.0, "slots": 50},
        "radio": {"p_avg_dbm": 20.0, "p_peak_dbm": 26.0206, "beta0_db": -30.0, "noise_dbm": -70.0},
        "ground_nodes": [
            {"name": "GN1", "x": 60.0, "y": 340.0},
            {"name": "GN2", "x": 300, "y": 50},
        ],
        "no_fly_zones": [{"name": "NFZ1", "x": 150.0, "y": 200.0, "radius": 30.0}],
    }


def _rejects(data: Any, *words: str) -> str:
    with pytest.raises(InputError) as err:
        parse_site(data, "site.yaml")
    msg = str(err.value)
    assert "\n" not in msg
    for word in words:
        assert word in msg, msg
    return msg


def test_sample_site_loads_in_si_units() -> None:
    site = load_site(SAMPLE)
    assert site.num_gns == 4 and site.num_nfzs == 3
    assert site.p_avg_w == pytest.approx(0.1)
    assert site.p_peak_w == pytest.approx(0.4, rel=1e-4)
    assert site.noise_w == pytest.approx(1e-10)
    assert site.beta0 == pytest.approx(1e-3)
    assert site.buffer_m == 2.0
    assert site.max_accel_mps2 == 2.5 and site.max_jerk_mps3 == 1.0


def test_geodetic_point_is_resolved_into_the_local_frame() -> None:
    data = _base()
    site = parse_site(data)
    lat, lon = site.frame.to_geodetic(np.array([60.0, 340.0]))
    data["ground_nodes"][0] = {"name": "GN1", "lat": float(lat), "lon": float(lon)}
    again = parse_site(data)
    assert np.allclose(again.gn_xy_m[0], [60.0, 340.0], atol=1e-6)


def test_site_round_trips_through_its_dict() -> None:
    site = load_site(SAMPLE)
    again = parse_site(site_to_dict(site))
    assert np.allclose(again.gn_xy_m, site.gn_xy_m)
    assert again.p_peak_w == pytest.approx(site.p_peak_w)


def test_endurance_is_optional_in_seconds_and_round_trips() -> None:
    data = _base()
    assert parse_site(data).endurance_s is None
    assert "endurance" not in site_to_dict(parse_site(data))["uav"]  # type: ignore[operator]
    data["uav"]["endurance"] = 840
    site = parse_site(data)
    assert site.endurance_s == 840.0
    assert parse_site(site_to_dict(site)).endurance_s == 840.0


def test_rejects_unknown_key() -> None:
    data = _base()
    data["uav"]["top_speed"] = 3
    _rejects(data, "uav.top_speed", "unknown key")


def test_rejects_missing_field() -> None:
    data = _base()
    del data["radio"]["noise_dbm"]
    _rejects(data, "radio.noise_dbm", "missing")


@pytest.mark.parametrize("field", ["altitude", "max_speed", "period", "slots", "endurance"])
def test_rejects_non_positive_uav_numbers(field: str) -> None:
    data = _base()
    data["uav"][field] = 0
    _rejects(data, f"uav.{field}")


def test_rejects_negative_radius() -> None:
    data = _base()
    data["no_fly_zones"][0]["radius"] = -5
    _rejects(data, "no_fly_zones[0] (NFZ1).radius")


def test_rejects_overlapping_nfzs() -> None:
    data = _base()
    data["no_fly_zones"].append({"name": "NFZ2", "x": 190.0, "y": 200.0, "radius": 30.0})
    _rejects(data, "NFZ2", "overlaps", "NFZ1")


def test_rejects_gn_inside_nfz() -> None:
    data = _base()
    data["ground_nodes"][1] = {"name": "GN2", "x": 160.0, "y": 200.0}
    _rejects(data, "ground_nodes[1] (GN2)", "inside NFZ1")


def test_rejects_home_inside_nfz_or_its_buffer() -> None:
    data = _base()
    data["home"] = {"x": 150.0, "y": 231.0}  # 1 m outside the zone, inside the 2 m buffer
    _rejects(data, "home", "NFZ1")


def test_rejects_peak_power_below_average() -> None:
    data = _base()
    data["radio"]["p_peak_dbm"] = 19.0
    _rejects(data, "radio", "p_peak_dbm")


def test_rejects_point_given_both_ways() -> None:
    data = _base()
    data["ground_nodes"][0]["lat"] = 37.5
    data["ground_nodes"][0]["lon"] = 127.0
    _rejects(data, "ground_nodes[0] (GN1)", "not both")


def test_rejects_point_given_neither_way() -> None:
    data = _base()
    data["ground_nodes"][0] = {"name": "GN1"}
    _rejects(data, "ground_nodes[0] (GN1)", "x/y or as lat/lon")


def test_rejects_duplicate_names() -> None:
    data = _base()
    data["ground_nodes"][1]["name"] = "GN1"
    _rejects(data, "ground_nodes[1] (GN1)", "duplicate")


def test_rejects_unreadable_yaml(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nuav: {altitude: 30\n")
    with pytest.raises(InputError, match="unreadable YAML"):
        load_site(bad)


def test_rejects_a_list_at_top_level() -> None:
    _rejects([1, 2], "mapping")


def test_negative_buffer_is_refused() -> None:
    site = parse_site(_base())
    with pytest.raises(InputError, match="buffer_m"):
        site.with_buffer(-1.0)


def test_file_and_dict_agree(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(copy.deepcopy(_base())))
    assert np.array_equal(load_site(path).nfz_xy_m, parse_site(_base()).nfz_xy_m)


def test_local_frame_is_the_tangent_plane_at_the_origin_altitude() -> None:
    """Same frame as the shared ArduCopter SITL data: fence centres there equal the NFZs."""
    from validator.geodesy import LocalFrame

    high = LocalFrame(-35.363261, 149.16523, 584.0)
    low = LocalFrame(-35.363261, 149.16523, 0.0)
    lat, lon = high.to_geodetic(np.array([360.0, 110.0]))
    assert np.allclose(high.to_local(lat, lon), [360.0, 110.0], atol=1e-5)
    # A frame at sea level would put the same point ~3 cm further out at 584 m.
    assert np.linalg.norm(low.to_local(lat, lon) - [360.0, 110.0]) > 0.02


CTR = [{"x": 300.0, "y": 150.0}, {"x": 420.0, "y": 150.0}, {"x": 420.0, "y": 190.0},
       {"x": 300.0, "y": 190.0}]


def _with_polygon(vertices: list[dict[str, float]] = CTR) -> dict[str, Any]:
    data = _base()
    data["no_fly_zones"].append({"name": "CTR", "polygon": copy.deepcopy(vertices)})
    return data


def test_a_polygon_zone_is_read_beside_the_circles() -> None:
    site = parse_site(_with_polygon())
    assert site.nfz_names == ("NFZ1",) and site.zone_names == ("NFZ1", "CTR")
    (ctr,) = site.polygon_zones
    assert ctr.area_m2 == pytest.approx(120.0 * 40.0) and ctr.is_convex


def test_polygon_vertices_may_be_geodetic() -> None:
    site = parse_site(_with_polygon([{"lat": 37.561, "lon": 127.001},
                                     {"lat": 37.562, "lon": 127.001},
                                     {"lat": 37.5615, "lon": 127.0025}]))
    assert site.polygon_zones[0].vertices_xy_m[:, 0].min() == pytest.approx(176.7, abs=0.5)


def test_a_polygon_site_round_trips_through_its_dict() -> None:
    site = parse_site(_with_polygon())
    again = parse_site(site_to_dict(site))
    assert again.zone_names == site.zone_names
    got, want = again.polygon_zones[0].vertices_xy_m, site.polygon_zones[0].vertices_xy_m
    assert got == pytest.approx(want)


@pytest.mark.parametrize("change, words", [
    (lambda z: z.update(radius=5.0), "no_fly_zones[1] (CTR): a polygon zone takes no"),
    (lambda z: z.update(polygon=z["polygon"][:2]), "at least 3 vertices"),
    (lambda z: z.update(polygon=[z["polygon"][i] for i in (0, 2, 1, 3)]),
     "no_fly_zones[1] (CTR).polygon: the polygon intersects itself"),
    (lambda z: z["polygon"][0].update(lat=37.5), "not both"),
])
def test_bad_polygon_zones_name_the_zone(change, words) -> None:
    data = _with_polygon()
    change(data["no_fly_zones"][1])
    _rejects(data, words)


def test_a_zone_without_radius_or_polygon_says_what_it_needs() -> None:
    data = _base()
    del data["no_fly_zones"][0]["radius"]
    _rejects(data, "no_fly_zones[0] (NFZ1)", "or a polygon")


def test_rejects_a_polygon_overlapping_a_circle_or_a_polygon() -> None:
    data = _with_polygon([{"x": 160.0, "y": 180.0}, {"x": 220.0, "y": 150.0},
                          {"x": 220.0, "y": 250.0}])
    _rejects(data, "no_fly_zones[1] (CTR): overlaps NFZ1")
    data = _with_polygon()
    data["no_fly_zones"].append({"name": "TWR", "polygon": [{"x": 410.0, "y": 180.0},
                                                            {"x": 500.0, "y": 180.0},
                                                            {"x": 500.0, "y": 250.0}]})
    _rejects(data, "no_fly_zones[2] (TWR): overlaps CTR")


def test_polygons_that_share_an_edge_do_not_overlap() -> None:
    data = _with_polygon()
    data["no_fly_zones"].append({"name": "TWR", "polygon": [{"x": 420.0, "y": 150.0},
                                                            {"x": 480.0, "y": 150.0},
                                                            {"x": 420.0, "y": 190.0}]})
    assert parse_site(data).zone_names == ("NFZ1", "CTR", "TWR")


def test_rejects_a_gn_inside_a_polygon_and_home_in_its_buffer() -> None:
    data = _with_polygon()
    data["ground_nodes"][1] = {"name": "GN2", "x": 350.0, "y": 170.0}
    _rejects(data, "ground_nodes[1] (GN2)", "inside CTR")
    data = _with_polygon()
    data["home"] = {"x": 350.0, "y": 191.0}  # 1 m outside, inside the 2 m buffer
    _rejects(data, "home lies inside CTR plus its 2 m safety buffer")


def test_a_home_or_node_beyond_a_missions_reach_is_refused() -> None:
    data = _base()
    data["ground_nodes"][0] = {"name": "GN1", "x": 500_000.0, "y": 0.0}  # a typo: 500 km
    _rejects(data, "site.yaml: ground_nodes[0] (GN1): 500 km from the origin, beyond the 100 km")
    data = _base()
    data["home"] = {"lat": data["origin"]["lat"] + 1.0, "lon": data["origin"]["lon"]}
    _rejects(data, "site.yaml: home: 111 km from the origin")
    data = _base()
    data["ground_nodes"][0] = {"name": "GN1", "x": 99_000.0, "y": 0.0}
    assert parse_site(data).gn_xy_m[0, 0] == 99_000.0


@pytest.mark.parametrize("lat", [90.0, -85.01])
def test_an_origin_near_a_pole_is_refused(lat: float) -> None:
    data = _base()
    data["origin"]["lat"] = lat
    _rejects(data, "site.yaml: origin.lat: ", f"{lat:g}° is within 5° of a pole")


def test_an_origin_at_the_polar_bound_is_a_site() -> None:
    data = _base()
    data["origin"]["lat"] = 85.0
    assert parse_site(data).frame.lat0_deg == 85.0


def test_duplicate_zone_names_across_circles_and_polygons() -> None:
    data = _with_polygon()
    data["no_fly_zones"][1]["name"] = "NFZ1"
    _rejects(data, "no_fly_zones[1] (NFZ1): duplicate")


def test_an_airspace_key_needs_a_site_file_on_disk() -> None:
    _rejects(_base() | {"airspace": "zones.geojson"}, "airspace", "site file read from disk")


@pytest.mark.parametrize("value", [True, "10"])
def test_a_number_written_as_a_boolean_or_a_string_is_refused(value: object) -> None:
    # coerced, `max_speed: true` had planned the site at 1 m/s
    data = _base()
    data["uav"]["max_speed"] = value
    _rejects(data, "site.yaml: uav.max_speed: Input should be a valid number")


def test_a_count_written_with_a_fraction_is_refused() -> None:
    data = _base()
    data["uav"]["slots"] = 64.0
    _rejects(data, "site.yaml: uav.slots: Input should be a valid integer")
