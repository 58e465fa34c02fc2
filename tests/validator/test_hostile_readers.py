"""Hostile input to every reader: only a clean InputError or a valid result, never a crash.

The readers run in-process (hypothesis mutates valid files: bytes, structure, numbers), and a
plan that reads is also resolved and audited, since that is where a bad value would surface.
"""

from __future__ import annotations

import copy
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.validator.builders import make_site, service_plan
from validator.audit import audit
from validator.errors import InputError
from validator.flight import resolve_flight
from validator.input_files import MAX_DEPTH, MAX_FILE_BYTES, parse_json, read_text
from validator.motion.limits import site_limits
from validator.motion.profile import make_profile
from validator.plan_format import FenceCircle, Plan, dumps_plan, loads_plan, plan_to_dict, read_plan
from validator.replay import replay, score_track
from validator.site import Site, load_site, loads_site
from validator.waypoints_format import MAX_ROWS, dumps_waypoints, loads_waypoints

SAMPLE_SITE = Path(__file__).parents[2] / "samples" / "paper-default.yaml"
HYPO = settings(max_examples=80, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])


def _site() -> Site:
    return make_site()


def _plan(site: Site) -> Plan:
    q = [(0, 60), (60, 60), (60, 100), (0, 60)]
    plan = service_plan(site, q, [6.0, 4.0, 8.0], [0.1] * 3, ["GN1", None, "GN2"], cycles=2)
    lat, lon = site.frame.to_geodetic(np.array([-50.0, -50.0]))
    plan.rally = [(float(lat), float(lon), 30.0)]
    plan.breach_return = (float(lat), float(lon), 30.0)
    plan.circles.append(FenceCircle(float(lat), float(lon), 2000.0, inclusion=True))
    return plan


SITE = _site()
PLAN_DICT = plan_to_dict(_plan(SITE))
PLAN_TEXT = dumps_plan(_plan(SITE))
SITE_TEXT = SAMPLE_SITE.read_text(encoding="utf-8")


def _read_and_check_plan(text: str) -> None:
    """Read a plan and, if it reads, resolve, audit, replay (both autopilots' models) and
    score it: InputError is the only failure."""
    try:
        plan = loads_plan(text, "mutant.plan")
        flight = resolve_flight(plan, SITE, "mutant.plan")
        audit(plan, SITE, flight, source="mutant.plan")
        for model in ("arducopter", "px4"):
            track = replay(flight, make_profile(model, site_limits(SITE)))
            score_track(track, flight, SITE, plan)
    except InputError as err:
        _assert_one_line(err, "mutant.plan")


def _read_site(text: str) -> None:
    try:
        site = loads_site(text, "mutant.yaml")
    except InputError as err:
        _assert_one_line(err, "mutant.yaml")
        return
    for arr in (site.gn_xy_m, site.nfz_xy_m, site.nfz_radius_m, site.home_xy_m):
        assert np.all(np.isfinite(arr))
    assert all(math.isfinite(v) for v in (site.altitude_m, site.max_speed_mps, site.period_s,
                                          site.p_avg_w, site.buffer_m))


def _assert_one_line(err: InputError, source: str) -> None:
    text = str(err)
    assert "\n" not in text and text.startswith(source), text


# --------------------------------------------------------------------------------------------
# the failures issue 14 found, one by one


def test_non_utf8_site_is_input_error(tmp_path: Path) -> None:
    path = tmp_path / "site.yaml"
    path.write_bytes(b"name: x\n\xff\xfe\x00binary")
    with pytest.raises(InputError, match=r"site.yaml: site file is not UTF-8 text \(byte 8"):
        load_site(path)


def test_deeply_nested_plan_is_input_error(tmp_path: Path) -> None:
    path = tmp_path / "deep.plan"
    path.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(InputError, match="nested too deeply"):
        read_plan(path)


def test_nesting_within_the_recursion_limit_is_still_refused() -> None:
    text = json.dumps({"fileType": "Plan", "nfzMission": _nested(MAX_DEPTH + 5)})
    with pytest.raises(InputError, match=r"nfzMission(\[0\])+: nested too deeply"):
        parse_json(text, "p.plan")


def _nested(depth: int) -> Any:
    out: Any = 1
    for _ in range(depth):
        out = [out]
    return out


