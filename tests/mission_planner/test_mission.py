"""Mission layout from hand-made solutions: items, speeds, holds, cycles, fence, clearance."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from mission_planner.flight_report import replay_mission
from mission_planner.mission import (
    MissionOptions,
    as_received,
    build_mission,
    cycle_duration_s,
    flown_legs,
    merge_straight_steps,
    mission_summary,
    nudge_clear,
    plan_problems,
    planned_cycle_s,
    scurve_legs,
    service_steps,
    whole_second_holds,
)
from mission_planner.mission.build import APPROACH_M, TRANSIT_STOP_S
from tests.mission_planner.solutions import (
    NUDGED_LEG_SLACK_M,
    circle_points,
    circle_tour,
    make_site,
    solution_for,
    subdivided,
)
from validator.autopilot.waypoint_radius import radius_params
from validator.errors import InputError
from validator.flight import resolve_flight
from validator.geometry import min_leg_clearance, segment_point_distance
from validator.item_lists import GLOBAL_FRAMES
from validator.motion.limits import site_limits
from validator.motion.profile import make_profile
from validator.motion.px4_swing import swing_findings
from validator.plan_format import EXTRA_KEY, Cmd, Frame, dumps_plan, loads_plan
from validator.replay import replay, score_track


@pytest.fixture(scope="module")
def site():
    return make_site()


def _commands(plan):
    return [it.command for it in plan.items]


def _reread(mission):
    return loads_plan(dumps_plan(mission.plan))


def test_layout_takeoff_transit_cycle_jump_return_land(site):
    m = build_mission(circle_tour(site), MissionOptions(cycles=3))
    cmds = _commands(m.plan)
    first, last = m.cycle_items
    assert cmds[0] == Cmd.NAV_TAKEOFF
    assert m.plan.items[0].params[6] == site.altitude_m
    assert m.plan.items[0].frame == Frame.GLOBAL_RELATIVE_ALT
    assert cmds[first] == Cmd.DO_CHANGE_SPEED
    assert cmds[last] == Cmd.NAV_WAYPOINT
    jump = m.plan.items[last + 1]
    assert jump.command == Cmd.DO_JUMP
    assert jump.params[0] == first + 1  # doJumpId of the cycle's first item
    assert jump.params[1] == 2  # three cycles = two repeats
    assert cmds[-1] == Cmd.NAV_LAND
    assert Cmd.NAV_RETURN_TO_LAUNCH not in cmds
    land = m.plan.items[-1]
    np.testing.assert_allclose(site.frame.to_local(land.lat_deg, land.lon_deg), site.home_xy_m,
                               atol=1e-6)


def test_single_cycle_has_no_jump(site):
    m = build_mission(circle_tour(site), MissionOptions(cycles=1))
    assert Cmd.DO_JUMP not in _commands(m.plan)


def test_one_waypoint_per_moving_slot_at_its_end_point(site):
    sol = circle_tour(site)
    m = build_mission(sol, MissionOptions(autopilot="px4"))
    first, last = m.cycle_items
    wps = [it for it in m.plan.items[first:last + 1] if it.command == Cmd.NAV_WAYPOINT]
    assert len(wps) == site.slots
    xy = site.frame.to_local([w.lat_deg for w in wps], [w.lon_deg for w in wps])
    np.testing.assert_allclose(xy, sol.trajectory_m[1:], atol=1e-6)


def test_speed_is_leg_length_over_delta_and_set_only_when_it_changes(site):
    q = circle_points((200, 200), 60, site.slots)
    delta = np.full(site.slots, 1.0)
    delta[25:] = 0.5 * 49 / 25 + 0.5  # second half flown at another speed, still T in total
    delta *= site.period_s / delta.sum()
    m = build_mission(solution_for(site, q, delta), MissionOptions(autopilot="px4"))
    first, last = m.cycle_items
    speeds = [it.params for it in m.plan.items[first:last + 1] if it.command == Cmd.DO_CHANGE_SPEED]
    assert len(speeds) == 2
    leg = float(np.linalg.norm(q[1] - q[0]))
    assert speeds[0][:2] == [1.0, pytest.approx(leg / delta[0])]
    assert speeds[1][1] == pytest.approx(leg / delta[-1])


def test_every_leg_speed_is_at_most_v_and_tiny_excess_is_clipped(site):
    q = circle_points((200, 200), 60, site.slots)
    leg = float(np.linalg.norm(q[1] - q[0]))
    delta = np.full(site.slots, leg / (site.max_speed_mps * (1 + 1e-6)))  # a hair too fast
    m = build_mission(solution_for(site, q, delta))
    speeds = [it.params[1] for it in m.plan.items if it.command == Cmd.DO_CHANGE_SPEED]
    assert max(speeds) <= site.max_speed_mps
    assert not m.problems


def test_a_leg_far_faster_than_v_is_a_problem(site):
    q = circle_points((200, 200), 60, site.slots)
    leg = float(np.linalg.norm(q[1] - q[0]))
    delta = np.full(site.slots, leg / (site.max_speed_mps * 1.5))
    m = build_mission(solution_for(site, q, delta))
    assert any("above the vehicle's" in p for p in m.problems)
    assert max(it.params[1] for it in m.plan.items if it.command == Cmd.DO_CHANGE_SPEED) \
        <= site.max_speed_mps


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
def test_planned_leg_times_sum_to_the_period(site, autopilot):
    q = circle_points((200, 200), 60, site.slots)
    q[10:14] = q[10]  # three hover slots
    rng = np.random.default_rng(3)
    delta = rng.uniform(0.5, 1.5, site.slots)
    delta *= site.period_s / delta.sum()
    m = build_mission(solution_for(site, q, delta), MissionOptions(autopilot=autopilot))
    cycle = planned_cycle_s(_reread(m), site)
    tol = 0.5 if autopilot == "ardupilot" else 1e-6  # whole-second holds on ArduPilot
    assert cycle == pytest.approx(site.period_s, abs=tol)
    assert mission_summary(m)["cycle_duration_s"] == pytest.approx(cycle)


def test_stationary_slots_merge_into_one_hold(site):
    q = circle_points((200, 200), 60, site.slots)
    q[10:14] = q[10]
    m = build_mission(solution_for(site, q), MissionOptions(autopilot="px4"))
    first, last = m.cycle_items
    wps = [it for it in m.plan.items[first:last + 1] if it.command == Cmd.NAV_WAYPOINT]
    assert len(wps) == site.slots - 3
    holds = [w.params[0] for w in wps]
    assert holds[9] == pytest.approx(3 * site.period_s / site.slots)
    assert sum(holds) == pytest.approx(holds[9])


def test_stationary_first_slots_hold_at_q0_first():
    steps = service_steps(np.array([[0, 0], [0, 0], [0, 0.01], [5, 0], [0, 0]]),
                          np.array([2.0, 3.0, 1.0, 1.0]), stationary_tol_m=0.05)
    assert [(s.index, s.slots, s.leg_s, s.hold_s) for s in steps] == [
        (0, (1, 2), 0.0, 5.0), (3, (3,), 1.0, 0.0), (4, (4,), 1.0, 0.0)]


def test_ardupilot_holds_are_whole_seconds_px4_keeps_fractions(site):
    q = circle_points((200, 200), 60, site.slots)
    q[10:12] = q[10]
    q[30:33] = q[30]
    delta = np.random.default_rng(5).uniform(0.5, 1.5, site.slots)
    ap = build_mission(solution_for(site, q, delta))
    px = build_mission(solution_for(site, q, delta), MissionOptions(autopilot="px4"))
    ap_holds = [it.params[0] for it in ap.plan.items if it.command == Cmd.NAV_WAYPOINT]
    px_holds = [it.params[0] for it in px.plan.items if it.command == Cmd.NAV_WAYPOINT]
    assert all(h == int(h) for h in ap_holds)
    assert any(h != int(h) for h in px_holds)
    assert abs(sum(ap_holds) - sum(px_holds)) < 0.5


def test_whole_second_holds_diffuse_the_rounding_error():
    holds = whole_second_holds([0.4, 0.4, 0.0, 0.4, 2.6, 0.0])
    np.testing.assert_array_equal(holds, [0, 1, 0, 0, 3, 0])
    assert abs(holds.sum() - 3.8) < 0.5


def test_slow_leg_flies_at_min_speed_and_holds_the_rest(site):
    q = circle_points((200, 200), 60, site.slots)
    u = (q[5] - q[4]) / np.linalg.norm(q[5] - q[4])
    q[5] = q[4] + 0.1 * u  # slot 5: 0.1 m in 1 s, below ArduCopter's 0.2 m/s minimum
    m = build_mission(solution_for(site, q), MissionOptions(autopilot="px4"))
    step = m.steps[4]
    assert step.slots == (5,)
    assert step.speed_mps == pytest.approx(0.2)
    assert step.hold_s == pytest.approx(1.0 - 0.1 / 0.2)
    assert min(it.params[1] for it in m.plan.items if it.command == Cmd.DO_CHANGE_SPEED) >= 0.2
    assert planned_cycle_s(m.plan, site) == pytest.approx(site.period_s)


def _round_the_wall(autopilot: str = "ardupilot"):
    """A cycle round GN1 with WALL between it and home, and the holds of its outbound transit."""
    site = make_site(no_fly_zones=[{"name": "WALL", "x": 100.0, "y": 0.0, "radius": 30.0}],
                     ground_nodes=[{"name": "GN1", "x": 250.0, "y": 0.0}])
    sol = solution_for(site, circle_points((250.0, 0.0), 40.0, site.slots, phase_rad=math.pi))
    mission = build_mission(sol, MissionOptions(autopilot=autopilot))
    first, _ = mission.cycle_items
    holds = [it.params[0] for it in mission.plan.items[1:first] if it.command == Cmd.NAV_WAYPOINT]
    return site, mission, holds


def test_transit_bends_around_an_nfz_between_home_and_the_cycle():
    site, m, _ = _round_the_wall()
    straight = float(np.linalg.norm(m.solution.trajectory_m[0] - site.home_xy_m))
    assert not m.problems
    assert len(m.outbound_m) > 2 and len(m.return_m) > 2
    for path in (m.outbound_m, m.return_m):
        assert min_leg_clearance(path, site.nfz_xy_m, site.planning_radius_m) >= 0
    summary = mission_summary(m)
    assert straight < summary["transit_out_m"] < straight * 1.2
    # The bend is in the file: some transit waypoint lies off the straight line.
    first, _ = m.cycle_items
    xy = site.frame.to_local([it.lat_deg for it in m.plan.items[2:first]],
                             [it.lon_deg for it in m.plan.items[2:first]])
    assert np.max(np.abs(xy[:, 1])) > 20


def test_a_px4_transit_stops_where_its_swing_would_reach_the_buffer():
    # the transit round WALL hugs its buffer: flown through, PX4's swing region (NAV_ACC_RAD
    # either side of both legs) would reach into it, so the points there hold, and PX4 stops
    site, mission, holds = _round_the_wall("px4")
    assert TRANSIT_STOP_S in holds
    acceptance = radius_params(site, "px4", mission.fence_margin_m)["NAV_ACC_RAD"]
    flight = resolve_flight(mission.plan, site, "px4 transit")
    assert swing_findings(flight, site, acceptance, 0.0) == []


def test_the_mission_duration_counts_the_px4_transits_stops():
    from mission_planner.mission.summary import mission_summary, transit_s

    # both transits pass WALL and stop there: out (the helper's holds) and back
    _, mission, out_holds = _round_the_wall("px4")
    _, last = mission.cycle_items
    back_holds = [it.params[0] for it in mission.plan.items[last + 1:]
                  if it.command == Cmd.NAV_WAYPOINT]
    stops_s = sum(out_holds) + sum(back_holds)
    assert sum(out_holds) > 0 and sum(back_holds) > 0
    summary = mission_summary(mission)
    assert summary["transit_hold_s"] == pytest.approx(stops_s)
    moving = (mission.options.cycles * summary["cycle_duration_s"]
              + transit_s(mission, mission.outbound_m) + transit_s(mission, mission.return_m))
    assert summary["mission_duration_s"] == pytest.approx(moving + stops_s)


def test_an_ardupilot_transit_flies_through_round_a_zone():
    # ArduCopter blends its corners inside the turn, not out of it: no stop is needed
    _, _, holds = _round_the_wall("ardupilot")
    assert set(holds) == {0.0}


def test_the_mission_duration_flies_the_transits_at_what_the_wind_leaves():
    # home to a cycle 250 m east and back, in 6 m/s from the east: out into the wind at the
    # ground speed the top airspeed leaves, back at the transit speed
    from mission_planner.mission.summary import transit_s
    from validator.motion.speed_model import cruise_speed_mps
    from validator.wind import Wind, ground_speed_mps

    site = make_site(ground_nodes=[{"name": "GN1", "x": 250.0, "y": 0.0}], no_fly_zones=[])
    points = circle_points((250.0, 0.0), 40.0, site.slots, phase_rad=math.pi)
    still = build_mission(solution_for(site, points))
    windy_site = site.with_limits(wind=Wind(6.0, 90.0))
    windy = build_mission(solution_for(windy_site, points))
    v = windy.plan.cruise_speed_mps
    top = cruise_speed_mps(windy_site)
    for path, nominal in ((windy.outbound_m, True), (windy.return_m, False)):
        d = np.diff(path, axis=0)
        length = np.hypot(d[:, 0], d[:, 1])
        g = np.minimum(v, ground_speed_mps(top, Wind(6.0, 90.0).vector_mps, d / length[:, None]))
        assert transit_s(windy, path) == pytest.approx(float(np.sum(length / g)))
        assert bool(transit_s(windy, path) > 1.5 * np.sum(length) / v) is nominal
    assert transit_s(still, still.outbound_m) == pytest.approx(
        float(np.sum(np.hypot(*np.diff(still.outbound_m, axis=0).T))) / v)
    assert (mission_summary(windy)["mission_duration_s"]
            > mission_summary(still)["mission_duration_s"] + 20.0)


def _tangent_polygon(centre, distance_m, sides):
    """A closed tour whose every leg passes exactly ``distance_m`` from ``centre``."""
    return circle_points(centre, distance_m / math.cos(math.pi / sides), sides)


def test_legs_short_of_the_buffer_by_solver_noise_are_nudged_clear_after_rounding():
    site = make_site(uav={"altitude": 30.0, "max_speed": 30.0, "period": 40.0, "slots": 40})
    c = site.nfz_xy_m[1]
    r = float(site.planning_radius_m[1])
    q = _tangent_polygon(c, r - 0.004, site.slots)  # 4 mm short on every leg
    m = build_mission(solution_for(site, q))
    assert not m.problems
    assert 0.004 < m.max_nudge_m < 0.03
    legs = flown_legs(_reread(m), site)
    d = segment_point_distance(legs[:, 0], legs[:, 1], c)
    assert np.min(d) >= r - NUDGED_LEG_SLACK_M


def test_without_the_nudge_rounding_leaves_legs_inside_the_buffer():
    site = make_site(uav={"altitude": 30.0, "max_speed": 30.0, "period": 40.0, "slots": 40})
    c = site.nfz_xy_m[1]
    q = _tangent_polygon(c, float(site.planning_radius_m[1]) - 0.02, site.slots)
    m = build_mission(solution_for(site, q), MissionOptions(max_nudge_m=0.0))
    assert m.problems and all("NFZ2" in p and "safety buffer" in p for p in m.problems)


def test_nudge_clear_moves_only_what_is_short():
    pts = np.array([[-10.0, 9.99], [10.0, 9.99], [10.0, 30.0], [-10.0, 30.0]])
    out, moved = nudge_clear(pts, [[0.0, 0.0]], [10.0], target_margin_m=0.01,
                             max_nudge_m=0.05, closed=True)
    assert segment_point_distance(out[0], out[1], [0.0, 0.0]) >= 10.01
    assert moved == pytest.approx(0.02, abs=1e-4)
    np.testing.assert_allclose(out[2:], pts[2:])


def test_a_leg_through_an_nfz_is_reported_not_hidden(site):
    q = circle_points((200, 200), 60, site.slots)
    q[20] = site.nfz_xy_m[2] + [0, 40]
    q[21] = site.nfz_xy_m[2] + [0, -40]  # straight through NFZ3
    q[22] = q[21] + [1, 0]
    m = build_mission(solution_for(site, q, scheme="conventional"))
    assert any("enters NFZ3" in p for p in m.problems)


def test_fence_has_one_exclusion_circle_per_nfz_at_radius_plus_half_buffer(site):
    m = build_mission(circle_tour(site))
    assert len(m.plan.circles) == site.num_nfzs
    for c, centre, r in zip(m.plan.circles, site.nfz_xy_m, site.nfz_radius_m, strict=True):
        assert not c.inclusion
        assert c.radius_m == pytest.approx(r + site.buffer_m / 2)
        np.testing.assert_allclose(site.frame.to_local(c.lat_deg, c.lon_deg), centre, atol=1e-6)
    assert m.plan.rally == [(m.plan.home_lat_deg, m.plan.home_lon_deg, site.altitude_m)]
    assert m.plan.breach_return == m.plan.rally[0]


def test_fence_margin_larger_than_the_buffer_is_refused(site):
    with pytest.raises(InputError, match="fence_margin_m"):
        build_mission(circle_tour(site), MissionOptions(fence_margin_m=site.buffer_m + 0.5))


@pytest.mark.parametrize("kind", ["polygon", "circle"])
def test_operating_area_contains_everything_flown(site, kind):
    m = build_mission(circle_tour(site), MissionOptions(operating_area=kind))
    assert not m.problems
    if kind == "polygon":
        assert len(m.plan.polygons) == 1 and m.plan.polygons[0].inclusion
    else:
        assert sum(c.inclusion for c in m.plan.circles) == 1


def test_rally_point_inside_an_exclusion_circle_is_a_problem(site):
    m = build_mission(circle_tour(site))
    m.plan.circles[0].lat_deg, m.plan.circles[0].lon_deg = m.plan.home_lat_deg, m.plan.home_lon_deg
    assert any("rally" in p for p in plan_problems(m.plan, site))


def test_extra_data_has_exactly_the_agreed_shape(site):
    sol = circle_tour(site)
    m = build_mission(sol, MissionOptions(cycles=2))
    extra = _reread(m).extra
    assert set(extra) == {"format", "site", "scheme", "trajectory_m", "delta_s", "power_w",
                          "schedule", "cycle_items", "cycles"}
    assert extra["format"] == 1 and extra["cycles"] == 2 and extra["scheme"] == "proposed"
    assert len(extra["trajectory_m"]) == site.slots + 1
    assert extra["delta_s"] == sol.delta_s.tolist()
    assert set(extra["schedule"]) <= set(site.gn_names)
    first, last = extra["cycle_items"]
    items = m.plan.items
    assert items[first].command in (Cmd.DO_CHANGE_SPEED, Cmd.NAV_WAYPOINT)
    assert items[last].command == Cmd.NAV_WAYPOINT and items[last + 1].command == Cmd.DO_JUMP
    assert EXTRA_KEY == "nfzMission"


def test_the_plan_as_received_holds_int32_coordinates_and_nothing_else_changed(site):
    plan = build_mission(circle_tour(site), MissionOptions(cycles=2)).plan
    got = as_received(plan)

    def on_grid(*deg):
        return all(d * 1e7 == pytest.approx(round(d * 1e7), abs=1e-6) for d in deg)

    moved = 0
    for a, b in zip(plan.items, got.items, strict=True):
        if a.frame in GLOBAL_FRAMES and math.isfinite(a.lat_deg):
            assert on_grid(b.lat_deg, b.lon_deg)
            assert np.allclose(b.params[4:6], a.params[4:6], rtol=0, atol=0.5e-7)
            moved += b.params[4:6] != a.params[4:6]
            b = replace(b, params=b.params[:4] + a.params[4:6] + b.params[6:])
        np.testing.assert_array_equal(b.params, a.params)
        assert (b.command, b.frame, b.autocontinue) == (a.command, a.frame, a.autocontinue)
    assert moved > 0
    assert on_grid(got.home_lat_deg, got.home_lon_deg)
    assert all(on_grid(c.lat_deg, c.lon_deg) for c in got.circles)
    assert all(on_grid(lat, lon) for lat, lon, _ in got.rally)
    assert [c.radius_m for c in got.circles] == [c.radius_m for c in plan.circles]


def test_geometry_reread_from_the_file_clears_every_nfz(site):
    m = build_mission(circle_tour(site), MissionOptions(cycles=2))
    legs = flown_legs(_reread(m), site)
    d = segment_point_distance(legs[:, None, 0], legs[:, None, 1], site.nfz_xy_m[None])
    assert np.all(d >= site.planning_radius_m - NUDGED_LEG_SLACK_M)


def test_same_solution_same_file(site):
    a = dumps_plan(build_mission(circle_tour(site)).plan)
    b = dumps_plan(build_mission(circle_tour(site)).plan)
    assert a == b


def test_a_site_without_nfzs_gets_straight_transits_and_no_exclusion_fence():
    site = make_site(no_fly_zones=[])
    m = build_mission(circle_tour(site))
    assert not m.problems and m.plan.circles == []
    assert len(m.outbound_m) == 2 and len(m.return_m) == 2
    assert mission_summary(m)["expanded_radius_max_m"] is None


def test_a_cycle_starting_at_home_still_flies_to_q0_first():
    site = make_site()
    q = circle_points((0.0, 60.0), 60.0, site.slots, phase_rad=-math.pi / 2)  # q[0] = home
    m = build_mission(solution_for(site, q))
    first, _ = m.cycle_items
    assert [it.command for it in m.plan.items[:first]] == [Cmd.NAV_TAKEOFF, Cmd.DO_CHANGE_SPEED,
                                                           Cmd.NAV_WAYPOINT]
    assert not m.problems


def _slow_square(autopilot="ardupilot", period_s=180.0):
    """A 100 m square at 2.2 m/s (180 s), entered from a 10 m/s transit."""
    site = make_site(uav={"altitude": 30.0, "max_speed": 10.0, "period": period_s, "slots": 12})
    sq = [(150.0, 150.0), (250.0, 150.0), (250.0, 250.0), (150.0, 250.0)]
    return build_mission(solution_for(site, subdivided(sq, 3)),
                         MissionOptions(autopilot=autopilot))


def _outbound(m):
    """(command, speed or waypoint xy) of the items between the takeoff and the cycle."""
    first, _ = m.cycle_items
    frame = m.solution.site.frame
    out = []
    for it in m.plan.items[1:first]:
        if it.command == Cmd.DO_CHANGE_SPEED:
            out.append(("speed", it.params[1]))
        else:
            out.append(("wp", tuple(np.round(frame.to_local(it.params[4], it.params[5]), 1))))
    return out


def test_a_slower_first_leg_is_commanded_short_of_the_cycle_start():
    m = _slow_square()
    q0 = m.trajectory_m[0]
    out = _outbound(m)
    first_speed = m.steps[0].speed_mps
    assert [k for k, _ in out] == ["speed", "wp", "speed", "wp"]
    assert out[0][1] == pytest.approx(10.0) and out[2][1] == pytest.approx(first_speed)
    assert np.hypot(*(np.array(out[1][1]) - q0)) == pytest.approx(APPROACH_M, abs=0.2)
    assert out[3][1] == pytest.approx(tuple(q0), abs=0.1)


def test_the_approach_keeps_the_first_cycle_on_time():
    # flown through at 10 m/s, the first leg would start fast and the cycle come 4 % early
    assert replay_mission(_slow_square()).cycle_ratio == pytest.approx(1.0, abs=0.02)


def test_px4_missions_have_no_approach_waypoint():
    assert [k for k, _ in _outbound(_slow_square("px4"))] == ["speed", "wp"]


def test_a_first_leg_as_fast_as_the_transit_has_no_approach_waypoint():
    # 100 m sides in 40 s: 10 m/s, the transit's speed
    assert [k for k, _ in _outbound(_slow_square(period_s=40.0))] == ["speed", "wp"]


# ---------------------------------------------------------------------------- long legs

SQUARE = [(150.0, 150.0), (250.0, 150.0), (250.0, 250.0), (150.0, 250.0)]  # clear of every NFZ


@pytest.fixture(scope="module")
def square_site():
    return make_site(uav={"altitude": 30.0, "max_speed": 30.0, "period": 48.0, "slots": 12})


def _waypoints(m):
    first, last = m.cycle_items
    return [it for it in m.plan.items[first:last + 1] if it.command == Cmd.NAV_WAYPOINT]


def test_straight_slots_at_one_speed_become_one_waypoint_per_side(square_site):
    m = build_mission(solution_for(square_site, subdivided(SQUARE, 3)))
    wps = _waypoints(m)
    assert len(wps) == 4 and m.merged_waypoints == 8
    xy = square_site.frame.to_local([w.lat_deg for w in wps], [w.lon_deg for w in wps])
    np.testing.assert_allclose(xy, np.roll(SQUARE, -1, axis=0), atol=1e-6)
    assert [s.moving_slots for s in m.steps] == [3, 3, 3, 3]
    assert mission_summary(m)["service_waypoints_merged"] == 8


def test_merged_legs_keep_the_cycle_time(square_site):
    m = build_mission(solution_for(square_site, subdivided(SQUARE, 3)))
    cycle = planned_cycle_s(_reread(m), square_site)
    assert cycle == pytest.approx(square_site.period_s, abs=1e-6)


def test_no_merge_keeps_one_waypoint_per_slot(square_site):
    m = build_mission(solution_for(square_site, subdivided(SQUARE, 3)),
                      MissionOptions(merge_legs=False))
    assert len(_waypoints(m)) == 12 and m.merged_waypoints == 0


def test_a_speed_change_on_a_straight_line_keeps_its_waypoint(square_site):
    delta = np.full(12, 4.0)
    delta[1] *= 1.02  # slot 2 flies 2 % slower than slots 1 and 3 of the same side
    delta[4] *= 1.001  # slot 5: 0.1 % slower: 1 cm behind at its end, merged
    delta *= square_site.period_s / delta.sum()
    m = build_mission(solution_for(square_site, subdivided(SQUARE, 3), delta),
                      MissionOptions(autopilot="px4"))
    assert [s.moving_slots for s in m.steps] == [1, 1, 1, 3, 3, 3]
    assert len(_waypoints(m)) == 6


@pytest.mark.parametrize("slower, merged", [(1.005, True), (1.02, False)])
def test_short_slots_merge_only_within_the_speed_tolerance(slower, merged):
    # 1 m slots: 2 % slower is only 1 cm behind, but above the 1 % speed tolerance.
    q = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    steps = service_steps(q, np.array([1.0, slower]), stationary_tol_m=0.05)
    assert (len(merge_straight_steps(steps, q)) == 1) == merged


def test_a_hover_on_a_straight_line_keeps_its_waypoint(square_site):
    q = subdivided(SQUARE, 3)
    q = np.insert(q, 2, q[1], axis=0)[:-1]  # hover at q[1] for one slot, drop one of side 4
    q[-1] = q[0]
    m = build_mission(solution_for(square_site, q), MissionOptions(autopilot="px4"))
    assert m.steps[0].moving_slots == 1 and m.steps[0].hold_s > 0
    assert m.steps[1].moving_slots == 2


@pytest.mark.parametrize("bend_deg, merged", [(0.05, True), (0.5, False), (2.0, False)])
def test_slots_merge_only_within_a_few_centimetres_of_straight(bend_deg, merged):
    # Two 30 m slots meeting at a bend: 0.05° puts the corner 1.3 cm off the chord (merged),
    # 0.5° 13 cm (more than 5 cm although within 1°), 2° is above the 1° tolerance.
    a = math.radians(bend_deg / 2)
    q = np.array([[0.0, 0.0], [30 * math.cos(a), 30 * math.sin(a)], [60 * math.cos(a), 0.0]])
    steps = service_steps(q, np.array([1.0, 1.0]), stationary_tol_m=0.05)
    out = merge_straight_steps(steps, q)
    assert (len(out) == 1) == merged


@pytest.mark.parametrize("gap_m, merged", [(0.0, False), (0.02, True)])
def test_a_merged_leg_keeps_the_clearance_its_slots_had(gap_m, merged):
    # Slots bowed 2 cm away from an NFZ below them: the chord is 2 cm closer to it. It may
    # merge only if the chord still keeps the 1 cm export margin.
    q = np.array([[0.0, 0.0], [30.0, 0.02], [60.0, 0.0]])
    steps = service_steps(q, np.array([1.0, 1.0]), stationary_tol_m=0.05)
    out = merge_straight_steps(steps, q, nfz_xy_m=[[30.0, -20.0 - gap_m]], nfz_radius_m=[20.0],
                               clearance_target_m=0.01)
    assert (len(out) == 1) == merged


def _planned_position(q, delta, t):
    """Where the planned (per-slot) trajectory is t seconds into the cycle."""
    knots = np.concatenate([[0.0], np.cumsum(delta)])
    return np.column_stack([np.interp(t, knots, q[:, 0]), np.interp(t, knots, q[:, 1])])


def test_flown_merged_legs_stay_within_the_offset_of_the_plan_at_every_instant(square_site):
    q = subdivided(SQUARE, 3)
    rng = np.random.default_rng(7)
    q[1:-1] += rng.uniform(-0.01, 0.01, q[1:-1].shape)  # solver-like noise off the sides
    q[[3, 6, 9]] = np.array(SQUARE)[1:]  # corners where they are
    sol = solution_for(square_site, q)
    m = build_mission(sol, MissionOptions(autopilot="px4"))
    assert m.merged_waypoints == 8
    flight = resolve_flight(m.plan, square_site)
    track = replay(flight, make_profile("ideal", site_limits(square_site)), dt_s=0.01)
    rep = score_track(track, flight, square_site, m.plan)
    inside = (track.t_s >= rep.cycle.start_s) & (track.t_s <= rep.cycle.end_s)
    t = track.t_s[inside] - rep.cycle.start_s
    planned = _planned_position(sol.trajectory_m, sol.delta_s, t)
    gap = np.hypot(*(track.xy_m[inside] - planned).T)
    assert np.max(gap) <= MissionOptions().merge_offset_m
    assert m.merge_offset_m <= MissionOptions().merge_offset_m


def _ideal_throughput(m, site):
    flight = resolve_flight(m.plan, site)
    rep = score_track(replay(flight, make_profile("ideal", site_limits(site)), dt_s=0.01), flight,
                      site,
                      m.plan)
    assert rep.throughput is not None, [f.message for f in rep.findings]
    return rep.throughput


def test_the_validator_scores_merged_legs_as_the_slots_they_replace(square_site):
    sol = solution_for(square_site, subdivided(SQUARE, 3))
    merged = _ideal_throughput(build_mission(sol, MissionOptions(autopilot="px4")), square_site)
    per_slot = _ideal_throughput(build_mission(sol, MissionOptions(autopilot="px4",
                                                                   merge_legs=False)),
                                 square_site)
    np.testing.assert_allclose(merged.planned_bps_hz, per_slot.planned_bps_hz, rtol=1e-12)
    np.testing.assert_allclose(merged.flown_bps_hz, per_slot.flown_bps_hz, rtol=1e-3)


def test_merged_slot_end_points_lie_on_their_leg_at_their_planned_time(square_site):
    delta = np.linspace(3.0, 5.0, 12)
    delta[:3] = 4.0  # side 1 at one speed, the others speeding up
    delta *= square_site.period_s / delta.sum()
    m = build_mission(solution_for(square_site, subdivided(SQUARE, 3), delta),
                      MissionOptions(autopilot="px4"))
    q = np.array(m.plan.extra["trajectory_m"])
    assert m.steps[0].moving_slots == 3
    t = np.cumsum(delta[:3])
    expect = q[0] + (t[:2] / t[2])[:, None] * (q[3] - q[0])
    np.testing.assert_allclose(q[1:3], expect, atol=1e-9)


def _scurve_square(per_side=4, stretch=1.0):
    """100 m sides timed as the autopilot's S-curve at V (side 2 ``stretch`` times slower),
    ``per_side`` equal slots each, then a hover at the first corner for the rest of T."""
    site = make_site(uav={"altitude": 30.0, "max_speed": 10.0, "period": 80.0,
                          "slots": 4 * per_side + 1})
    prof = scurve_legs(site, [100.0], site.max_speed_mps, "ardupilot", {})
    total = float(prof.total_s[0])
    along, _, _ = prof.state(np.zeros(per_side, dtype=np.int64),
                             total * np.arange(1, per_side + 1) / per_side)
    corners = np.array(SQUARE)
    points, delta = [corners[0]], []
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        points += list(a + along[:, None] / 100.0 * (b - a))
        delta += [total / per_side * (stretch if k == 1 else 1.0)] * per_side
    points.append(corners[0])
    delta.append(site.period_s - sum(delta))
    return site, solution_for(site, np.array(points), np.array(delta))


def test_slots_timed_as_the_autopilot_s_curve_become_one_leg_at_top_speed():
    # ArduPilot: the square is laid along ArduCopter's S-curve, and a mission merges slots
    # along its own autopilot's motion model (a PX4 mission along PX4's)
    site, sol = _scurve_square()
    m = build_mission(sol, MissionOptions(autopilot="ardupilot"))
    assert [(s.moving_slots, s.scurve) for s in m.steps] == [(4, True)] * 4
    first, last = m.cycle_items
    speeds = [it.params[1] for it in m.plan.items[first:last + 1]
              if it.command == Cmd.DO_CHANGE_SPEED]
    assert speeds == [site.max_speed_mps]
    # the hover is written in whole seconds (error diffusion: within half a second of T)
    assert cycle_duration_s(m) == pytest.approx(site.period_s, abs=0.5)
    assert mission_summary(m)["scurve_legs"] == 4


def test_slots_off_the_s_curve_are_not_merged_as_one():
    _, sol = _scurve_square(stretch=1.05)  # side 2 flown 5 % slower than the autopilot would
    m = build_mission(sol, MissionOptions(autopilot="ardupilot"))
    side2 = [s for s in m.steps if set(s.slots[:s.moving_slots]) <= {5, 6, 7, 8}]
    assert side2 and not any(s.scurve for s in side2)
    assert sum(s.scurve for s in m.steps) == 3


def test_the_validator_scores_s_curve_legs():
    # ArduPilot: the square is laid along ArduCopter's S-curve, and a mission merges slots
    # along its own autopilot's motion model (a PX4 mission along PX4's)
    site, sol = _scurve_square()
    m = build_mission(sol, MissionOptions(autopilot="ardupilot"))
    flight = resolve_flight(m.plan, site)
    rep = score_track(replay(flight, make_profile("arducopter", site_limits(site))), flight, site,
                      m.plan)
    assert rep.throughput is not None, [f.message for f in rep.findings]
