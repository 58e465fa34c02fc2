"""The mission view's figure and page without a browser: optional layers, the rates the slider
shows, a self-contained page, and the commands' --html, --html-map and --flown."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import shapely

from tests.validator.builders import make_site, nav, plan_of, speed
from tests.view_figure import layer, page_figure
from validator.autopilot.param_file import read_params
from validator.cli import validate_mission_main
from validator.failsafe import audit_failsafes
from validator.flight import DO_SET_HOME, resolve_flight
from validator.geometry import segment_point_distance
from validator.plan_format import Cmd, Frame, MissionItem, read_plan, write_plan
from validator.site import load_site
from validator.validation import validate_mission
from validator.view import (
    STILL_AIR,
    FailsafePath,
    ViewInputs,
    Wind,
    failsafe_paths,
    fault_mark,
    validation_inputs,
    view_figure,
)
from validator.view.page import view_html
from validator.view.timeline import Timeline

REPO = Path(__file__).resolve().parents[2]
PLAN = REPO / "tests/golden/realistic-vehicle/mission.plan"
SITE = REPO / "samples/realistic.yaml"


@pytest.fixture(scope="module")
def validation():
    return validate_mission(PLAN, SITE, replay_flight=True)


def _layers(fig) -> list[str]:
    return [t["meta"]["layer"] for t in fig["data"] if "meta" in t]


def test_a_plan_alone_has_no_slider_and_no_flight_layers(validation):
    v = validation
    fig = view_figure(ViewInputs(v.plan, v.site, v.flight))
    layers = _layers(fig)
    assert fig["frames"] == [] and "sliders" not in fig["layout"]
    assert "track" not in layers and "vehicle" not in layers and "failsafe" not in layers
    assert layers.count("zone") == 3 and layers.count("fence") == len(v.plan.circles)
    assert not any("wind" in a["text"] for a in fig["layout"]["annotations"])  # none given
    assert fig["layout"]["yaxis3"]["visible"] is False and "visible" not in fig["layout"]["yaxis2"]


def test_failsafe_paths_and_wind_are_drawn_when_given(validation):
    ring = np.array([[0.0, 0.0], [100.0, 50.0], [0.0, 100.0], [0.0, 0.0]])
    paths = (FailsafePath("RTL from item 4", np.array([[0.0, 0.0], [100.0, 50.0]])),
             FailsafePath("RTL from item 7", np.array([[10.0, 0.0], [90.0, 50.0]]), ok=False,
                          note="crosses NFZ2"),
             FailsafePath("straight returns", ring, ok=False, kind="region"))
    inputs = dataclasses.replace(validation_inputs(validation), failsafe_paths=paths,
                                 wind=Wind(8.0, 270.0, 1.5))
    fig = view_figure(inputs)
    failsafe = [t for t in fig["data"] if t.get("meta", {}).get("layer") == "failsafe"]
    assert [t["line"]["color"] for t in failsafe] == ["#2ca02c", "#d62728", "#d62728"]
    assert failsafe[1]["hovertext"] == "<b>RTL from item 7</b><br>crosses NFZ2"
    assert "fill" not in failsafe[1] and failsafe[2]["fill"] == "toself"  # a region is filled
    assert failsafe[2]["x"] == ring[:, 0].tolist()
    arrow, text = fig["layout"]["annotations"]
    # from the west, so it blows east: the arrow's tail is left of its head, level with it
    assert arrow["ax"] < 0 and abs(arrow["ay"]) < 1e-9
    assert "8 m/s from 270°" in text["text"] and "turbulence 1.5 m/s" in text["text"]


@pytest.mark.parametrize("frm, ax_sign, ay_sign", [(0.0, 0, -1), (90.0, 1, 0), (225.0, -1, 1)])
def test_the_wind_arrow_points_where_the_air_goes(validation, frm, ax_sign, ay_sign):
    # ax, ay: from the head to the tail, screen y down. From the north (0°) the air goes
    # south: the tail above the head (ay < 0)
    inputs = dataclasses.replace(validation_inputs(validation), wind=Wind(5.0, frm))
    arrow = view_figure(inputs)["layout"]["annotations"][0]
    assert np.sign(np.round(arrow["ax"], 6)) == ax_sign
    assert np.sign(np.round(arrow["ay"], 6)) == ay_sign


def test_a_wind_other_than_the_plans_shows_both_and_still_air_has_no_arrow(validation):
    inputs = dataclasses.replace(validation_inputs(validation), wind=STILL_AIR,
                                 planned_wind=Wind(7.0, 300.0))
    notes = view_figure(inputs)["layout"]["annotations"]
    assert [a.get("showarrow") for a in notes] == [False, True, False]  # one arrow: planned
    assert "flown in" in notes[0]["text"] and "still air" in notes[0]["text"]
    assert "plan made for" in notes[2]["text"] and "7 m/s from 300°" in notes[2]["text"]


def test_the_bars_end_the_cycle_at_the_flown_rates(validation):
    timeline = Timeline(validation_inputs(validation))
    served = timeline.served[0]
    assert served is not None and validation.replay is not None
    flown = validation.replay.throughput
    assert flown is not None
    np.testing.assert_allclose(served.so_far[-1], flown.flown_bps_hz, rtol=1e-9)
    # one node at a time, and only while it is served
    assert np.all(served.rate_bps_hz[served.gn < 0] == 0)
    assert np.all(np.diff(served.so_far, axis=0) >= 0)


def test_every_frame_moves_the_vehicle_to_the_track(validation):
    inputs = validation_inputs(validation)
    fig = view_figure(inputs)
    track = validation.replay_track
    vehicle = next(i for i, t in enumerate(fig["data"]) if t.get("meta", {}).get("layer")
                   == "vehicle")
    for frame in fig["frames"][::20]:
        t = float(frame["name"])
        state = frame["data"][frame["traces"].index(vehicle)]
        j = int(np.argmin(np.abs(track.t_s - t)))
        np.testing.assert_allclose([state["x"][0], state["y"][0]], track.xy_m[j], atol=0.01)


def test_the_page_is_self_contained(validation):
    page = view_html(validation_inputs(validation))
    assert "<script src=" not in page  # plotly.js is inside, not fetched
    assert "Plotly.newPlot" in page and "<title>realistic: mission.plan</title>" in page


def test_validate_mission_writes_the_view(tmp_path, capsys):
    out = tmp_path / "view.html"
    assert validate_mission_main([str(PLAN), "--site", str(SITE), "--html", str(out)]) == 0
    page = out.read_text(encoding="utf-8")
    assert "replay (arducopter)" in page  # --html implies --replay
    assert "Replay (arducopter" in capsys.readouterr().out


@pytest.mark.parametrize("args, says", [
    (["--html-map"], "--html-map: only with --html"),
    (["--html", "{tmp}/nowhere/view.html"], "does not exist"),
    (["--html", "{tmp}/view.html", "--flown", "{tmp}/missing.csv"], "missing.csv"),
])
def test_bad_view_arguments_are_one_line_and_write_nothing(tmp_path, capsys, args, says):
    argv = [str(PLAN), "--site", str(SITE), *(a.format(tmp=tmp_path) for a in args)]
    assert validate_mission_main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert says in err and len(err.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_a_plan_without_planner_metadata_says_why_it_shows_no_rates(tmp_path):
    import json

    data = json.loads(PLAN.read_text())
    del data["nfzMission"]  # as QGroundControl would save a plan it edited
    bare = tmp_path / "bare.plan"
    bare.write_text(json.dumps(data))
    fig = view_figure(validation_inputs(validate_mission(bare, SITE, replay_flight=True)))
    layers = _layers(fig)
    assert "vehicle" in layers and fig["frames"]  # the flight still plays
    assert not {"so-far", "rate", "planned", "cursor"} & set(layers)
    assert fig["layout"]["xaxis2"]["visible"] is False
    assert any("nfzMission" in a["text"] for a in fig["layout"]["annotations"])


# --------------------------------------------------------------------------------------------
# the failsafe audit's paths and the wind, as validate-mission --params --wind draws them

FAILSAFE = REPO / "tests/data/failsafe"


def _failsafe(fig) -> list[dict]:
    return layer(fig, "failsafe")


def _audited(site: str, plan: str, params: str):
    return validate_mission(FAILSAFE / "plans" / plan, FAILSAFE / "sites" / f"{site}.yaml",
                            vehicle_params=read_params(FAILSAFE / "params" / params))


def test_an_rtl_into_a_zone_is_drawn_red_through_it():
    v = _audited("realistic", "realistic-ardupilot.plan", "thr-rtl.param")
    assert v.failsafe is not None and not v.failsafe.ok
    paths = failsafe_paths(v.failsafe, v.flight)
    region = [p for p in paths if p.kind == "region"]
    lines = [p for p in paths if p.kind == "line"]
    assert len(region) == 1 and not region[0].ok
    # one red line per zone entered, the deepest: it runs through NFZ3 to home
    assert [p.ok for p in lines] == [False] and "NFZ3" in lines[0].note
    (a, b), centre = lines[0].xy_m, v.site.nfz_xy_m[v.site.nfz_names.index("NFZ3")]
    assert np.allclose(b, v.flight.home_xy_m)
    assert segment_point_distance(a[None], b[None], centre)[0] < v.site.nfz_radius_m[2]
    # the region holds every start of a return and home, and the zone it crosses
    shape = shapely.Polygon(region[0].xy_m).buffer(1.0)
    assert shape.contains(shapely.MultiPoint([*v.flight.path_xy_m, v.flight.home_xy_m,
                                              centre]))


def test_a_clear_rtl_draws_its_closest_return_green():
    v = _audited("open", "open-ardupilot.plan", "all-rtl.param")
    assert v.failsafe is not None and v.failsafe.ok
    paths = failsafe_paths(v.failsafe, v.flight)
    assert {p.kind for p in paths} == {"region", "line"} and all(p.ok for p in paths)
    w = v.failsafe.worst_return
    line = next(p for p in paths if p.kind == "line")
    assert w is not None and np.allclose(line.xy_m, [w.xy_m, w.destination_xy_m])


def _fault(clearance_m: dict[str, float]) -> dict:
    from validator.mavlink.faults import FaultReport

    return FaultReport("rc-loss", "SIM_RC_FAIL 1", "simulator truth (SIMSTATE)", 144.6,
                       (-195.4, 125.3), (-196.7, 127.0), clearance_m, "landed", (0.03, 0.03),
                       0.05, ("SMART_RTL",), ("Radio Failsafe",),
                       track_xy_m=((-195.3, 125.0), (-120.9, 49.0), (0.0, 0.0))).as_dict()


@pytest.mark.parametrize("clearance, colour, says", [
    ({"HOSP": 12.33, "CTR1": 79.2}, "#2ca02c", "closest to a zone: HOSP, 12.33 m"),
    ({"HOSP": -1.5, "CTR1": 79.2}, "#d62728", "entered HOSP 1.50 m deep"),
])
def test_a_fault_is_drawn_where_it_was_injected_with_the_flight_after_it(
        validation, clearance, colour, says):
    v = validation
    mark = fault_mark(_fault(clearance))
    assert mark is not None
    fig = view_figure(ViewInputs(v.plan, v.site, v.flight, fault=mark))
    after, injected = (t for t in fig["data"] if t.get("meta", {}).get("layer") == "fault")
    assert (injected["x"], injected["y"]) == ([-195.4], [125.3])
    assert after["x"] == [-195.3, -120.9, 0.0] and after["line"]["color"] == colour
    assert injected["marker"]["color"] == colour
    for text in ("rc-loss injected (SIM_RC_FAIL 1)", "then flew SMART_RTL",
                 "ended landed, 0.1 m from home", says):
        assert text in injected["hovertext"]
    assert fault_mark({**_fault(clearance), "injected_xy_m": None}) is None  # never injected


def test_the_planners_own_file_retraces_the_mission_and_flies_no_straight_return():
    v = _audited("realistic", "realistic-ardupilot.plan", "realistic-ardupilot-planned.param")
    paths = failsafe_paths(v.failsafe, v.flight)
    assert [p.kind for p in paths] == ["retrace"]
    assert np.array_equal(paths[0].xy_m, v.flight.path_xy_m)
    assert "FS_THR_ENABLE" in paths[0].note


def test_validate_mission_html_draws_the_failsafe_paths_and_both_winds(tmp_path, capsys):
    out = tmp_path / "view.html"
    argv = [str(FAILSAFE / "plans/realistic-ardupilot.plan"), "--site",
            str(FAILSAFE / "sites/realistic.yaml"), "--params",
            str(FAILSAFE / "params/thr-rtl.param"), "--wind", "6@300,1.5", "--html", str(out)]
    assert validate_mission_main(argv) == 1  # the RTL enters NFZ3
    capsys.readouterr()
    fig = page_figure(out.read_text(encoding="utf-8"))
    kinds = [(t["meta"]["kind"], t["meta"]["ok"]) for t in _failsafe(fig)]
    assert ("region", False) in kinds and ("line", False) in kinds
    assert "NFZ3" in next(t["hovertext"] for t in _failsafe(fig) if t["meta"]["kind"] == "line")
    texts = [a["text"] for a in fig["layout"]["annotations"]]
    flown = next(t for t in texts if "flown in" in t)
    assert "6 m/s from 300°" in flown and "turbulence 1.5 m/s" in flown
    assert any("plan made for" in t and "still air" in t for t in texts)


def test_validate_mission_html_without_params_or_wind_draws_neither(tmp_path, capsys):
    out = tmp_path / "view.html"
    assert validate_mission_main([str(FAILSAFE / "plans/realistic-ardupilot.plan"), "--site",
                                  str(FAILSAFE / "sites/realistic.yaml"), "--html",
                                  str(out)]) == 0
    capsys.readouterr()
    fig = page_figure(out.read_text(encoding="utf-8"))
    assert _failsafe(fig) == []
    assert not any("wind" in a["text"] or "flown in" in a["text"]
                   for a in fig["layout"].get("annotations", []))


# --------------------------------------------------------------------------------------------
# a home moved mid-mission (DO_SET_HOME): its marker, and the returns drawn to it


def _set_home_at(site, xy, frame: Frame = Frame.GLOBAL_RELATIVE_ALT) -> MissionItem:
    lat, lon = site.frame.to_geodetic(np.asarray(xy, dtype=float))
    return MissionItem(DO_SET_HOME, [0.0, 0.0, 0.0, math.nan, float(lat), float(lon), 30.0],
                       int(frame))


def _with_set_home(tmp_path, item: MissionItem) -> Path:
    """The quick start's plan with ``item`` after its waypoint 8, in the service cycle."""
    plan = read_plan(PLAN)
    assert plan.extra is not None and plan.extra["cycle_items"] == [3, 12]
    path = tmp_path / "set-home.plan"
    # inside the service cycle: its last item moves one on, so the planned slots still match
    write_plan(dataclasses.replace(plan, items=[*plan.items[:9], item, *plan.items[9:]],
                                   extra={**plan.extra, "cycle_items": [3, 13]}), path)
    return path


