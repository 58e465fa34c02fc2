"""The HTML mission view in a real browser (headless Chromium through Selenium): it loads with
no console error, its layers match the plan, hovering a waypoint tells its details, the
time slider moves the vehicle, and a home a DO_SET_HOME moves is drawn and tells its legs.

Skips with the reason when no browser is installed (``scripts/install-browser.sh``).
``VIEW_SCREENSHOT=docs/view.png`` also saves the sample site's view, the slider moved, as the
README shows it.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import pytest

from tests.browser import WAIT_FOR_PLOT, chromium, find_browser
from validator.item_numbers import item_number
from validator.validation import validate_mission
from validator.view import validation_inputs, write_view

REPO = Path(__file__).resolve().parents[2]
SAMPLE_PLAN = REPO / "tests/golden/realistic-vehicle/mission.plan"  # samples/realistic.yaml's
SAMPLE_SITE = REPO / "samples/realistic.yaml"
FLOWN = REPO / "tests/data/px4-sih/realistic-ardutimed"  # a plan flown in PX4 SIH, recorded

found = find_browser()
pytestmark = pytest.mark.skipif(isinstance(found, str), reason=str(found))


@pytest.fixture(scope="module")
def browser():
    assert not isinstance(found, str)
    with chromium(*found) as session:
        yield session


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    v = validate_mission(SAMPLE_PLAN, SAMPLE_SITE, replay_flight=True)
    path = tmp_path_factory.mktemp("view") / "sample.html"
    write_view(path, validation_inputs(v, title="realistic.yaml: the quick start's mission"))
    return v, path


@pytest.fixture(scope="module")
def flown(tmp_path_factory):
    v = validate_mission(FLOWN / "mission.plan", FLOWN / "site.yaml", replay_flight=True,
                         flown_track=FLOWN / "track.csv.gz")
    path = tmp_path_factory.mktemp("view") / "flown.html"
    write_view(path, validation_inputs(v))
    return v, path


def _open(browser, path: Path) -> float:
    """Load the page and wait for the plot and its frames; seconds it took."""
    browser.get_log("browser")  # drop what an earlier page logged
    started = time.perf_counter()
    browser.get(path.as_uri())
    assert browser.execute_async_script(WAIT_FOR_PLOT), "the plot never appeared"
    return time.perf_counter() - started


def _until(browser, script: str, *args, timeout_s: float = 10.0):
    """Poll a JavaScript function body until it returns something truthy (or time is up): a
    busy machine answers a mouse move or a frame late, never by a fixed sleep."""
    end = time.monotonic() + timeout_s
    while True:
        value = browser.execute_script(script, *args)
        if value or time.monotonic() > end:
            return value
        time.sleep(0.05)


HOVER_TEXT = "const h = document.querySelector('.hoverlayer'); return h && h.textContent;"
VEHICLE = ("document.getElementById('mission-view').data.filter("
           "t => t.meta && t.meta.layer === 'vehicle')[0]")


def _layer_counts(browser) -> dict[str, int]:
    return browser.execute_script("""
        const out = {};
        for (const t of document.getElementById('mission-view').data) {
          const k = t.meta && t.meta.layer; if (k) out[k] = (out[k] || 0) + 1; }
        return out;""")


def _trace(browser, layer: str, index: int = 0) -> dict:
    return browser.execute_script(
        "return document.getElementById('mission-view').data.filter("
        "t => t.meta && t.meta.layer === arguments[0])[arguments[1]];", layer, index)


def test_sample_view_loads_with_no_console_error(browser, sample):
    _, path = sample
    seconds = _open(browser, path)
    errors = [e for e in browser.get_log("browser") if e["level"] in ("SEVERE", "WARNING")]
    assert errors == []
    # plotly's own schema check: every attribute the page sets is one plotly knows and uses
    # (a slider step's arguments are only read when it is used: "dynamic")
    problems = browser.execute_script(
        "const gd = document.getElementById('mission-view');"
        "return Plotly.validate(gd.data, gd.layout) || [];")
    assert [p["msg"] for p in problems if p["code"] != "dynamic"] == []
    print(f"loaded in {seconds:.2f} s, {path.stat().st_size / 1e6:.2f} MB")


def test_layers_match_the_plan(browser, sample):
    v, path = sample
    _open(browser, path)
    counts = _layer_counts(browser)
    assert counts["zone"] == len(v.site.zone_names) == 3
    assert counts["buffer"] == len(v.site.zone_names)
    assert counts["fence"] == len(v.plan.circles) + len(v.plan.polygons)
    assert counts["track"] == 1 and counts["vehicle"] == 1
    assert counts["rally"] == 1 and counts["home"] == 1
    items = sorted({item_number(leg.item) for leg in v.flight.legs})  # as QGroundControl's
    waypoints = _trace(browser, "waypoint")
    assert sorted(i for at in waypoints["meta"]["items"] for i in at) == items
    places = {tuple(np.round(leg.end_xy_m, 1)) for leg in v.flight.legs}
    # drawn, not only declared: one SVG marker per place a waypoint is
    drawn = browser.find_elements("css selector", ".scatterlayer .tracewaypoints path.point")
    assert len(drawn) == len(waypoints["x"]) == len(places)


def test_hovering_a_waypoint_shows_its_details(browser, sample):
    from selenium.webdriver.common.action_chains import ActionChains

    v, path = sample
    _open(browser, path)
    waypoints = _trace(browser, "waypoint")
    drawn = browser.find_elements("css selector", ".scatterlayer .tracewaypoints path.point")
    # a service waypoint alone at its place: one the planner's slots are flown to
    k = next(i for i, text in enumerate(waypoints["hovertext"])
             if "slots" in text and len(waypoints["meta"]["items"][i]) == 1)
    ActionChains(browser).move_to_element(drawn[k]).perform()
    shown = _until(browser, HOVER_TEXT)
    item = waypoints["meta"]["items"][k][0]  # its number, index + 1
    assert f"item {item}: NAV_WAYPOINT" in shown
    leg = next(leg for leg in v.flight.legs if item_number(leg.item) == item)
    assert f"speed {leg.speed_mps:.2f} m/s" in shown and "hold" in shown
    assert "slot" in shown and "of T" in shown and "clearance" in shown


def test_the_slider_moves_the_vehicle(browser, sample):
    from selenium.webdriver.common.action_chains import ActionChains

    v, path = sample
    _open(browser, path)
    vehicle = browser.find_element("css selector", ".scatterlayer .tracevehicle0 path.point")
    before = vehicle.rect
    start_x = _trace(browser, "vehicle")["x"][0]
    grip = browser.find_element("css selector", ".slider-grip-rect")
    rail = browser.find_element("css selector", ".slider-rail-rect")
    # drag the grip 60 % of the way along the rail, as a user would
    ActionChains(browser).click_and_hold(grip).move_by_offset(
        int(rail.rect["width"] * 0.6), 0).release().perform()
    assert _until(browser, f"return {VEHICLE}.x[0] !== arguments[0];", start_x)
    t = float(browser.execute_script(
        "const s = document.getElementById('mission-view')._fullLayout.sliders[0];"
        "return s.steps[s.active].label;"))
    assert t > 0
    after = browser.find_element("css selector", ".scatterlayer .tracevehicle0 path.point").rect
    assert (after["x"], after["y"]) != (before["x"], before["y"])
    # where the replay is at that time
    track = v.replay_track
    assert track is not None
    j = int(np.argmin(np.abs(track.t_s - t)))
    drawn = _trace(browser, "vehicle")
    assert np.allclose([drawn["x"][0], drawn["y"][0]], track.xy_m[j], atol=0.01)
    shown = browser.find_element("css selector", ".slider-group .slider-label").text
    assert shown.startswith("t = ")
    shot = os.environ.get("VIEW_SCREENSHOT")  # the README's picture: the vehicle mid-cycle,
    if shot:  # a waypoint's details shown
        waypoints = _trace(browser, "waypoint")
        k = next(i for i, text in enumerate(waypoints["hovertext"])
                 if "slots" in text and len(waypoints["meta"]["items"][i]) == 1)
        point = browser.find_elements("css selector", ".scatterlayer .tracewaypoints path.point")
        ActionChains(browser).move_to_element(point[k]).perform()
        assert _until(browser, HOVER_TEXT)
        browser.get_screenshot_as_file(shot)


def test_a_flown_track_is_drawn_beside_the_replay(browser, flown):
    v, path = flown
    _open(browser, path)
    assert [e for e in browser.get_log("browser") if e["level"] == "SEVERE"] == []
    counts = _layer_counts(browser)
    assert counts["track"] == 2 and counts["vehicle"] == 2
    names = [_trace(browser, "track", i)["name"] for i in range(2)]
    assert names[0].startswith("replay") and names[1].startswith("flown (recorded")
    rates = _trace(browser, "flown-rate", 1)
    assert v.sitl is not None and v.sitl.throughput is not None
    assert np.allclose(rates["y"], v.sitl.throughput.flown_bps_hz, atol=1e-3)


@pytest.fixture()
def served(tmp_path):
    """A web server on loopback for ``tmp_path``: browsers refuse MapLibre's worker from a
    file:// page, so a map view is opened the way the README says, over HTTP."""
    import functools
    import http.server
    import threading

    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(tmp_path))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield tmp_path, f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