@pytest.mark.parametrize("value", ["NaN", "Infinity", "-Infinity", "1e999", "null"])
def test_non_finite_or_null_latitude_is_input_error(value: str) -> None:
    data = copy.deepcopy(PLAN_DICT)
    data["mission"]["items"][2]["params"][4] = "@"
    text = json.dumps(data).replace('"@"', value)
    with pytest.raises(InputError, match=r"items\[2\]|not a finite number"):
        loads_plan(text, "p.plan")


@pytest.mark.parametrize(
    "path",
    [("version",), ("mission", "version"), ("geoFence", "version"), ("rallyPoints", "version"),
     ("geoFence", "circles", 0, "version")],
)
def test_unknown_version_is_refused(path: tuple[str | int, ...]) -> None:
    data = copy.deepcopy(PLAN_DICT)
    node = data
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = 99
    with pytest.raises(InputError, match=r"version: expected \d, got 99"):
        loads_plan(json.dumps(data), "p.plan")


def test_current_versions_and_missing_versions_are_read() -> None:
    assert loads_plan(PLAN_TEXT).items
    data = copy.deepcopy(PLAN_DICT)
    for part in (data, data["mission"], data["geoFence"], data["rallyPoints"]):
        del part["version"]
    assert len(loads_plan(json.dumps(data)).items) == len(PLAN_DICT["mission"]["items"])


# --------------------------------------------------------------------------------------------
# size limits


def test_file_over_the_limit_is_refused_before_reading(tmp_path: Path) -> None:
    path = tmp_path / "huge.plan"
    with path.open("wb") as f:  # sparse: costs no disk and no time
        f.truncate(MAX_FILE_BYTES + 1)
    with pytest.raises(InputError, match="plan file too large"):
        read_plan(path)


def test_endless_stream_is_cut_at_the_limit() -> None:
    with pytest.raises(InputError, match="too large"):
        read_text("/dev/zero", "plan", max_bytes=4096)


def test_million_mission_items_are_refused() -> None:
    data = copy.deepcopy(PLAN_DICT)
    data["mission"]["items"] = [{}] * 1_000_000
    with pytest.raises(InputError, match="1000000 entries, at most 65535"):
        loads_plan(json.dumps(data), "p.plan")


@pytest.mark.parametrize("command, index, value, says", [
    (16, 0, 1e9, "a 1e+09 s hold"),  # NAV_WAYPOINT param1: seconds
    (16, 0, 1e308, "a 1e+308 s hold"),
    (178, 1, 1e-6, "m at 1e-06 m/s"),  # DO_CHANGE_SPEED param2: m/s
])
def test_a_mission_of_more_than_a_day_is_refused_when_it_is_resolved(command, index, value,
                                                                     says) -> None:
    # sampled every 0.05 s these took 20 to 149 GB (a traceback, or the kernel's kill); the
    # audit alone, timing it, printed times of 1e308 s and "Result: CLEAR"
    data = copy.deepcopy(PLAN_DICT)
    k = next(i for i, it in enumerate(data["mission"]["items"]) if it["command"] == command)
    data["mission"]["items"][k]["params"][index] = value
    plan = loads_plan(json.dumps(data), "p.plan")
    with pytest.raises(InputError, match=rf"^p\.plan: item \d+: .*{re.escape(says)}.*beyond a day"):
        resolve_flight(plan, SITE, "p.plan")


@pytest.mark.parametrize("alt_m", [1e12, -1e308, 2.0**63])
def test_an_altitude_beyond_a_missions_reach_is_refused(alt_m: float) -> None:
    # the replay sampled the climb to 1e12 m: a traceback asking for 155 TiB
    data = copy.deepcopy(PLAN_DICT)
    k = next(i for i, it in enumerate(data["mission"]["items"]) if it["command"] == 16)
    data["mission"]["items"][k]["params"][6] = alt_m
    plan = loads_plan(json.dumps(data), "p.plan")
    with pytest.raises(InputError, match=rf"^p\.plan: item {k + 1}: altitude .* beyond the 100 km"):
        resolve_flight(plan, SITE, "p.plan")


def test_a_flight_of_more_than_a_day_made_without_a_plan_file_is_not_replayed() -> None:
    """The planner's own flights (corner checks) are built without resolve_flight: the
    replay refuses them too, before it samples them."""
    import dataclasses

    flight = resolve_flight(loads_plan(json.dumps(PLAN_DICT), "p.plan"), SITE, "p.plan")
    k = next(i for i, leg in enumerate(flight.legs) if leg.kind == "waypoint")
    legs = list(flight.legs)
    legs[k] = dataclasses.replace(legs[k], hold_s=1e9)
    long = dataclasses.replace(flight, legs=tuple(legs), source="planner")
    for name in ("ideal", "arducopter", "px4"):
        with pytest.raises(InputError, match=r"^planner: item \d+: a 1e\+09 s hold"):
            replay(long, make_profile(name, site_limits(SITE)))


