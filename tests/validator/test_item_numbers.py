"""One number for a mission item wherever a person reads it (validator.item_numbers): the
number QGroundControl shows (its doJumpId, index + 1, home 0), which is ArduPilot's wire seq.
These fail if any reader drifts back to the 0-based index or to PX4's wire seq."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from tests.validator.builders import jump, make_site, nav, plan_of, speed, waypoint_plan
from tests.view_figure import layer
from validator.audit import audit
from validator.errors import InputError
from validator.flight import resolve_flight
from validator.geojson_format import plan_geojson
from validator.item_numbers import item_label, item_number, list_item_label, wire_item_number
from validator.mavlink.connection import VehicleInfo
from validator.mavlink.mission_protocol import _name
from validator.mavlink.storage import first_stored_difference, stored_form
from validator.mavlink.wire import MissionType, plan_to_wire
from validator.motion.limits import site_limits
from validator.motion.profile import make_profile
from validator.plan_format import Autopilot, Cmd, plan_to_dict
from validator.replay import replay, score_track
from validator.view import ViewInputs, view_figure
from validator.view.inputs import TrackLayer
from validator.view.timeline import Timeline

ARDUPILOT, PX4 = int(Autopilot.ARDUPILOTMEGA), int(Autopilot.PX4)


def _qgc_number(plan, index: int) -> int:
    """The number QGroundControl shows for ``plan.items[index]``: the doJumpId it writes."""
    return int(plan_to_dict(plan)["mission"]["items"][index]["doJumpId"])


def test_the_rule():
    assert [item_number(i) for i in (-1, 0, 20)] == [0, 1, 21]
    assert [item_label(i) for i in (-1, 0, 20)] == ["home", "item 1", "item 21"]
    # ArduPilot's mission seq is the number; PX4's is the index; fence and rally keep theirs
    assert wire_item_number(21, home_item=True) == wire_item_number(20, home_item=False) == 21
    for mtype in (1, 2):
        assert wire_item_number(3, home_item=True, mission_type=mtype) == 3
        assert wire_item_number(3, home_item=False, mission_type=mtype) == 3
    assert list_item_label(3, home_item=False, mission_type=1) == "fence item 3"
    assert list_item_label(3, home_item=True, mission_type=2) == "rally item 3"


@pytest.fixture(scope="module")
def site():
    return make_site()


@pytest.fixture(scope="module")
def crossing(site):
    # the leg from the waypoint at index 3 to the one at index 4 passes 15 m from NFZ1's centre
    return waypoint_plan(site, [(0, -15), (75, -15), (125, -15), (200, -15)], end="none")


def test_an_audit_finding_names_the_item_qgroundcontrol_shows(crossing, site):
    report = audit(crossing, site)
    (bad,) = [f for f in report.violations if "enters NFZ1" in f.message]
    assert bad.item == 4  # the index, inside
    a, b = _qgc_number(crossing, 3), _qgc_number(crossing, 4)
    assert (a, b) == (4, 5)
    assert bad.message.startswith(f"leg item {a} -> item {b} (waypoint)")
    data = report.as_dict()
    assert {"item": b, "severity": "violation", "message": bad.message} in data["findings"]
    (nfz,) = data["nfz"]
    assert (nfz["from_item"], nfz["item"]) == (a, b)
    first = data["legs"][0]
    assert (first["from_item"], first["item"]) == (0, 1)  # home is 0, the takeoff is 1


def test_arducopter_and_px4_name_the_same_plan_item_alike(crossing):
    """A read-back that differs at plan index 3: ArduPilot's seq 4, PX4's seq 3, one number."""
    said = []
    for autopilot, home_item in ((ARDUPILOT, True), (PX4, False)):
        sent = plan_to_wire(crossing, home_item=home_item).mission
        k = 3 + int(home_item)
        kept = [stored_form(w, autopilot) for w in sent]  # as the autopilot holds them
        held = (*kept[:k], dataclasses.replace(kept[k], z=kept[k].z + 7.0), *kept[k + 1:])
        said.append(first_stored_difference(sent, held, MissionType.MISSION, autopilot,
                                            skip_seq0=home_item))
    assert said[0] is not None and said[0].startswith("mission item 4: z ")
    assert said[1] is not None and said[1].startswith("mission item 4: z ")
    assert _qgc_number(crossing, 3) == 4


def test_upload_and_download_messages_name_the_same_number_on_both_autopilots():
    def link(autopilot: int):
        return SimpleNamespace(vehicle=VehicleInfo(1, 1, autopilot, 2))

    assert _name(link(ARDUPILOT), MissionType.MISSION, 4) == "mission item 4"
    assert _name(link(PX4), MissionType.MISSION, 3) == "mission item 4"
    assert _name(link(PX4), MissionType.FENCE, 3) == "fence item 3"
    assert _name(link(ARDUPILOT), MissionType.RALLY, 0) == "rally item 0"


def test_the_do_jump_message_names_the_jump_and_its_target_in_one_numbering(site):
    # the DO_JUMP is the third item: QGroundControl's item 3; it names a 4th that is not there
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(5.0), jump(3, 1)]
    plan = plan_of(site, items)
    assert _qgc_number(plan, 2) == 3
    with pytest.raises(InputError, match=r"^plan: item 3 \(DO_JUMP\): target 4 is not an item "
                                         r"\(1\.\.3\)$"):
        resolve_flight(plan, site, "plan")


def test_the_view_marker_and_the_timeline_say_the_number(crossing, site):
    flight = resolve_flight(crossing, site)
    track = replay(flight, _ideal(site))
    inputs = ViewInputs(crossing, site, flight, tracks=(TrackLayer("replay", track),))
    (marks,) = layer(view_figure(inputs), "waypoint")
    shown = sorted(n for group in marks["meta"]["items"] for n in group)
    assert shown == sorted({_qgc_number(crossing, leg.item) for leg in flight.legs})
    assert any(text.startswith("<b>item 5</b>: NAV_WAYPOINT") for text in
               "<br>—<br>".join(marks["hovertext"]).split("<br>—<br>"))
    # the time slider's read-out at the end of the flight: on the last waypoint, index 5
    hover = Timeline(inputs)._state(float(track.t_s[-1]))[0]["hovertext"][0]
    assert "item 6" in hover and int(track.mission_seq[-1]) == 5


def test_a_scored_track_reports_numbers(crossing, site):
    flight = resolve_flight(crossing, site)
    rep = score_track(replay(flight, _ideal(site)), flight, site).as_dict()
    lags = rep["waypoint_lag"]
    assert [w["item"] for w in lags] == [item_number(leg.item) for leg in flight.legs]
    (nfz,) = rep["nfz"]
    assert nfz["item"] in {item_number(leg.item) for leg in flight.legs}
    assert np.isfinite(nfz["t_s"])


def _ideal(site):
    return make_profile("ideal", site_limits(site))


def test_the_geojson_waypoints_carry_the_number(crossing, site):
    feats = plan_geojson(crossing, site)["features"]
    numbers = [f["properties"]["item"] for f in feats if f["properties"]["kind"] == "waypoint"]
    positioned = [i for i, it in enumerate(crossing.items) if it.command != Cmd.DO_CHANGE_SPEED]
    assert numbers == [_qgc_number(crossing, i) for i in positioned] == [1, 3, 4, 5, 6]
