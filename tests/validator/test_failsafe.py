"""The failsafe audit: exact return paths, and a corpus of parameter files over both autopilots.

The corpus (tests/data/failsafe/corpus.json: 35 cases, 31 parameter files on four sites, each
with an ArduCopter and a PX4 plan) says which parameters each file leaves flying a straight
return into a zone or its buffer. Each verdict is checked twice: against the audit, and
against an independent oracle here that samples every 0.5 m of every leg, draws the straight
line to the destination the firmware picks, and measures it against every zone.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import shapely

from tests.validator.builders import make_site, nav, plan_of, speed, waypoint_plan
from validator.autopilot.param_file import read_params
from validator.cli import validate_mission_main
from validator.failsafe import audit_failsafes
from validator.flight import DO_SET_HOME, resolve_flight
from validator.plan_format import (
    Autopilot,
    Cmd,
    Frame,
    MissionItem,
    Plan,
    read_plan,
    write_plan,
)
from validator.site import Site, load_site
from validator.validation import validate_mission

DATA = Path(__file__).resolve().parents[1] / "data" / "failsafe"
CORPUS = json.loads((DATA / "corpus.json").read_text())


# --------------------------------------------------------------------------------------------
# an independent oracle: sampled starts, the destination rule as documented, straight lines


def _destination(p: np.ndarray, home: np.ndarray, rally: np.ndarray, params: dict[str, float],
                 px4: bool) -> np.ndarray:
    if not len(rally):
        return home
    d = np.hypot(*(rally - p).T)
    if px4:  # the nearest of home and the rally points > 10 m from home, a rally 2 m nearer
        best, least = home, math.inf if params.get("RTL_TYPE", 0) == 1 else float(
            np.hypot(*(home - p)))
        for r, dist in zip(rally, d, strict=True):
            if np.hypot(*(r - home)) > 10.0 and dist + 2.0 < least:
                best, least = r, dist
        return best
    i = int(np.argmin(d))
    limit_m = 1000.0 * params.get("RALLY_LIMIT_KM", 0.3)
    if limit_m > 0 and d[i] > limit_m:
        return home
    if params.get("RALLY_INCL_HOME", 1) and np.hypot(*(home - p)) <= d[i]:
        return home
    return rally[i]


def oracle_return_clearance(plan: Plan, site: Site, params: dict[str, float]) -> float:
    """The least clearance minus buffer of a straight return from any sampled point."""
    flight = resolve_flight(plan, site)
    px4 = plan.firmware_type == Autopilot.PX4
    rally = np.array([site.frame.to_local(lat, lon) for lat, lon, _ in plan.rally]).reshape(-1, 2)
    starts = []
    for leg in flight.legs:
        n = max(2, int(np.hypot(*(leg.end_xy_m - leg.start_xy_m)) / 0.5) + 1)
        t = np.linspace(0.0, 1.0, n)[:, None]
        starts.append(leg.start_xy_m + t * (leg.end_xy_m - leg.start_xy_m))
    pts = np.vstack(starts)
    ends = np.array([_destination(p, flight.home_xy_m, rally, params, px4) for p in pts])
    lines = shapely.linestrings(np.stack([pts, ends], axis=1))
    least = math.inf
    for c, r in zip(site.nfz_xy_m, site.nfz_radius_m, strict=True):
        least = min(least, float(np.min(shapely.distance(shapely.Point(c), lines))) - r)
    for z in site.polygon_zones:
        d = np.asarray(shapely.distance(z.shape, lines))
        least = min(least, float(np.min(d)) if np.all(d > 0) else -1.0)
    return least - site.buffer_m


@pytest.mark.parametrize("case", CORPUS, ids=[f"{c['params']}@{c['plan']}" for c in CORPUS])
def test_the_audit_flags_exactly_the_parameters_whose_return_crosses_a_zone(case):
    params = read_params(DATA / case["params"])
    site = load_site(DATA / case["site"])
    plan = read_plan(DATA / case["plan"])
    report = audit_failsafes(plan, site, resolve_flight(plan, site), params)
    flagged = {f.param for f in report.findings}
    assert flagged == set(case["flagged"]), case["why"]
    # the expected verdict follows from the geometry: every parameter whose action may fly a
    # straight return is flagged when, and only when, some straight return enters a buffer
    returns = {c.param for c in report.checks if "rtl" in c.paths}
    crosses = oracle_return_clearance(plan, site, params) < 0.0
    assert set(case["flagged"]) == (returns if crosses else set())


def test_the_corpus_covers_both_autopilots_and_both_verdicts():
    files = {c["params"] for c in CORPUS}
    assert len(files) >= 20
    assert {Path(c["plan"]).stem.split("-")[1] for c in CORPUS} == {"ardupilot", "px4"}
    assert any(c["flagged"] for c in CORPUS) and any(not c["flagged"] for c in CORPUS)


# --------------------------------------------------------------------------------------------
# exact geometry


def _square_site():
    # home (0, 0); the mission goes out to (200, 60), down to (200, -60) and back: the zone
    # at (100, 0) sits between that leg and home
    return make_site(nfz=((100.0, 0.0, 20.0), (100.0, 45.0, 5.0)),
                     gns=((200.0, 60.0), (200.0, -60.0)), buffer_m=2.0)


def test_an_rtl_through_the_centre_is_as_deep_as_the_radius():
    site = _square_site()
    plan = waypoint_plan(site, [(200.0, 60.0), (200.0, -60.0)])
    report = audit_failsafes(plan, site, resolve_flight(plan, site), {"FS_THR_ENABLE": 1})
    rc = [f for f in report.findings if f.param == "FS_THR_ENABLE"]
    assert [(f.zone, f.item) for f in rc] == [("NFZ1", 3)]  # only from the leg to (200, -60)
    assert rc[0].clearance_m == pytest.approx(-20.0, abs=1e-9)
    assert rc[0].start_xy_m[1] == pytest.approx(0.0, abs=0.5)  # fired abeam the centre
    assert "enters NFZ1 20.00 m deep" in rc[0].message


def test_the_return_region_is_measured_exactly_not_sampled():
    site = _square_site()
    plan = waypoint_plan(site, [(200.0, 60.0), (200.0, -60.0)])
    w = audit_failsafes(plan, site, resolve_flight(plan, site), {}).worst_return
    assert w is not None and w.zone == "NFZ1" and w.clearance_m == pytest.approx(-20.0)
    # NFZ2 (100, 45), r 5, lies beside the outbound leg y = 0.3 x: the triangles reach no
    # nearer than that leg, 15 / sqrt(1.09) m from its centre
    site2 = make_site(nfz=((100.0, 45.0, 5.0),), gns=((200.0, 60.0), (200.0, -60.0)))
    plan2 = waypoint_plan(site2, [(200.0, 60.0), (200.0, -60.0)])
    w2 = audit_failsafes(plan2, site2, resolve_flight(plan2, site2), {}).worst_return
    assert w2 is not None
    assert w2.clearance_m == pytest.approx(15.0 / math.sqrt(1.09) - 5.0, abs=1e-6)


def test_smartrtl_land_and_continue_are_clear_wherever_the_mission_is():
    site = _square_site()
    plan = waypoint_plan(site, [(200.0, 60.0), (200.0, -60.0)])
    safe = {"FS_THR_ENABLE": 5, "FS_GCS_ENABLE": 7, "BATT_FS_LOW_ACT": 4, "BATT_FS_CRT_ACT": 1,
            "FS_DR_ENABLE": 1, "FENCE_ACTION": 5}
    assert audit_failsafes(plan, site, resolve_flight(plan, site), safe).ok
    cont = {**safe, "FS_THR_ENABLE": 1, "FS_OPTIONS": 1}  # RC loss continues the mission
    assert audit_failsafes(plan, site, resolve_flight(plan, site), cont).ok
    assert not audit_failsafes(plan, site, resolve_flight(plan, site),
                               {**safe, "FS_THR_ENABLE": 4}).ok  # SmartRTL or RTL


# --------------------------------------------------------------------------------------------
# a home moved mid-mission (DO_SET_HOME): returns go to the home in force on each leg

RTL_ITEM = MissionItem(int(Cmd.NAV_RETURN_TO_LAUNCH), [0.0] * 7, int(Frame.MISSION))


def _moved_home_beyond_the_zone(site: Site) -> Plan:
    # the mission stays west of home, so returns to home at (0, 0) keep off NFZ1 (100, 0);
    # index 2 (item 3) moves home to (200, 0), east of NFZ1, before the leg to index 3
    return plan_of(site, [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(5.0),
                          nav(site, DO_SET_HOME, (200.0, 0.0)),
                          nav(site, Cmd.NAV_WAYPOINT, (-50.0, 50.0)),
                          nav(site, Cmd.NAV_WAYPOINT, (-50.0, -50.0)),
                          nav(site, Cmd.NAV_LAND, (-50.0, -50.0), 0.0)])


def test_a_return_after_a_do_set_home_flies_to_the_new_home_across_a_zone():
    site = make_site()
    plan = _moved_home_beyond_the_zone(site)
    report = audit_failsafes(plan, site, resolve_flight(plan, site), {"FS_THR_ENABLE": 1})
    found = {(f.zone, f.item, f.destination) for f in report.findings}  # f.item: the index
    assert found == {("NFZ1", 3, "home set by item 3"), ("NFZ1", 4, "home set by item 3"),
                     ("NFZ1", 5, "home set by item 3")}
    assert all(f.destination_xy_m == pytest.approx((200.0, 0.0), abs=1e-6)
               for f in report.findings)
    rc = next(f for f in report.findings if f.param == "FS_THR_ENABLE" and f.item == 4)
    assert "RTL straight to home set by item 3 and enters NFZ1 20.00 m deep, from the leg " \
           "item 4 -> item 5" in rc.message  # indices 3 -> 4


def test_returns_before_a_do_set_home_still_fly_to_the_plans_home():
    site = make_site()
    plan = _moved_home_beyond_the_zone(site)
    flight = resolve_flight(plan, site)
    report = audit_failsafes(plan, site, flight, {"FS_THR_ENABLE": 1})
    takeoff = [f for f in report.findings if f.item == 0]
    assert takeoff == [] and flight.home_of(0).set_by_item is None


def _moved_home_past_the_zone(site: Site, firmware: Autopilot) -> Plan:
    # the leg (200, 60) -> (200, -60) passes NFZ1 (100, 0) on its far side from home (0, 0),
    # so a return to home from it crosses NFZ1; item 3 makes (200, 60) home first
    here = MissionItem(DO_SET_HOME, [1.0, 0, 0, 0, 0, 0, 0], int(Frame.MISSION))  # PX4's frame
    items = [nav(site, Cmd.NAV_TAKEOFF, site.home_xy_m), speed(5.0),
             nav(site, Cmd.NAV_WAYPOINT, (200.0, 60.0)), here,
             nav(site, Cmd.NAV_WAYPOINT, (200.0, -60.0)), RTL_ITEM]
    return dataclasses.replace(plan_of(site, items), firmware_type=int(firmware))


def test_a_home_moved_past_the_zone_makes_the_returns_beyond_it_clear():
    site = _square_site()
    plan = _moved_home_past_the_zone(site, Autopilot.ARDUPILOTMEGA)
    report = audit_failsafes(plan, site, resolve_flight(plan, site), {"FS_THR_ENABLE": 1})
    assert report.findings == ()


def test_px4_returns_to_a_home_its_mission_moved_to_the_current_position():
    site = _square_site()
    plan = _moved_home_past_the_zone(site, Autopilot.PX4)
    report = audit_failsafes(plan, site, resolve_flight(plan, site), {"NAV_RCL_ACT": 2})
    assert report.findings == ()


# --------------------------------------------------------------------------------------------
# validate-mission --params


def test_validate_mission_fails_a_file_whose_failsafe_crosses_a_zone_unless_forced(tmp_path,
                                                                                   capsys):
    plan, site = DATA / "plans/realistic-ardupilot.plan", DATA / "sites/realistic.yaml"
    bad, good = DATA / "params/thr-rtl.param", DATA / "params/realistic-ardupilot-planned.param"
    out = tmp_path / "r.json"
    assert validate_mission_main([str(plan), "--site", str(site), "--params", str(bad),
                                  "--report", str(out)]) == 1
    text = capsys.readouterr().out
    assert "VIOLATION" in text and "FS_THR_ENABLE 1 (Enabled always RTL)" in text
    report = json.loads(out.read_text())
    assert {f["param"] for f in report["failsafe"]["findings"]} == {"FS_THR_ENABLE"}
    assert min(f["clearance_m"] for f in report["failsafe"]["findings"]) < 0
    assert validate_mission_main([str(plan), "--site", str(site), "--params", str(bad),
                                  "--force"]) == 0
    forced = capsys.readouterr().out
    assert "warning   item 7: failsafe RC loss" in forced and "Result: CLEAR" in forced
    assert validate_mission_main([str(plan), "--site", str(site), "--params", str(good)]) == 0


def test_validate_mission_fails_a_return_to_a_home_moved_behind_a_zone(tmp_path, capsys):
    """The open site's plan is clear under a plain RTL (home sees the whole cycle); a
    DO_SET_HOME before the last leg moving home south of NFZ1 (no rally point to go to
    instead) puts NFZ1 between that leg and the home its returns fly to."""
    site_file = DATA / "sites/open.yaml"
    site, plan = load_site(site_file), read_plan(DATA / "plans/open-ardupilot.plan")
    lat, lon = site.frame.to_geodetic(np.array([250.0, -100.0]))
    moved = MissionItem(DO_SET_HOME, [0.0, 0.0, 0.0, math.nan, float(lat), float(lon), 30.0],
                        int(Frame.GLOBAL_RELATIVE_ALT))
    items = [*plan.items[:9], moved, *plan.items[9:]]  # after the cycle's last waypoint
    path = tmp_path / "moved-home.plan"
    write_plan(dataclasses.replace(plan, items=items, rally=[]), path)
    assert validate_mission_main([str(path), "--site", str(site_file), "--params",
                                  str(DATA / "params/thr-rtl.param")]) == 1
    text = capsys.readouterr().out
    # the DO_SET_HOME at index 9 is QGroundControl's item 10
    assert "VIOLATION item 12: failsafe RC loss: FS_THR_ENABLE 1 (Enabled always RTL) flies " \
           "RTL straight to home set by item 10 and enters NFZ1 35.00 m deep, from the leg " \
           "item 9 -> item 12" in text


def test_without_a_parameter_file_there_is_no_failsafe_audit():
    v = validate_mission(DATA / "plans/realistic-ardupilot.plan", DATA / "sites/realistic.yaml")
    assert v.failsafe is None and v.exit_status == 0


def test_the_text_lists_the_deepest_coast_per_zone_and_the_report_every_leg(tmp_path, capsys):
    """In wind a GPS loss's coast reaches zones from dozens of legs: the text says the deepest
    per zone and from how many more legs (as it does the failsafe paths); the JSON report
    keeps every leg."""
    plan, site = DATA / "plans/realistic-ardupilot.plan", DATA / "sites/realistic.yaml"
    out = tmp_path / "r.json"
    validate_mission_main([str(plan), "--site", str(site), "--params",
                           str(DATA / "params/realistic-ardupilot-planned.param"),
                           "--wind", "6@270", "--report", str(out)])
    coasts = json.loads(out.read_text())["failsafe"]["position_loss"]
    lines = [line for line in capsys.readouterr().out.splitlines() if "GPS loss: from" in line]
    zones = {c["zone"] for c in coasts}
    assert len(coasts) > len(zones) and len(lines) == len(zones)
    for zone in zones:
        of = [c for c in coasts if c["zone"] == zone]
        deepest = min(of, key=lambda c: c["clearance_m"])
        line = next(x for x in lines if f"may enter {zone} " in x)
        assert f"{-deepest['clearance_m']:.2f} m deep" in line
        more = f"(and from {len(of) - 1} more leg(s))"
        assert line.endswith(more) if len(of) > 1 else "more leg" not in line


def test_the_failsafe_table_points_the_gps_loss_row_at_its_coast(tmp_path, capsys):
    """The row of the failsafe that acts after a GPS loss (EKF3's; with drag fusion the
    dead-reckoning one) says how many legs' coasts reach a zone, not just 'clear'."""
    plan, site = DATA / "plans/realistic-ardupilot.plan", DATA / "sites/realistic.yaml"
    planned = DATA / "params/realistic-ardupilot-planned.param"
    drag = tmp_path / "drag.param"
    drag.write_text(planned.read_text() + "\nEK3_DRAG_BCOEF_X 9.5\nEK3_DRAG_BCOEF_Y 9.5\n"
                    "EK3_DRAG_MCOEF 0.082\n")

    def rows(params: Path) -> dict[str, str]:
        validate_mission_main([str(plan), "--site", str(site), "--params", str(params),
                               "--wind", "6@270"])
        text = capsys.readouterr().out
        return {p: next(line for line in text.splitlines() if f" {p} " in line)
                for p in ("FS_EKF_ACTION", "FS_DR_ENABLE")}

    free, reckoned = rows(planned), rows(drag)
    assert "its coast after a GPS loss:" in free["FS_EKF_ACTION"]
    assert "coast" not in free["FS_DR_ENABLE"]
    assert "its coast after a GPS loss:" in reckoned["FS_DR_ENABLE"]
    assert "coast" not in reckoned["FS_EKF_ACTION"]
    validate_mission_main([str(DATA / "plans/realistic-px4.plan"), "--site", str(site),
                           "--params", str(DATA / "params/realistic-px4-planned.params")])
    px4 = next(line for line in capsys.readouterr().out.splitlines()
               if " COM_POSCTL_NAVL " in line)
    # PX4's coast is modelled too: its plan at the 3 m buffer passes NFZ3 within its reach
    assert re.search(r"its coast after a GPS loss: \d+ leg warning\(s\)$", px4), px4
