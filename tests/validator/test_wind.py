"""Wind geometry (validator.wind), the site's wind: and the flight models in wind."""

from __future__ import annotations

import math

import numpy as np
import pytest

from validator.errors import InputError
from validator.flight import Flight, Leg
from validator.motion.arducopter_speed import (
    PLAN_YAW_BEHAVIOR,
    arducopter_top_speed_mps,
    faces_course,
    held_top_speed_mps,
    lean_caps_mps,
    leg_speed_caps_mps,
    leg_speeds_mps,
    yaw_findings,
)
from validator.motion.limits import site_limits
from validator.motion.profile import make_profile, profile_wind
from validator.motion.px4_mission import px4_rest_to_rest, px4_top_speed_mps
from validator.plan_format import Autopilot
from validator.replay import replay
from validator.site import load_site, parse_site, site_to_dict
from validator.wind import (
    GUST_KEEP,
    Wind,
    check_flyable,
    course_speeds_mps,
    ground_speed_mps,
    heading_deg,
    held_air_speed_mps,
    lean_limit_ground_speed_mps,
    parse_wind_arg,
    wind_vector_mps,
)

SAMPLE = "samples/realistic.yaml"


def _unit(course_deg: float) -> np.ndarray:
    b = math.radians(course_deg)
    return np.array([[math.sin(b), math.cos(b)]])


def test_wind_vector_points_where_the_air_goes() -> None:
    # From the west (270°) the air moves east; from the north (0°) it moves south.
    assert wind_vector_mps(5.0, 270.0) == pytest.approx([5.0, 0.0], abs=1e-12)
    assert wind_vector_mps(5.0, 0.0) == pytest.approx([0.0, -5.0], abs=1e-12)
    assert wind_vector_mps(4.0, 135.0) == pytest.approx(
        [-4.0 / math.sqrt(2), 4.0 / math.sqrt(2)], abs=1e-12)


@pytest.mark.parametrize("course", [0.0, 37.0, 90.0, 181.0, 270.0, 333.0])
@pytest.mark.parametrize("wind", [(0.0, 0.0), (3.0, 270.0), (7.0, 45.0), (9.5, 200.0)])
def test_ground_speed_keeps_the_air_speed(course: float, wind: tuple[float, float]) -> None:
    v_air = 10.0
    w = wind_vector_mps(*wind)
    u = _unit(course)
    g = float(ground_speed_mps(v_air, w, u)[0])
    assert g > 0
    # |g u - w| = V: the vehicle flies at exactly its air-speed limit
    assert float(np.linalg.norm(g * u[0] - w)) == pytest.approx(v_air, rel=1e-12)


def test_head_tail_and_cross_wind() -> None:
    w = wind_vector_mps(4.0, 270.0)  # blows east
    east, west, north = _unit(90.0), _unit(270.0), _unit(0.0)
    assert ground_speed_mps(10.0, w, east)[0] == pytest.approx(14.0)  # tailwind
    assert ground_speed_mps(10.0, w, west)[0] == pytest.approx(6.0)  # headwind
    assert ground_speed_mps(10.0, w, north)[0] == pytest.approx(math.sqrt(100 - 16))
    assert heading_deg(np.array([[1.0, 0.0], [0.0, -1.0]])) == pytest.approx([90.0, 180.0])


def test_no_ground_speed_against_a_wind_above_the_air_speed() -> None:
    w = wind_vector_mps(12.0, 270.0)
    assert np.isnan(ground_speed_mps(10.0, w, _unit(270.0))[0])  # upwind: none
    assert ground_speed_mps(10.0, w, _unit(90.0))[0] == pytest.approx(22.0)
    with pytest.raises(InputError, match=r"leg A \(course 270°\) cannot be flown: 12 m/s "
                                         r"from 270° is at or above .* 10\.00 m/s"):
        check_flyable(10.0, Wind(12.0, 270.0), "wind", np.vstack([_unit(90), _unit(270)]),
                      ["leg B", "leg A"])
    check_flyable(10.0, Wind(9.99, 270.0), "wind")  # below the air speed: flyable


@pytest.mark.parametrize("text,expect", [
    ("7@300", (7.0, 300.0, 0.0)), ("6@135,1.5", (6.0, 135.0, 1.5)), (" 0 ", (0.0, 0.0, 0.0)),
    ("8@360", (8.0, 0.0, 0.0)),
])
def test_parse_wind_arg(text: str, expect: tuple[float, float, float]) -> None:
    w = parse_wind_arg(text)
    assert (w.speed_mps, w.from_deg, w.turbulence_mps) == expect


@pytest.mark.parametrize("text", ["7", "7@", "@300", "7@400", "-1@30", "7@30,x", "nan@3",
                                  "500@3"])
