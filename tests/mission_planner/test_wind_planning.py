"""Planning for the wind: the air-frame cone in (P3-2) and in the plan, the timing in wind,
what the plan and report say, refusals, and validate-mission in another wind."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from mission_planner.cli import plan_mission_main
from mission_planner.optimize import PAPER_OPTIONS, plan
from mission_planner.optimize.initial import initial_tour
from mission_planner.optimize.overrelax import feasible, flyable_slots
from mission_planner.optimize.scaled import LENGTH_UNIT_M, scale_site
from mission_planner.optimize.trajectory import TrajectoryProblem
from mission_planner.optimize.trajectory_model import TrajectoryModel
from mission_planner.study.sites import random_site
from validator.cli import validate_mission_main
from validator.errors import InputError
from validator.plan_format import Cmd, read_plan
from validator.site import load_site
from validator.wind import Wind, ground_speed_mps

SAMPLE = "samples/realistic.yaml"
HARBOUR = "tests/data/arducopter-sitl-wind/sites/harbour.yaml"


def _air_excess(q: np.ndarray, delta: np.ndarray, wind: np.ndarray, speed: float) -> np.ndarray:
    """‖q[n] − q[n−1] − w δ[n]‖ − V δ[n] for a closed (N+1, 2) trajectory (SI or scaled)."""
    legs = np.diff(q, axis=0)
    return np.asarray(np.linalg.norm(legs - delta[:, None] * wind[None, :], axis=1)
                      - speed * delta)


def test_trajectory_step_keeps_the_air_frame_cone_and_agrees_with_the_model() -> None:
    site = random_site(4, slots=24).with_limits(wind=Wind(9.0, 250.0))
    sc = scale_site(site, 0.02)
    assert sc.wind is not None
    q, delta = initial_tour(sc)
    assert feasible(sc, q, delta, np.full(sc.num_slots, 0.9), "proposed")
    rng = np.random.default_rng(4)
    s = rng.dirichlet(np.ones(sc.num_gns), size=sc.num_slots).T
    power = rng.uniform(0.5, 1.0, sc.num_slots)
    shape = (sc.num_slots, sc.num_gns, sc.num_nfzs, "proposed", 1)
    direct = TrajectoryProblem(*shape).solve(sc, q, delta, power, s)
    oracle = TrajectoryModel(*shape, wind=True).solve(sc, q, delta, power, s)
    assert direct is not None and oracle is not None
    assert direct.r_min == pytest.approx(oracle.r_min, abs=1e-4)
    for step in (direct, oracle):
        closed = np.vstack([step.q[-1:], step.q])
        assert np.all(_air_excess(closed, step.delta, sc.wind, sc.speed) <= 1e-6)
    # Without the wind the same step would leave the cone: it binds
    still = TrajectoryProblem(*shape).solve(scale_site(random_site(4, slots=24), 0.02), q, delta,
                                            power, s)
    assert still is not None
    closed = np.vstack([still.q[-1:], still.q])
    assert np.max(_air_excess(closed, still.delta, sc.wind, sc.speed)) > 1e-3


def test_flyable_slots_meet_the_air_frame_limit() -> None:
    sc = scale_site(random_site(2, slots=20).with_limits(wind=Wind(12.0, 90.0)), 0.02)
    q, delta = initial_tour(sc)
    d = flyable_slots(sc, q * 1.05, delta)
    assert d is not None
    legs = q * 1.05 - np.roll(q * 1.05, 1, axis=0)
    assert np.all(sc.air_excess(legs, d) <= 1e-9)
    assert np.sum(d) == pytest.approx(sc.num_slots)


def test_paper_plan_in_wind_keeps_the_cone_in_every_slot() -> None:
    wind = Wind(10.0, 300.0)
    site = random_site(1, slots=30).with_limits(wind=wind)
    sol = plan(site, options=PAPER_OPTIONS)
    excess = _air_excess(sol.trajectory_m, sol.delta_s, wind.vector_mps, site.max_speed_mps)
    assert np.max(excess) <= 1e-4 * site.max_speed_mps * float(np.max(sol.delta_s))
    ground = np.linalg.norm(np.diff(sol.trajectory_m, axis=0), axis=1)
    assert np.all(ground <= site.max_speed_mps * sol.delta_s * (1 + 1e-6))
    assert sol.report()["wind"]["at_flight_altitude"]["speed_mps"] == 10.0
    # The cone binds somewhere: against the wind the plan is slower than V over the ground.
    assert np.max(excess) > -1e-3 * LENGTH_UNIT_M


def test_calm_wind_plans_as_still_air() -> None:
    site = random_site(1, slots=20)
    a = plan(site, options=PAPER_OPTIONS)
    b = plan(site.with_limits(wind=Wind(0.0, 120.0)), options=PAPER_OPTIONS)
    assert np.array_equal(a.trajectory_m, b.trajectory_m)
    assert np.array_equal(a.delta_s, b.delta_s)


def test_plan_refuses_a_wind_beyond_the_top_speed() -> None:
    site = load_site(SAMPLE).with_limits(wind=Wind(10.5, 45.0))
    with pytest.raises(InputError, match=r"^wind: 10.5 m/s from 45° is at or above the "
                                         r"vehicle's top airspeed 10\.00 m/s"):
        plan(site)


def test_plan_refuses_a_wind_beyond_the_airspeed_held_through_its_gusts() -> None:
    site = load_site(SAMPLE).with_limits(wind=Wind(9.9, 45.0, 2.0))
    with pytest.raises(InputError, match=r"^wind: 9.9 m/s from 45°, turbulence 2 m/s is at "
                                         r"or above the airspeed the vehicle holds through its "
                                         r"gusts, 9\.78 m/s"):
        plan(site)


def test_plan_mission_refuses_such_a_wind_with_one_line(tmp_path, capsys) -> None:
    out = tmp_path / "m.plan"
    code = plan_mission_main([SAMPLE, "-o", str(out), "--wind", "11@90", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "11 m/s from 90°" in err and "top airspeed" in err
    assert not list(tmp_path.iterdir())


@pytest.fixture(scope="module")
def windy_plan(tmp_path_factory):
    d = tmp_path_factory.mktemp("wind")
    out = d / "w.plan"
    code = plan_mission_main([SAMPLE, "-o", str(out), "--report", str(d / "w.json"),
                              "--wind", "6@270,1.5", "--quiet"])
    assert code == 0
    return d, out


def test_every_leg_transits_included_is_commanded_what_the_wind_leaves(windy_plan) -> None:
    """Transits too: commanded the cruise speed into the wind, ArduCopter SITL leaned to its
    limit and gave up the track (harbour in 8 m/s from 45°: 0.8 m downwind of a transit leg
    all along it, 2.6 m from the breakwater it was planned 3.44 m from)."""
    from validator.flight import resolve_flight
    from validator.motion.speed_model import commanded_top_speed_mps, cruise_speed_mps

    _, out = windy_plan
    site = load_site(SAMPLE).with_limits(wind=Wind(6.0, 270.0, 1.5))
    flight = resolve_flight(read_plan(out), site)
    cruise = cruise_speed_mps(site)
    # in turbulence 1.5 m/s, what the lean limit holds through the gusts
    held = commanded_top_speed_mps(site)
    assert held < cruise - 0.05
    capped = 0
    for leg in flight.legs:
        if leg.length_m < 1.0 or leg.speed_mps is None:
            continue
        u = (leg.end_xy_m - leg.start_xy_m) / leg.length_m
        g = ground_speed_mps(held, Wind(6.0, 270.0).vector_mps, u[None, :])[0]
        assert leg.speed_mps <= g + 0.02, (leg.item, leg.speed_mps, g)
        capped += leg.speed_mps < cruise - 0.1
    assert capped >= 1


def test_the_summary_line_says_the_wind(tmp_path, capsys) -> None:
    out = tmp_path / "w.plan"
    assert plan_mission_main([SAMPLE, "-o", str(out), "--wind", "3@90", "--quiet",
                              "--report", str(tmp_path / "r.json")]) == 0
    line = capsys.readouterr().out
    assert "planned for wind 3 m/s from 90°" in line
    # how long the replay flies it, in that wind: the figure held against the battery
    flown_s = json.loads((tmp_path / "r.json").read_text())["flight"]["replayed_mission_s"]
    assert "arducopter replay: cycle 1" in line and f"take-off to landing {flown_s:.0f} s" in line


def test_windy_plan_says_its_wind_and_commands_ground_speeds(windy_plan) -> None:
    d, out = windy_plan
    plan_file = read_plan(out)
    assert plan_file.extra["wind"] == {"speed_mps": 6.0, "from_deg": 270.0,
                                       "turbulence_mps": 1.5}
    report = json.loads((d / "w.json").read_text())
    assert report["wind"]["speed_mps"] == 6.0
    # the most airspeed a leg is commanded: what the lean limit holds through 1.5 m/s gusts
    held = report["wind"]["commanded_airspeed_max_mps"]
    assert held == pytest.approx(math.sqrt(10.08 ** 2 - 1.5 * 1.5 ** 2), abs=0.01)
    flight = report["flight"]
    assert abs(flight["cycle_ratio"] - 1.0) <= 0.05  # flown in its wind, on time
    # Every cycle leg is commanded at most the ground speed its course leaves of 10 m/s
    site = load_site(SAMPLE)
    traj = np.asarray(plan_file.extra["trajectory_m"])
    frame = site.frame
    items = plan_file.items
    first, last = plan_file.extra["cycle_items"]
    speed = None
    prev = None
    slower = 0
    for it in items[first:last + 1]:
        if it.command == Cmd.DO_CHANGE_SPEED:
            speed = it.params[1]
        elif it.command == Cmd.NAV_WAYPOINT:
            here = frame.to_local(it.params[4], it.params[5])
            if prev is not None and speed is not None and np.hypot(*(here - prev)) > 1.0:
                u = (here - prev) / np.hypot(*(here - prev))
                g = ground_speed_mps(10.07, Wind(6.0, 270.0).vector_mps, u[None, :])[0]
                assert speed <= g + 0.05
                slower += speed < 9.9
            prev = here
    assert slower >= 1 and len(traj) == 65


def test_the_planner_times_a_windy_cycle_as_the_replay_flies_it(windy_plan) -> None:
    """Its cycle is timed with the exported speeds: a leg after a corner first runs at the
    speed commanded before it (the planner timing its legs at the planning speed instead
    flew them up to 1.9 s a cycle faster than the exported plan)."""
    d, _ = windy_plan
    report = json.loads((d / "w.json").read_text())
    assert report["flight"]["replayed_cycle_s"] == pytest.approx(
        report["mission"]["cycle_duration_s"], abs=0.1)


def test_validate_mission_reports_another_wind(windy_plan, capsys) -> None:
    d, out = windy_plan
    code = validate_mission_main([str(out), "--site", SAMPLE, "--params",
                                  str(out.with_suffix(".param")), "--report",
                                  str(d / "v.json")])
    assert code == 0
    as_planned = json.loads((d / "v.json").read_text())
    assert as_planned["wind"]["as_planned"] is True
    cycle = as_planned["replay"]["cycle"]
    assert cycle["flown_cycle_s"] / cycle["planned_period_s"] == pytest.approx(1.0, abs=0.05)
    code = validate_mission_main([str(out), "--site", SAMPLE, "--params",
                                  str(out.with_suffix(".param")), "--wind", "8@90",
                                  "--report", str(d / "v8.json")])
    text = capsys.readouterr().out
    assert "NOT the plan's wind" in text and "flown in 8 m/s from 90°" in text
    stronger = json.loads((d / "v8.json").read_text())
    assert stronger["wind"]["as_planned"] is False
    assert stronger["wind"]["flown_in"]["speed_mps"] == 8.0
    # from the other side and stronger: the cycle no longer keeps T
    cycle = stronger["replay"]["cycle"]
    assert cycle["flown_cycle_s"] / cycle["planned_period_s"] > 1.05


def test_a_wind_beyond_the_buffer_models_flights_is_a_warning(windy_plan, tmp_path,
                                                               capsys) -> None:
    # the track-deviation model is fitted to SITL flights up to 8 m/s, turbulence 2 m/s
    _, out = windy_plan
    assert validate_mission_main([str(out), "--site", SAMPLE, "--params",
                                  str(out.with_suffix(".param")), "--wind", "9@270,1"]) in (0, 1)
    text = capsys.readouterr().out
    assert "  warning: the wind buffer's track deviation is fitted to SITL flights" in text
    assert plan_mission_main([SAMPLE, "-o", str(tmp_path / "g.plan"), "--quiet",
                              "--dynamics", "none", "--wind", "4@90,3"]) == 0
    [line] = [x for x in capsys.readouterr().err.splitlines() if "extrapolated" in x]
    assert line.startswith("plan-mission: warning: the wind buffer's track deviation")
    assert "in 4 m/s from 90°, turbulence 3 m/s its" in line


def test_validate_mission_refuses_a_wind_the_plan_cannot_fly(windy_plan, capsys) -> None:
    _, out = windy_plan
    code = validate_mission_main([str(out), "--site", SAMPLE, "--wind", "12@180"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert "cannot be flown: 12 m/s from 180°" in err and "mission item" in err


@pytest.mark.parametrize("arg", ["7@", "7", "7@400", "x@3", "-2@30"])
def test_plan_mission_refuses_a_malformed_wind(tmp_path, capsys, arg) -> None:
    code = plan_mission_main([SAMPLE, "-o", str(tmp_path / "m.plan"), f"--wind={arg}"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "--wind" in err
    assert not list(tmp_path.iterdir())


def test_a_malformed_plan_wind_is_refused_naming_the_field(windy_plan, tmp_path, capsys) -> None:
    _, out = windy_plan
    plan = json.loads(out.read_text())
    plan["nfzMission"]["wind"] = {"speed_mps": 3.0, "from_deg": 10.0, "gust": 1.0}
    bad = tmp_path / "bad.plan"
    bad.write_text(json.dumps(plan))
    assert validate_mission_main([str(bad), "--site", SAMPLE]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "nfzMission.wind.gust: unknown key" in err


def test_a_wind_plan_is_not_worse_than_the_still_air_path_retimed_in_the_wind() -> None:
    """realistic.yaml at 6 m/s from 270°: the air-frame cone's path plans 1.23 bps/Hz, the
    still-air path re-timed in the wind 1.6; searching both keeps the better and says so."""
    from dataclasses import replace

    from mission_planner.optimize import PlannerOptions
    from validator.autopilot.waypoint_radius import radius_params

    site = load_site(SAMPLE).with_limits(wind=Wind(6.0, 270.0, 1.5))
    opt = PlannerOptions(timing_params=radius_params(site, "ardupilot"), search_ahead=False)
    both = plan(site, options=opt)
    cone_only = plan(site, options=replace(opt, wind_paths=("air-frame",)))
    assert both.timing.wind_path == "still-air"
    assert cone_only.timing.wind_path == "air-frame"
    assert both.min_rate_bps_hz > 1.05 * cone_only.min_rate_bps_hz
    assert float(np.sum(both.delta_s)) == pytest.approx(site.period_s)  # within T


def test_in_wind_the_still_air_path_searches_from_the_start_that_fits_better(
    monkeypatch: pytest.MonkeyPatch
) -> None:
    """realistic.yaml at 6 m/s from 135°: the still-air family's first candidate from the 1/K
    shares start overruns T by less than the nearest-GN start's, so the search goes on from
    it, plans more than from the nearest start alone, and the report says which start."""
    import math

    from mission_planner.optimize import PlannerOptions, flyable
    from validator.autopilot.waypoint_radius import radius_params

    site = load_site(SAMPLE).with_limits(wind=Wind(6.0, 135.0, 1.5))
    opt = PlannerOptions(timing_params=radius_params(site, "ardupilot"), search_ahead=False)
    chosen = plan(site, options=opt)
    monkeypatch.setattr(flyable, "START_MARGIN", math.inf)  # the nearest start, as before
    nearest = plan(site, options=opt)
    assert chosen.timing is not None and nearest.timing is not None
    assert (chosen.timing.start_schedule, nearest.timing.start_schedule) == ("shares", "nearest")
    assert chosen.timing.as_dict()["start_schedule"] == "shares"
    assert chosen.min_rate_bps_hz > 1.01 * nearest.min_rate_bps_hz


def test_every_node_gets_in_the_replay_what_the_planner_gave_it_in_wind() -> None:
    """In wind most corners change speed, and a leg entered through one first runs at the
    speed of the leg before: the planner lays its slots where the model flies the legs, so
    the service it schedules is the service the replay delivers. (Laid by each leg's own
    S-curve, harbour in 8 m/s from 0° replayed GN3 at 0.938 and GN2 at 1.036 of the plan.)"""
    from mission_planner.flight_report import replay_mission
    from mission_planner.pipeline import plan_and_build

    site = load_site(HARBOUR).with_limits(wind=Wind(8.0, 0.0, 2.0))
    flight = replay_mission(plan_and_build(site))
    tp = flight.report.throughput
    assert tp is not None
    assert np.all(np.abs(tp.flown_bps_hz / tp.planned_bps_hz - 1.0) <= 0.02), \
        np.round(tp.flown_bps_hz / tp.planned_bps_hz, 3)


def test_an_unknown_family_of_wind_paths_is_refused() -> None:
    from mission_planner.optimize import PlannerOptions

    site = load_site(SAMPLE).with_limits(wind=Wind(6.0, 270.0, 1.5))
    with pytest.raises(InputError, match="wind_paths: expected some of air-frame, still-air"):
        plan(site, options=PlannerOptions(wind_paths=("cone",)))
