"""The fault injector's timing and the score of the flight after a fault, on made-up
telemetry (the real firmware flies them in test_fault_flights.py)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from tests.validator.builders import make_site, nav, plan_of, speed
from validator.errors import InputError
from validator.flight import DO_SET_HOME, resolve_flight
from validator.mavlink.faults import (
    FaultInjector,
    FaultReport,
    fault_findings,
    fault_lines,
    fault_settings,
    score_fault,
)
from validator.mavlink.telemetry import Telemetry
from validator.mavlink.wire import mavlink
from validator.plan_format import Cmd, Frame, MissionItem


class FakeLink:
    def __init__(self) -> None:
        self.listeners: list = []
        self.sent: dict[str, float] = {}
        self.commands: list[tuple[float, ...]] = []

    def command(self, *args: float) -> int:
        self.commands.append(args)
        return 0


def _recorder(rows, home_amsl_m=100.0):
    return SimpleNamespace(rows=rows, mission_mode=3, custom_mode=3, armed=True,
                           home_amsl_m=home_amsl_m)


def _row(t, x, y, alt=30.0, v=(0.0, 0.0, 0.0)):
    return (t, x, y, alt, *v)  # lat/lon stand in for x/y: to_local below is the identity


def _injector(kind="gcs-loss"):
    link = FakeLink()
    inj = FaultInjector(link, kind, (100.0, 0.0), lambda lat, lon: np.array([lat, lon]),
                        px4=True)
    return inj, link


def test_the_fault_fires_at_the_sample_closest_to_the_worst_point():
    inj, _ = _injector()
    rows = []
    rec = _recorder(rows)
    for i, x in enumerate([80.0, 92.0, 98.0, 101.0, 104.0]):
        rows.append(_row(float(i), x, 0.0, v=(0.0, 10.0, 0.0)))
        assert inj(rec) is None
        if x < 104.0:
            assert math.isnan(inj.injected_s)
    assert inj.injected_s == 4.0  # the sample after the closest (101 m), when it opens again
    assert inj.how == "our GCS heartbeats stopped"


def test_after_the_fault_a_landing_ends_the_flight_and_a_descent_is_not_a_hold():
    inj, _ = _injector()
    rows = [_row(0.0, 99.0, 0.0), _row(1.0, 103.0, 0.0)]
    rec = _recorder(rows)
    inj(_recorder(rows[:1]))
    assert inj(rec) is None and inj.injected_s == 1.0
    rec.custom_mode = 9  # LAND: descending in place at 0.5 m/s for a minute is no hold
    for t in range(2, 70):
        rows.append(_row(float(t), 103.0, 0.0, alt=30.0 - 0.4 * t, v=(0.0, 0.0, 0.5)))
        assert inj(rec) is None
    rec.armed = False
    rows.append(_row(70.0, 103.0, 0.0, alt=0.1))
    assert inj(rec) == "landed and disarmed after the fault"


def test_holding_still_outside_the_mission_is_a_safe_hold():
    inj, _ = _injector()
    rows = [_row(0.0, 99.0, 0.0), _row(1.0, 103.0, 0.0)]
    rec = _recorder(rows)
    inj(_recorder(rows[:1]))
    inj(rec)
    rec.custom_mode = 17  # Brake
    ends = []
    for t in range(2, 40):
        rows.append(_row(float(t), 103.0, 0.0))
        ends.append(inj(rec))
    assert ends[-1] == "holding still for 30 s after the fault" and ends[-10] is None


def test_holding_still_at_a_home_moved_up_to_it_is_a_safe_hold():
    """A DO_SET_HOME where the vehicle was, 30 m up, moves home there: a Brake at that height
    reads 0 m relative altitude, yet is 30 m above the ground it took off from."""
    inj, _ = _injector()
    rows = [_row(0.0, 99.0, 0.0), _row(1.0, 103.0, 0.0)]
    rec = _recorder(rows)
    inj(_recorder(rows[:1]))
    inj(rec)
    rec.home_amsl_m = 130.0  # the home moved up to the vehicle: relative altitude 0 from here
    rec.custom_mode = 17  # Brake
    ends = []
    for t in range(2, 40):
        rows.append(_row(float(t), 103.0, 0.0, alt=0.0))
        ends.append(inj(rec))
    assert ends[-1] == "holding still for 30 s after the fault"


def test_faults_the_simulator_cannot_make_are_refused():
    assert fault_settings("rc-loss", px4=False) == {"SIM_RC_FAIL": 1.0}
    with pytest.raises(InputError, match="rc-loss: not simulated on PX4 SIH"):
        fault_settings("rc-loss", px4=True)
    with pytest.raises(InputError, match="^fault solar-flare: not simulated on ArduCopter"):
        fault_settings("solar-flare", px4=False, field="fault")


def test_a_px4_gps_loss_takes_the_simulated_receivers_fix():
    assert fault_settings("gps-loss", px4=True) == {"SIM_GPS_USED": 0.0}


MAV = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)


def _hil_state(lat_e7: int, lon_e7: int):
    return MAV.hil_state_quaternion_encode(0, [1.0, 0.0, 0.0, 0.0], 0, 0, 0, lat_e7, lon_e7,
                                           30000, 0, 0, 0, 0, 0, 0, 0, 0)


def test_px4s_truth_is_its_simulators_position_on_the_vehicles_clock():
    # PX4 stops GLOBAL_POSITION_INT once its estimate has no position: the truth's time must
    # come from the messages that go on (ATTITUDE), not the last position report
    inj, link = _injector("gps-loss")
    asked = {int(c[1]) for c in link.commands if c[0] == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL}
    assert asked == {mavlink.MAVLINK_MSG_ID_HIL_STATE_QUATERNION,
                     mavlink.MAVLINK_MSG_ID_CURRENT_MODE, mavlink.MAVLINK_MSG_ID_HOME_POSITION}
    take = link.listeners[0]
    take(MAV.global_position_int_encode(1000, 0, 0, 0, 0, 0, 0, 0, 0))
    take(_hil_state(375600000, 1270000000))
    take(MAV.attitude_encode(2500, 0, 0, 0, 0, 0, 0))
    take(_hil_state(375600010, 1270000020))
    assert inj.truth == [pytest.approx((1.0, 37.56, 127.0)),
                         pytest.approx((2.5, 37.560001, 127.000002))]
    assert inj.truth_source == "simulator truth (HIL_STATE_QUATERNION)"


def _after(clearance_m: dict[str, float], end_state: str) -> FaultReport:
    return FaultReport("rc-loss", "SIM_RC_FAIL 1", "simulator truth (SIMSTATE)", 5.0, (0.0, 0.0),
                       (0.0, 0.0), clearance_m, end_state, (0.0, 0.0), 0.0, ("RTL",), ())


def test_a_zone_entered_after_the_fault_is_a_violation_of_the_flight():
    found = fault_findings(_after({"NFZ1": -1.5, "NFZ2": 4.0}, "landed"))
    assert [(f.severity, f.message) for f in found] == [
        ("violation", "after the rc-loss fault the vehicle entered NFZ1 1.50 m deep")]


def test_a_flight_that_neither_lands_nor_holds_after_the_fault_is_a_violation():
    assert fault_findings(_after({"NFZ1": 3.0}, "landed")) == ()
    assert fault_findings(_after({"NFZ1": 3.0}, "safe hold")) == ()
    found = fault_findings(_after({"NFZ1": 3.0}, "time limit reached"))
    assert [f.message for f in found] == ["after the rc-loss fault: time limit reached"]


def test_the_score_measures_the_track_after_the_fault_between_samples():
    site = make_site(nfz=((100.0, 0.0, 20.0),), gns=((0.0, 50.0), (200.0, 50.0)))
    inj, _ = _injector()
    inj.injected_s, inj.injected_xy_m, inj.how = 5.0, (0.0, 30.0), "test"
    # straight through y = 30 until t = 5, then a chord from (60, 30) to (140, 10): its
    # closest point to the zone's centre is between samples
    xy = np.array([[0.0, 30.0], [60.0, 30.0], [140.0, 10.0], [140.0, 10.0]])
    lat, lon = site.frame.to_geodetic(xy)
    n = len(xy)
    tel = Telemetry(t_s=np.array([0.0, 5.0, 10.0, 20.0]), lat_deg=lat, lon_deg=lon,
                    rel_alt_m=np.array([30.0, 30.0, 30.0, 0.0]), vel_mps=np.zeros((n, 3)),
                    mission_seq=np.zeros(n, dtype=np.int64), armed=np.array([1, 1, 1, 0], bool),
                    fence_breach=np.zeros(n, bool), mode_changes=[(6.0, "SMART_RTL")])
    flight = resolve_flight(plan_of(site, [nav(site, Cmd.NAV_TAKEOFF, (0.0, 0.0))]), site)
    rep = score_fault(inj, tel, site, flight, "landed and disarmed after the fault")
    d = np.array([80.0, -20.0])  # the chord's direction
    r = np.array([100.0, 0.0]) - xy[1]
    closest = abs(d[0] * r[1] - d[1] * r[0]) / np.linalg.norm(d)
    assert rep.clearance_m["NFZ1"] == pytest.approx(closest - 20.0, abs=0.05)
    assert rep.end_state == "landed" and rep.modes == ("SMART_RTL",)
    assert rep.end_xy_m == pytest.approx((140.0, 10.0), abs=0.01)


# --------------------------------------------------------------------------------------------
# "landed, N m from home": the home a return after the fault flies to (a DO_SET_HOME moves it)

A_XY, B_XY = (0.0, 60.0), (80.0, 60.0)


def _set_home_flight(site):
    """Takeoff, A, DO_SET_HOME where the vehicle is (A), B, RTL: its return lands at A."""
    items = [nav(site, Cmd.NAV_TAKEOFF, (0.0, 0.0)), speed(5.0), nav(site, Cmd.NAV_WAYPOINT, A_XY),
             MissionItem(DO_SET_HOME, [1.0, 0, 0, 0, 0, 0, 0], int(Frame.GLOBAL_RELATIVE_ALT)),
             nav(site, Cmd.NAV_WAYPOINT, B_XY),
             MissionItem(int(Cmd.NAV_RETURN_TO_LAUNCH), [0.0] * 7, int(Frame.MISSION))]
    return resolve_flight(plan_of(site, items), site)


def _after_set_home(site, landed_xy=A_XY):
    """ArduCopter telemetry: up to A, faulted halfway to B (item 5, ArduPilot's seq 5), landed at
    ``landed_xy``; and its injector (nothing heard from the vehicle about its home)."""
    xy = np.array([[0.0, 0.0], [0.0, 30.0], A_XY, [40.0, 60.0], [60.0, 60.0], landed_xy,
                   landed_xy])
    lat, lon = site.frame.to_geodetic(xy)
    n = len(xy)
    tel = Telemetry(t_s=np.arange(n) * 10.0, lat_deg=lat, lon_deg=lon,
                    rel_alt_m=np.array([0.0, 30, 30, 30, 30, 30, 0]), vel_mps=np.zeros((n, 3)),
                    mission_seq=np.array([1, 3, 5, 5, 5, 5, 5]), armed=np.arange(n) < n - 1,
                    fence_breach=np.zeros(n, bool), mode_changes=[(35.0, "SMART_RTL")],
                    takeoff_start_s=0.0, mission_start_s=0.0)
    inj = FaultInjector(FakeLink(), "rc-loss", (40.0, 60.0), site.frame.to_local, px4=False)
    inj.injected_s, inj.injected_xy_m, inj.how = 30.0, (40.0, 60.0), "SIM_RC_FAIL 1"
    return inj, tel


def test_a_landing_is_measured_from_the_home_in_force_when_the_fault_came():
    site = make_site(nfz=((300.0, 300.0, 10.0),))
    flight = _set_home_flight(site)
    inj, tel = _after_set_home(site)
    rep = score_fault(inj, tel, site, flight, "landed and disarmed after the fault")
    assert rep.end_from_home_m == pytest.approx(0.0, abs=0.01)
    assert rep.home == "home set by item 4"  # the DO_SET_HOME, index 3


def test_a_fault_before_the_do_set_home_is_measured_from_the_plans_home():
    site = make_site(nfz=((300.0, 300.0, 10.0),))
    inj, tel = _after_set_home(site, landed_xy=(0.0, 0.0))
    inj.injected_s = 10.0  # on the leg to A
    rep = score_fault(inj, tel, site, _set_home_flight(site), "landed and disarmed")
    assert rep.end_from_home_m == pytest.approx(0.0, abs=0.01) and rep.home == "home"


def test_the_home_the_vehicle_reports_is_the_one_a_landing_is_measured_from():
    """ArduCopter took its home where it cut A's corner: its HOME_POSITION, not the plan's
    waypoint, is where its return landed."""
    site = make_site(nfz=((300.0, 300.0, 10.0),))
    cut = (1.2, 58.9)
    inj, tel = _after_set_home(site, landed_xy=cut)
    lat, lon = site.frame.to_geodetic(np.array(cut))
    inj._take_truth(SimpleNamespace(get_type=lambda: "HOME_POSITION",
                                    latitude=round(float(lat) * 1e7),
                                    longitude=round(float(lon) * 1e7)))
    rep = score_fault(inj, tel, site, _set_home_flight(site), "landed and disarmed")
    assert rep.end_from_home_m == pytest.approx(0.0, abs=0.02)
    assert rep.home == "the home the vehicle reported"


def test_the_fault_line_says_which_home_the_landing_is_measured_from():
    site = make_site(nfz=((300.0, 300.0, 10.0),))
    inj, tel = _after_set_home(site, landed_xy=(3.0, 64.0))
    rep = score_fault(inj, tel, site, _set_home_flight(site), "landed and disarmed")
    assert "ended landed, 5.0 m from home set by item 4" in fault_lines(rep.as_dict())
