"""A ``.plan``'s DO_JUMP names its target by the target's ``doJumpId``, as QGroundControl reads
it, whatever the ids are; plans with ids 1..N in order (ours, QGroundControl's) read as before."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.validator.builders import jump, make_site, nav, plan_of
from validator.cli import validate_mission_main
from validator.errors import InputError
from validator.flight import resolve_flight
from validator.plan_format import Cmd, dumps_plan, loads_plan, plan_to_dict
from validator.site import Site, site_to_dict

JUMP_ITEM = 4  # the DO_JUMP's index in _plan_dict's items
GOLDEN_PLANS = sorted((Path(__file__).parents[1] / "golden").glob("*/mission.plan"))


@pytest.fixture()
def site() -> Site:
    return make_site()


def _plan_dict(site: Site, ids: list[int] | None, target_id: float) -> dict[str, Any]:
    """Takeoff, waypoints A, B, C, a DO_JUMP naming ``target_id`` once, LAND (its approach and
    descent are two legs); each item's ``doJumpId`` from ``ids`` (None: no item has one, as in
    a plan written by hand)."""
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), nav(site, Cmd.NAV_WAYPOINT, (0, 60)),
             nav(site, Cmd.NAV_WAYPOINT, (60, 60)), nav(site, Cmd.NAV_WAYPOINT, (60, 100)),
             jump(0, 1), nav(site, Cmd.NAV_LAND, site.home_xy_m, 0.0)]
    data = plan_to_dict(plan_of(site, items))
    entries = data["mission"]["items"]  # type: ignore[index]
    for entry, jump_id in zip(entries, ids or [None] * len(entries), strict=True):
        if jump_id is None:
            del entry["doJumpId"]
        else:
            entry["doJumpId"] = jump_id
    entries[JUMP_ITEM]["params"][0] = target_id
    return data


def _legs(site: Site, data: dict[str, Any]) -> list[int]:
    return [leg.item for leg in resolve_flight(loads_plan(json.dumps(data)), site).legs]


def test_a_do_jump_goes_to_the_item_carrying_its_doJumpId_not_to_that_position(site):
    # ids of A and B swapped by hand: doJumpId 3 is A (item 1), while position 3 is B
    data = _plan_dict(site, [1, 3, 2, 4, 5, 6], target_id=3)
    assert _legs(site, data) == [0, 1, 2, 3, 1, 2, 3, 5, 5]


def test_doJumpIds_far_from_the_positions_name_their_targets(site):
    data = _plan_dict(site, [10, 20, 30, 40, 50, 60], target_id=30)
    assert _legs(site, data) == [0, 1, 2, 3, 2, 3, 5, 5]


def test_items_without_doJumpId_are_named_by_their_number_from_1(site):
    # QGroundControl writes each item's number as its id; a plan written by hand may omit it
    data = _plan_dict(site, None, target_id=3)
    assert _legs(site, data) == [0, 1, 2, 3, 2, 3, 5, 5]


def test_a_plan_read_and_written_again_jumps_to_the_same_item(site):
    data = _plan_dict(site, [1, 3, 2, 4, 5, 6], target_id=3)
    again = json.loads(dumps_plan(loads_plan(json.dumps(data))))
    assert _legs(site, again) == _legs(site, data)


@pytest.mark.parametrize("path", GOLDEN_PLANS, ids=lambda p: p.parent.name)
def test_a_plan_the_planner_wrote_reads_and_writes_back_bit_for_bit(path: Path):
    text = path.read_text()
    assert dumps_plan(loads_plan(text)) == text


def test_a_doJumpId_no_item_has_is_refused_naming_the_item(site):
    # 3 is a position in the plan but no item's id: read as a position it would fly to B
    data = _plan_dict(site, [10, 20, 30, 40, 50, 60], target_id=3)
    with pytest.raises(InputError, match=r"^m\.plan\.mission\.items\[4\] \(item 5, DO_JUMP\): "
                                         r"no item has doJumpId 3"):
        loads_plan(json.dumps(data), "m.plan")


def test_a_doJumpId_two_items_carry_is_refused_where_a_jump_names_it(site):
    data = _plan_dict(site, [1, 2, 2, 4, 5, 6], target_id=2)
    with pytest.raises(InputError, match=r"items\[4\] \(item 5, DO_JUMP\): its target, "
                                         r"doJumpId 2, is ambiguous: items\[1\] and items\[2\] "
                                         "both have it"):
        loads_plan(json.dumps(data), "m.plan")


def test_a_doJumpId_that_is_no_whole_number_is_refused_naming_the_item(site):
    data = _plan_dict(site, [1, 2, 2.5, 4, 5, 6], target_id=2)  # type: ignore[list-item]
    with pytest.raises(InputError, match=r"m\.plan\.mission\.items\[2\]\.doJumpId: expected an "
                                         r"integer"):
        loads_plan(json.dumps(data), "m.plan")


def test_validate_mission_refuses_a_jump_to_no_doJumpId_in_one_line(site, tmp_path: Path,
                                                                      capsys):
    site_path = tmp_path / "site.yaml"
    site_path.write_text(yaml.safe_dump(site_to_dict(site)))
    plan_path = tmp_path / "edited.plan"
    plan_path.write_text(json.dumps(_plan_dict(site, [10, 20, 30, 40, 50, 60], target_id=3)))
    assert validate_mission_main([str(plan_path), "--site", str(site_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    # the JSON path counts from 0 as JSON does; the item's number is QGroundControl's
    assert f"{plan_path}.mission.items[4] (item 5, DO_JUMP): no item has doJumpId 3" in err