def test_parse_wind_arg_refuses(text: str) -> None:
    with pytest.raises(InputError, match=r"^--wind "):
        parse_wind_arg(text)


def test_site_wind_with_layers_round_trips() -> None:
    d = site_to_dict(load_site(SAMPLE))
    d["wind"] = {"speed_mps": 4.0, "from_deg": 90.0, "turbulence_mps": 1.0,
                 "layers": [{"above_m": 50.0, "speed_mps": 8.0, "from_deg": 100.0},
                            {"above_m": 20.0, "speed_mps": 6.0, "from_deg": 95.0}]}
    site = parse_site(d)
    assert site.wind is not None and site.flight_wind is not None
    # 30 m above ground: the 20 m layer
    assert (site.flight_wind.speed_mps, site.flight_wind.from_deg) == (6.0, 95.0)
    assert site.wind.at(60.0).speed_mps == 8.0 and site.wind.at(10.0).speed_mps == 4.0
    assert parse_site(site_to_dict(site)).wind == site.wind
    lim = site_limits(site)
    assert (lim.wind_speed_mps, lim.wind_from_deg) == (6.0, 95.0)


def test_a_layered_wind_is_labelled_layer_by_layer() -> None:
    d = site_to_dict(load_site(SAMPLE))
    d["wind"] = {"speed_mps": 2.0, "from_deg": 270.0,
                 "layers": [{"above_m": 20.0, "speed_mps": 6.0, "from_deg": 275.0,
                             "turbulence_mps": 1.0}]}
    site = parse_site(d)
    assert site.wind is not None and site.flight_wind is not None
    assert site.wind.label() == ("2 m/s from 270° at the ground, 6 m/s from 275°, turbulence "
                                 "1 m/s from 20 m")
    assert site.flight_wind.label() == "6 m/s from 275°, turbulence 1 m/s"


@pytest.mark.parametrize("wind,msg", [
    ({"speed_mps": 4.0, "from_deg": 90.0, "gust": 3.0}, "wind.gust: unknown key"),
    ({"speed_mps": 4.0}, "wind.from_deg: missing field"),
    ({"speed_mps": -1.0, "from_deg": 90.0}, "wind.speed_mps"),
    ({"speed_mps": 4.0, "from_deg": 400.0}, "wind.from_deg"),
    ({"speed_mps": 2.0, "from_deg": 270.0,
      "layers": [{"above_m": 20.0, "speed_mps": 6.0, "from_deg": 270.0},
                 {"above_m": 20.0, "speed_mps": 8.0, "from_deg": 270.0}]},
     r"wind.layers: .*layers\[1\].above_m 20 m is layer 0's height too"),
])
def test_site_wind_refuses_mistakes(wind: dict[str, float], msg: str) -> None:
    d = site_to_dict(load_site(SAMPLE))
    d["wind"] = wind
    with pytest.raises(InputError, match=msg):
        parse_site(d, "site.yaml")


def _legs(course_deg: float, length_m: float = 200.0) -> Flight:
    u = _unit(course_deg)[0]
    legs = (Leg(item=1, first_item=1, kind="waypoint", start_xy_m=np.zeros(2),
                end_xy_m=u * length_m, start_alt_m=30.0, end_alt_m=30.0, speed_mps=10.0,
                hold_s=1.0),)
    return Flight(legs=legs, home_xy_m=np.zeros(2), firmware_type=int(Autopilot.ARDUPILOTMEGA),
                  findings=(), cycle=None, service=None)


def test_arducopter_caps_each_leg_at_its_ground_speed() -> None:
    site = load_site(SAMPLE)
    still = make_profile("arducopter", site_limits(site))
    windy = make_profile("arducopter", site_limits(site), {"WIND_SPEED": 5.0, "WIND_FROM": 270.0})
    assert profile_wind(still) is None and profile_wind(windy) == Wind(5.0, 270.0)
    top = arducopter_top_speed_mps(windy)
    units = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    caps = leg_speed_caps_mps(windy, units)
    assert caps[0] == pytest.approx(top + 5.0) and caps[1] == pytest.approx(top - 5.0)
    assert caps[2] == top  # a climb: the horizontal cap does not bind
    assert np.all(leg_speed_caps_mps(still, units) == arducopter_top_speed_mps(still))
    # Flown upwind the leg takes longer than in still air, downwind (commanded 10) no less.
    t_still = replay(_legs(270.0), still).leg_done_s[-1]
    t_up = replay(_legs(270.0), windy).leg_done_s[-1]
    t_down = replay(_legs(90.0), windy).leg_done_s[-1]
    assert t_up > t_still + 5.0
    assert t_down == pytest.approx(replay(_legs(90.0), still).leg_done_s[-1])