def test_a_do_set_home_draws_the_home_it_puts_in_force_and_the_returns_go_there(tmp_path):
    site = load_site(SITE)
    path = _with_set_home(tmp_path, _set_home_at(site, (150.0, 250.0)))
    v = validate_mission(path, SITE, vehicle_params=read_params(FAILSAFE / "params/thr-rtl.param"))
    fig = view_figure(validation_inputs(v))
    (moved,) = layer(fig, "set-home")
    assert (moved["x"], moved["y"]) == ([150.0], [250.0])
    # the DO_SET_HOME is at index 9: QGroundControl's item 10, in the text and the meta alike
    assert moved["text"] == ["home set by item 10"] and moved["meta"]["items"] == [10]
    assert moved["name"] == "home set by DO_SET_HOME" and moved["marker"]["symbol"] == \
        "square-open"
    # the legs after it, to the landing: the item 11 waypoint ... the LAND, item 16
    assert "in force on the legs to items 11 ... 16" in moved["customdata"][0]
    (home,) = layer(fig, "home")
    assert home["marker"]["symbol"] == "square" and home["text"] == ["home (the plan's)"]
    assert "until the DO_SET_HOME of item 10" in home["hovertemplate"]
    # the deepest RTL into NFZ1 starts after item 10: it is drawn to the moved home; those
    # into NFZ2 and NFZ3 start before it and go to the plan's
    ends = {(t["hovertext"].split("<br>")[-1].split(" ")[-1], t["x"][-1], t["y"][-1])
            for t in _failsafe(fig) if t["meta"]["kind"] == "line"}
    assert ends == {("NFZ1", 150.0, 250.0), ("NFZ2", *home["x"], *home["y"]),
                    ("NFZ3", *home["x"], *home["y"])}