def test_yaml_alias_bomb_is_refused() -> None:
    lines = ["a0: &a0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    for i in range(1, 9):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]")
    with pytest.raises(InputError, match="too many values"):
        loads_site("\n".join(lines) + "\n", "bomb.yaml")


def test_too_many_ground_nodes_are_refused() -> None:
    data = yaml.safe_load(SITE_TEXT)
    data["ground_nodes"] = [{"name": f"G{i}", "x": 1000.0 + i, "y": 0.0} for i in range(1001)]
    with pytest.raises(InputError, match="ground_nodes: .*at most 1000"):
        loads_site(yaml.safe_dump(data), "s.yaml")


def test_too_many_waypoint_rows_are_refused() -> None:
    row = "\t".join(["{}", "0", "3", "16"] + ["0"] * 7 + ["1"])
    text = "QGC WPL 110\n" + "\n".join(row.format(i) for i in range(MAX_ROWS + 1)) + "\n"
    with pytest.raises(InputError, match=f"more than {MAX_ROWS} items"):
        loads_waypoints(text, "w.waypoints")


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e400"])
def test_non_finite_waypoint_number_is_refused(value: str) -> None:
    lines = dumps_waypoints(_plan(SITE)).splitlines()
    fields = lines[3].split("\t")
    fields[8] = value
    lines[3] = "\t".join(fields)
    with pytest.raises(InputError, match="line 4: every number must be finite"):
        loads_waypoints("\n".join(lines), "w.waypoints")


@pytest.mark.parametrize("value", [".nan", ".inf", "-.inf", "1.0e999"])
def test_non_finite_site_number_is_refused(value: str) -> None:
    text = SITE_TEXT.replace("period: 50.0", f"period: {value}")
    with pytest.raises(InputError, match="uav.period"):
        loads_site(text, "s.yaml")


# --------------------------------------------------------------------------------------------
# property-based: mutated files give a clean InputError or a valid result

_EXTREME = st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324, -0.0, 0,
                            -1, 2**63, 10**30, 90.0000001, -180.5, 65536, True, None])
_JSON_LEAF = st.one_of(st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=8),
                       _EXTREME)
_JSON = st.recursive(_JSON_LEAF, lambda kids: st.one_of(
    st.lists(kids, max_size=4), st.dictionaries(st.text(max_size=6), kids, max_size=4)),
    max_leaves=12)


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, (*prefix, i))
    return out


def _mutate(data: Any, draw: st.DrawFn) -> Any:
    """One structural or numeric mutation at a random place in ``data`` (a copy)."""
    data = copy.deepcopy(data)
    paths = [p for p in _paths(data) if p]
    path = draw(st.sampled_from(paths))
    parent = data
    for key in path[:-1]:
        parent = parent[key]
    key = path[-1]
    action = draw(st.sampled_from(["replace", "extreme", "delete", "wrap", "add_key"]))
    if action == "replace":
        parent[key] = draw(_JSON)
    elif action == "extreme":
        parent[key] = draw(_EXTREME)
    elif action == "delete":
        del parent[key]
    elif action == "wrap":
        parent[key] = [parent[key]]
    elif isinstance(parent, dict):
        parent[draw(st.text(max_size=6))] = draw(_JSON)
    return data


def _mutate_bytes(text: str, draw: st.DrawFn) -> bytes:
    raw = bytearray(text.encode("utf-8"))
    for _ in range(draw(st.integers(1, 4))):
        pos = draw(st.integers(0, len(raw) - 1))
        what = draw(st.sampled_from(["flip", "insert", "delete", "truncate"]))
        if what == "flip":
            raw[pos] ^= 1 << draw(st.integers(0, 7))
        elif what == "insert":
            raw[pos:pos] = draw(st.binary(min_size=1, max_size=4))
        elif what == "delete":
            del raw[pos]
        else:
            del raw[pos:]
            break
    return bytes(raw)


@HYPO
@given(st.data())
def test_plan_structure_mutations(data: st.DataObject) -> None:
    mutant = _mutate(PLAN_DICT, data.draw)
    _read_and_check_plan(json.dumps(mutant, allow_nan=True))