def test_the_map_background_view_draws_the_layers_and_moves_the_vehicle(
        browser, sample, served, monkeypatch):
    import validator.view.page as page

    monkeypatch.setattr(page, "MAP_STYLE", "white-bg")  # no tiles to fetch in a test
    v, _ = sample
    folder, url = served
    write_view(folder / "map.html", validation_inputs(v), map_background=True)
    browser.get_log("browser")
    browser.get(f"{url}/map.html")
    assert browser.execute_async_script(WAIT_FOR_PLOT), "the map never appeared"
    offline = ("ERR_NAME_NOT_RESOLVED", "ERR_INTERNET_DISCONNECTED", "AJAXError", "favicon")
    errors = [e["message"] for e in browser.get_log("browser")
              if e["level"] == "SEVERE" and not any(s in e["message"] for s in offline)]
    assert errors == []
    counts = _layer_counts(browser)
    assert counts["zone"] == len(v.site.zone_names) and counts["vehicle"] == 1
    assert _trace(browser, "zone")["type"] == "scattermap"
    before = _trace(browser, "vehicle")["lat"]
    browser.execute_script(
        "Plotly.animate(document.getElementById('mission-view'), ['100'], {mode: 'immediate',"
        " frame: {duration: 0, redraw: true}, transition: {duration: 0}});")
    assert _until(browser, f"return {VEHICLE}.lat[0] !== arguments[0];", before[0])
    after = _trace(browser, "vehicle")
    lat, lon = v.site.frame.to_geodetic(v.replay_track.xy_m[np.argmin(
        np.abs(v.replay_track.t_s - 100.0))])
    assert after["lat"] != before and np.allclose([after["lat"][0], after["lon"][0]],
                                                  [lat, lon], atol=1e-6)


