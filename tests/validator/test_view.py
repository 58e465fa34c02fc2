"""The mission view's figure and page without a browser: optional layers, the rates the slider
shows, a self-contained page, and the commands' --html, --html-map and --flown."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from validator.cli import validate_mission_main
from validator.validation import validate_mission
from validator.view import FailsafePath, ViewInputs, Wind, validation_inputs, view_figure
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
    paths = (FailsafePath("RTL from item 4", np.array([[0.0, 0.0], [100.0, 50.0]])),
             FailsafePath("RTL from item 7", np.array([[10.0, 0.0], [90.0, 50.0]]), ok=False,
                          note="crosses NFZ2"))
    inputs = dataclasses.replace(validation_inputs(validation), failsafe_paths=paths,
                                 wind=Wind(8.0, 270.0))
    fig = view_figure(inputs)
    failsafe = [t for t in fig["data"] if t.get("meta", {}).get("layer") == "failsafe"]
    assert [t["line"]["color"] for t in failsafe] == ["#2ca02c", "#d62728"]
    assert failsafe[1]["hovertext"] == "RTL from item 7: crosses NFZ2"
    arrow, text = fig["layout"]["annotations"]
    # from the west, so it blows east: the arrow's tail is left of its head, level with it
    assert arrow["ax"] < 0 and abs(arrow["ay"]) < 1e-9
    assert "8 m/s from 270°" in text["text"]


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