@HYPO
@given(st.data())
def test_plan_byte_mutations(tmp_path_factory: pytest.TempPathFactory,
                             data: st.DataObject) -> None:
    path = tmp_path_factory.mktemp("bytes") / "mutant.plan"
    path.write_bytes(_mutate_bytes(PLAN_TEXT, data.draw))
    try:
        plan = read_plan(path)
        audit(plan, SITE, resolve_flight(plan, SITE, str(path)), source=str(path))
    except InputError as err:
        _assert_one_line(err, str(path))


@HYPO
@given(st.data())
def test_site_structure_mutations(data: st.DataObject) -> None:
    mutant = _mutate(yaml.safe_load(SITE_TEXT), data.draw)
    _read_site(yaml.safe_dump(mutant, allow_unicode=True))


@HYPO
@given(st.data())
def test_site_byte_mutations(tmp_path_factory: pytest.TempPathFactory,
                             data: st.DataObject) -> None:
    path = tmp_path_factory.mktemp("bytes") / "mutant.yaml"
    path.write_bytes(_mutate_bytes(SITE_TEXT, data.draw))
    try:
        site = load_site(path)
    except InputError as err:
        _assert_one_line(err, str(path))
        return
    assert np.all(np.isfinite(site.gn_xy_m)) and math.isfinite(site.period_s)


@HYPO
@given(st.data())
def test_waypoints_mutations(data: st.DataObject) -> None:
    lines = dumps_waypoints(_plan(SITE)).splitlines()
    n = data.draw(st.integers(0, len(lines) - 1))
    fields = lines[n].split("\t")
    f = data.draw(st.integers(0, len(fields) - 1))
    fields[f] = data.draw(st.one_of(
        st.sampled_from(["nan", "inf", "-inf", "1e999", "", "x", "1.5", "-1", "99999999999",
                         "65536", "5000"]),
        st.text(alphabet="0123456789.-e+naif \t", max_size=8)))
    lines[n] = "\t".join(fields)
    try:
        plan = loads_waypoints("\n".join(lines) + "\n", "mutant.waypoints")
        audit(plan, SITE, resolve_flight(plan, SITE, "mutant.waypoints"),
              source="mutant.waypoints")
    except InputError as err:
        _assert_one_line(err, "mutant.waypoints")


POLYGON_SITE = yaml.safe_load(SITE_TEXT) | {"no_fly_zones": [
    {"name": "NFZ1", "x": 190.0, "y": 330.0, "radius": 30.0},
    {"name": "CTR", "polygon": [{"x": 300, "y": -100}, {"x": 420, "y": -100}, {"x": 360, "y": -80},
                                {"x": 420, "y": -60}, {"x": 300, "y": -60}]},
    {"name": "TWR", "polygon": [{"lat": 37.5565, "lon": 127.0005},
                                {"lat": 37.5565, "lon": 127.0015},
                                {"lat": 37.557, "lon": 127.001}]}]}
AIRSPACE = {"type": "FeatureCollection", "features": [
    {"type": "Feature", "properties": {"name": "PRISON"}, "geometry": {
        "type": "MultiPolygon", "coordinates": [[[[126.998, 37.556], [126.9985, 37.556],
                                                  [126.998, 37.5565], [126.998, 37.556]]]]}},
    {"type": "Feature", "properties": {"name": "MAST", "radius_m": 20}, "geometry": {
        "type": "Point", "coordinates": [126.9985, 37.5605]}}]}


@HYPO
@given(st.data())
def test_polygon_site_structure_mutations(data: st.DataObject) -> None:
    _read_site(yaml.safe_dump(_mutate(POLYGON_SITE, data.draw), allow_unicode=True))


@HYPO
@given(st.data())
def test_airspace_structure_mutations(tmp_path_factory: pytest.TempPathFactory,
                                      data: st.DataObject) -> None:
    folder = tmp_path_factory.mktemp("airspace")
    (folder / "zones.geojson").write_text(json.dumps(_mutate(AIRSPACE, data.draw),
                                                     allow_nan=True))
    (folder / "site.yaml").write_text(yaml.safe_dump(yaml.safe_load(SITE_TEXT)
                                                     | {"airspace": "zones.geojson"}))
    try:
        site = load_site(folder / "site.yaml")
    except InputError as err:
        assert "\n" not in str(err) and str(err).startswith(str(folder)), str(err)
        return
    for zone in site.polygon_zones:
        assert np.all(np.isfinite(zone.vertices_xy_m)) and zone.area_m2 > 0