def test_arducopter_refuses_a_wind_beyond_its_top_speed() -> None:
    site = load_site(SAMPLE)
    prof = make_profile("arducopter", site_limits(site), {"WIND_SPEED": 12.0, "WIND_FROM": 90.0})
    with pytest.raises(InputError, match=r"mission item 2 \(course 90°\) cannot be flown"):
        replay(_legs(90.0), prof)


def test_gusts_take_from_the_airspeed_held() -> None:
    assert held_air_speed_mps(10.0, 0.0) == 10.0
    assert held_air_speed_mps(10.08, 2.0) == pytest.approx(math.sqrt(10.08**2 - GUST_KEEP * 4))
    assert held_air_speed_mps(10.0, 1.0) > held_air_speed_mps(10.0, 2.0) > 9.5
    assert held_air_speed_mps(1.0, 5.0) == 0.0  # gusts beyond the vehicle leave nothing


def test_arducopter_plans_command_what_it_holds_through_the_gusts() -> None:
    """Commanded at its lean limit straight into 7 m/s with turbulence 2 m/s, ArduCopter SITL
    flew 9.79-9.88 m/s of air: a plan commands the held airspeed, and the replay's cap, what
    the vehicle flies leaning at its limit, is no less on any course, so the replay flies the
    plan's legs as commanded."""
    site = load_site(SAMPLE)
    gusty = make_profile("arducopter", site_limits(site),
                         {"WIND_SPEED": 7.0, "WIND_FROM": 270.0, "WIND_TURB": 2.0})
    steady = make_profile("arducopter", site_limits(site),
                          {"WIND_SPEED": 7.0, "WIND_FROM": 270.0})
    assert profile_wind(gusty) == Wind(7.0, 270.0, 2.0)
    held = held_top_speed_mps(gusty)
    assert held < arducopter_top_speed_mps(gusty) - 0.2
    assert held_top_speed_mps(steady) == arducopter_top_speed_mps(steady)
    courses = np.array([[-1.0, 0.0], [0.0, 1.0], [1.0, 0.0]])  # upwind, across, downwind
    commanded = leg_speeds_mps(gusty, 10.0, courses)
    air = Wind(7.0, 270.0).vector_mps
    assert commanded == pytest.approx(np.minimum(10.0, ground_speed_mps(held, air, courses)))
    replay_caps = lean_caps_mps(gusty, np.column_stack([courses, np.zeros(3)]), held)
    assert commanded[0] == pytest.approx(replay_caps[0])  # into the wind: the same cone
    assert commanded[1] < replay_caps[1] - 0.5 and commanded[2] == 10.0
    assert np.all(leg_speeds_mps(steady, 10.0, courses)[:2] > commanded[:2])


def test_the_lean_limit_flies_more_across_a_wind_than_a_plan_commands() -> None:
    # SITL's quad crabbing across 7 m/s: its body drag is per axis, so it holds more air speed
    # along the course than one whose drag is the same every way
    site = load_site(SAMPLE)
    windy = make_profile("arducopter", site_limits(site), {"WIND_SPEED": 7.0, "WIND_FROM": 0.0})
    top = arducopter_top_speed_mps(windy)
    units = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]])
    caps = lean_caps_mps(windy, units, top)
    planned = leg_speed_caps_mps(windy, units, top_mps=top)
    assert caps[0] > planned[0] + 1.0  # across the wind
    assert caps[1] == pytest.approx(planned[1]) == pytest.approx(top + 7.0)  # downwind
    assert caps[2] == top  # a climb: the horizontal cap does not bind


def test_a_lean_limit_beyond_the_wind_is_refused_naming_the_leg() -> None:
    site = load_site(SAMPLE)
    prof = make_profile("arducopter", site_limits(site), {"WIND_SPEED": 12.0, "WIND_FROM": 0.0})
    with pytest.raises(InputError, match=r"leg A \(course 0°\) cannot be flown"):
        lean_caps_mps(prof, np.array([[0.0, 1.0, 0.0]]), 10.0, ["leg A"])


@pytest.mark.parametrize("yaw", [1.0, 2.0, 3.0])
def test_a_vehicle_turning_toward_its_waypoints_faces_its_course(yaw: float) -> None:
    prof = make_profile("arducopter", site_limits(load_site(SAMPLE)), {"WP_YAW_BEHAVIOR": yaw})
    assert faces_course(prof)


def test_arducopter_faces_its_course_by_default_as_the_plan_sets_it() -> None:
    prof = make_profile("arducopter", site_limits(load_site(SAMPLE)))
    assert prof.params["WP_YAW_BEHAVIOR"] == PLAN_YAW_BEHAVIOR and faces_course(prof)