def test_the_closest_clear_return_is_drawn_to_the_home_in_force():
    # home (0, 0); item 4 (index 3) moves it to (150, 100), so the returns from the leg after
    # it, the closest to NFZ1 (100, 0), fly there: the green line ends at the moved home's marker
    site = make_site()
    plan = plan_of(site, [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(5.0),
                          nav(site, Cmd.NAV_WAYPOINT, (0.0, 100.0)),
                          _set_home_at(site, (150.0, 100.0)),
                          nav(site, Cmd.NAV_WAYPOINT, (150.0, 60.0)),
                          nav(site, Cmd.NAV_LAND, (150.0, 60.0), 0.0)])
    flight = resolve_flight(plan, site)
    report = audit_failsafes(plan, site, flight, {"FS_THR_ENABLE": 1})
    assert report.ok and report.worst_return is not None
    assert report.worst_return.destination == "home set by item 4"
    fig = view_figure(ViewInputs(plan, site, flight,
                                 failsafe_paths=failsafe_paths(report, flight)))
    (line,) = [t for t in _failsafe(fig) if t["meta"]["kind"] == "line"]
    (moved,) = layer(fig, "set-home")
    assert line["meta"]["ok"] and (line["x"][-1], line["y"][-1]) == (150.0, 100.0)
    assert (moved["x"], moved["y"]) == ([150.0], [100.0])
    assert "in force on the legs to items 5 ... 6" in moved["customdata"][0]