FAILSAFE = REPO / "tests/data/failsafe"


@pytest.fixture(scope="module")
def audited():
    """issue 27's site: the RC-loss RTL of thr-rtl.param flies through NFZ3; in wind."""
    from validator.autopilot.param_file import read_params
    from validator.wind import Wind

    return validate_mission(FAILSAFE / "plans/realistic-ardupilot.plan",
                            FAILSAFE / "sites/realistic.yaml", replay_flight=True,
                            vehicle_params=read_params(FAILSAFE / "params/thr-rtl.param"),
                            wind=Wind(6.0, 300.0, 1.5))


@pytest.mark.parametrize("map_background", [False, True])
def test_failsafe_paths_and_the_wind_are_drawn(browser, audited, served, monkeypatch,
                                               map_background):
    import validator.view.page as page

    monkeypatch.setattr(page, "MAP_STYLE", "white-bg")  # no tiles to fetch in a test
    folder, url = served
    write_view(folder / "failsafe.html", validation_inputs(audited),
               map_background=map_background)
    browser.get_log("browser")
    browser.get(f"{url}/failsafe.html")
    assert browser.execute_async_script(WAIT_FOR_PLOT), "the view never appeared"
    offline = ("ERR_NAME_NOT_RESOLVED", "ERR_INTERNET_DISCONNECTED", "AJAXError", "favicon")
    assert [e["message"] for e in browser.get_log("browser") if e["level"] == "SEVERE"
            and not any(s in e["message"] for s in offline)] == []
    problems = browser.execute_script(
        "const gd = document.getElementById('mission-view');"
        "return Plotly.validate(gd.data, gd.layout) || [];")
    assert [p["msg"] for p in problems if p["code"] != "dynamic"] == []
    counts = _layer_counts(browser)
    assert counts["failsafe"] == 3  # the return region, the RTL into NFZ3, SmartRTL's path
    region = next(_trace(browser, "failsafe", i) for i in range(3)
                  if _trace(browser, "failsafe", i)["meta"]["kind"] == "region")
    assert region["fill"] == "toself" and region["meta"]["ok"] is False
    if not map_background:  # drawn: a filled SVG path, light red (the zones are darker)
        fills = browser.find_elements("css selector", ".scatterlayer .js-fill")
        assert sum("fill: rgb(214, 39, 40); fill-opacity: 0.08" in f.get_attribute("style")
                   for f in fills) == 1
    arrows = browser.find_elements("css selector", ".annotation-arrow-g")
    assert len(arrows) == 1  # the flown wind; the plan was made for still air: no arrow
    texts = [a.text for a in browser.find_elements("css selector", ".annotation-text-g")]
    assert any("6 m/s from 300°" in t for t in texts)
    assert any("still air" in t for t in texts)
    shot = os.environ.get("VIEW_FAILSAFE_SCREENSHOT")
    if shot and not map_background:
        browser.get_screenshot_as_file(shot)