def test_a_kept_yaw_in_wind_is_warned_of() -> None:
    # the drag per body axis is a vehicle facing along its course: at 0 it is not
    prof = make_profile("arducopter", site_limits(load_site(SAMPLE)),
                        {"WP_YAW_BEHAVIOR": 0, "WIND_SPEED": 6.0, "WIND_FROM": 90.0})
    (finding,) = yaw_findings(prof)
    assert finding.severity == "warning" and "WP_YAW_BEHAVIOR 0 does not turn" in finding.message


def test_a_kept_yaw_in_still_air_is_not_warned_of() -> None:
    prof = make_profile("arducopter", site_limits(load_site(SAMPLE)), {"WP_YAW_BEHAVIOR": 0})
    assert yaw_findings(prof) == []


def test_a_leg_with_no_course_keeps_the_airspeed() -> None:
    # a climb has no course over the ground for the wind to take from
    speeds = course_speeds_mps(10.0, Wind(6.0, 90.0), [[0.0, 0.0, 5.0], [20.0, 0.0, 0.0]])
    assert speeds == pytest.approx([10.0, 4.0])  # east, into a wind from the east: 10 − 6


def test_a_course_refusal_names_the_first_horizontal_leg_it_cannot_fly() -> None:
    with pytest.raises(InputError, match=r"item 3 \(course 0°\) cannot be flown"):
        course_speeds_mps(8.0, Wind(9.0, 0.0), [[0.0, 0.0], [0.0, 30.0]], ["item 2", "item 3"])


# a course along the x axis; (east, north) wind vectors of 6 m/s across it or along it
ACROSS = np.array([0.0, 6.0])
ALONG = np.array([-6.0, 0.0])
EAST = np.array([[1.0, 0.0]])


def test_drag_the_same_every_way_leaves_the_cone_s_ground_speed() -> None:
    for wind in (ACROSS, ALONG, np.array([3.0, -4.0])):
        assert lean_limit_ground_speed_mps(10.0, wind, EAST, 1.0) == pytest.approx(
            ground_speed_mps(10.0, wind, EAST))


def test_body_drag_per_axis_alone_balances_each_axis_on_its_own() -> None:
    # (a/V)^4 + (c/V)^4 = 1: across 6 m/s of wind, a = (10^4 - 6^4)^(1/4)
    assert lean_limit_ground_speed_mps(10.0, ACROSS, EAST, 0.0) == pytest.approx(
        (10.0**4 - 6.0**4) ** 0.25)


def test_along_the_wind_the_drag_s_shape_does_not_matter() -> None:
    for share in (0.0, 0.47, 1.0):
        assert lean_limit_ground_speed_mps(10.0, ALONG, EAST, share) == pytest.approx(4.0)


def test_across_a_wind_the_less_linear_the_drag_the_more_ground_speed() -> None:
    speeds = [float(lean_limit_ground_speed_mps(10.0, ACROSS, EAST, s)[0])
              for s in (1.0, 0.47, 0.0)]
    assert speeds[0] == pytest.approx(8.0) and speeds[0] < speeds[1] < speeds[2]


def test_a_crosswind_at_the_airspeed_leaves_no_ground_speed() -> None:
    assert np.isnan(lean_limit_ground_speed_mps(10.0, np.array([0.0, 10.0]), EAST, 0.47)[0])


def test_into_a_wind_beyond_the_airspeed_there_is_no_ground_speed() -> None:
    assert np.isnan(lean_limit_ground_speed_mps(10.0, np.array([-11.0, 0.0]), EAST, 0.47)[0])


def test_a_linear_share_outside_0_to_1_is_refused() -> None:
    with pytest.raises(ValueError, match="linear_share"):
        lean_limit_ground_speed_mps(10.0, ACROSS, EAST, 1.5)


def test_px4_flies_slower_upwind_through_its_drag() -> None:
    site = load_site(SAMPLE)
    still = make_profile("px4", site_limits(site))
    windy = make_profile("px4", site_limits(site), {"WIND_SPEED": 4.0, "WIND_FROM": 90.0})
    top = px4_top_speed_mps(windy)
    lengths = np.array([300.0, 300.0, 300.0])
    units = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0]])  # upwind, downwind, across
    legs = px4_rest_to_rest(windy, lengths, top, units)
    calm = px4_rest_to_rest(still, lengths, top, units)
    assert legs.total_s[0] > calm.total_s[0] * 1.2  # against 4 m/s of its ~9.8
    assert legs.total_s[2] > calm.total_s[2]  # a crosswind eats tilt too
    # Upwind cruise close to the ground speed the wind leaves (V - w)
    t, s = legs.t_s[0], legs.s_m[0]
    cruise = float(np.max(np.gradient(s, t)))
    assert cruise == pytest.approx(top - 4.0, rel=0.03)