def test_a_home_set_where_the_vehicle_is_is_drawn_at_the_waypoint_before_it():
    site = make_site()
    here = MissionItem(DO_SET_HOME, [1.0, 0, 0, 0, 0, 0, 0], int(Frame.MISSION))
    plan = plan_of(site, [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(5.0),
                          nav(site, Cmd.NAV_WAYPOINT, (0.0, 100.0)), here,
                          nav(site, Cmd.NAV_WAYPOINT, (150.0, 60.0)),
                          nav(site, Cmd.NAV_WAYPOINT, (150.0, 60.0), p1=5.0)])
    (moved,) = layer(view_figure(ViewInputs(plan, site, resolve_flight(plan, site))),
                     "set-home")
    assert (moved["x"], moved["y"]) == ([0.0], [100.0])
    assert "home set by item 4</b> (DO_SET_HOME, where the vehicle is)" in \
        moved["customdata"][0]
    assert "in force on the legs to items 5 ... 6" in moved["customdata"][0]


def test_no_do_set_home_or_one_the_autopilot_refuses_draws_no_moved_home(validation, tmp_path):
    fig = view_figure(validation_inputs(validation))
    assert layer(fig, "set-home") == []
    (home,) = layer(fig, "home")
    assert "text" not in home and home["hovertemplate"].startswith("home<br>")
    # ArduCopter reads no coordinates in the mission frame: home stays where it was
    site = load_site(SITE)
    refused = _with_set_home(tmp_path, _set_home_at(site, (150.0, 250.0), Frame.MISSION))
    v = validate_mission(refused, SITE)
    assert any(f.item == 9 and f.severity == "violation" for f in v.flight.findings)
    assert layer(view_figure(validation_inputs(v)), "set-home") == []


def test_the_map_background_puts_the_moved_home_on_the_map_in_view(tmp_path):
    site = load_site(SITE)
    far = (150.0, -900.0)  # well south of everything else the map holds
    v = validate_mission(_with_set_home(tmp_path, _set_home_at(site, far)), SITE)
    (moved,) = layer(view_figure(validation_inputs(v), map_background=True), "set-home")
    lat, lon = site.frame.to_geodetic(np.array(far))
    assert moved["type"] == "scattermap"
    assert np.allclose([moved["lat"][0], moved["lon"][0]], [lat, lon], atol=1e-7)
    assert "%{lat:.6f}°" in moved["hovertemplate"]
    plain = view_figure(validation_inputs(validate_mission(PLAN, SITE)), map_background=True)
    centre = view_figure(validation_inputs(v), map_background=True)["layout"]["map"]["center"]
    assert centre["lat"] < plain["layout"]["map"]["center"]["lat"]  # moved to take it in