def test_a_home_moved_by_do_set_home_is_drawn_apart_and_tells_where_it_is_in_force(
        browser, tmp_path):
    """The quick start's plan with a DO_SET_HOME after waypoint 8 moving home to (150, 250),
    under issue 27's RC-loss RTL: the moved home is its own open, named square, and hovering
    it says which DO_SET_HOME put it in force and on which legs."""
    import dataclasses
    import math

    from selenium.webdriver.common.action_chains import ActionChains

    from validator.autopilot.param_file import read_params
    from validator.flight import DO_SET_HOME
    from validator.plan_format import Frame, MissionItem, read_plan, write_plan
    from validator.site import load_site

    lat, lon = load_site(SAMPLE_SITE).frame.to_geodetic(np.array([150.0, 250.0]))
    moved = MissionItem(DO_SET_HOME, [0.0, 0.0, 0.0, math.nan, float(lat), float(lon), 30.0],
                        int(Frame.GLOBAL_RELATIVE_ALT))
    plan = read_plan(SAMPLE_PLAN)
    assert plan.extra is not None and plan.extra["cycle_items"] == [3, 12]
    # inside the service cycle: its last item moves one on, so the planned slots still match
    write_plan(dataclasses.replace(plan, items=[*plan.items[:9], moved, *plan.items[9:]],
                                   extra={**plan.extra, "cycle_items": [3, 13]}),
               tmp_path / "set-home.plan")
    v = validate_mission(tmp_path / "set-home.plan", SAMPLE_SITE, replay_flight=True,
                         vehicle_params=read_params(FAILSAFE / "params/thr-rtl.param"))
    write_view(tmp_path / "set-home.html", validation_inputs(v))
    _open(browser, tmp_path / "set-home.html")
    assert [e for e in browser.get_log("browser") if e["level"] in ("SEVERE", "WARNING")] == []
    problems = browser.execute_script(
        "const gd = document.getElementById('mission-view');"
        "return Plotly.validate(gd.data, gd.layout) || [];")
    assert [p["msg"] for p in problems if p["code"] != "dynamic"] == []
    counts = _layer_counts(browser)
    assert counts["home"] == 1 and counts["set-home"] == 1
    (point,) = browser.find_elements("css selector", ".scatterlayer .traceset-home path.point")
    labels = [t.text for t in browser.find_elements(
        "css selector", ".scatterlayer .traceset-home .textpoint")]
    assert labels == ["home set by item 10"]  # the DO_SET_HOME at index 9
    legend = [t.text for t in browser.find_elements("css selector", ".legend .legendtext")]
    assert "home" in legend and "home set by DO_SET_HOME" in legend
    ActionChains(browser).move_to_element(point).perform()
    shown = _until(browser, HOVER_TEXT)
    assert "home set by item 10 (DO_SET_HOME, at its coordinates)" in shown
    assert "in force on the legs to items 11 ... 16" in shown and "150 m E, 250 m N" in shown
