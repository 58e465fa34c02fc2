"""Faults injected into a real autopilot's SITL in flight, and the flight that follows, scored.

``validate-mission --sitl-binary ... --fault KIND`` flies the mission and, as the vehicle passes
the point whose straight return comes closest to a zone (the failsafe audit's
:attr:`~validator.failsafe.FailsafeReport.worst_return`: where an RTL would do the most harm;
a GPS loss, whose failsafe path is the coast, where the coast comes closest:
:func:`validator.position_loss.worst_position_loss_point`), injects the fault the way the
simulator offers it:

========== ======================================== =========================================
fault      ArduCopter 4.5.6 SITL                    PX4 v1.15 SIH
========== ======================================== =========================================
rc-loss    SIM_RC_FAIL 1 (no RC pulses)             not simulated (SIH flies without RC)
gcs-loss   our GCS heartbeats stop (FS_GCS_ENABLE   our heartbeats stop (NAV_DLL_ACT after
           after FS_GCS_TIMEOUT, put back to 5 s)   COM_DL_LOSS_T, 10 s)
battery-low SIM_BATT_VOLTAGE 10.3 V, under           SIM_BAT_MIN_PCT 2 with SIM_BAT_DRAIN 1 s
           BATT_LOW_VOLT 10.5 V (BATT_LOW_TIMER     (below BAT_CRIT_THR: COM_LOW_BAT_ACT)
           10 s)
gps-loss   SIM_GPS_DISABLE 1 (EKF failsafe,         SIM_GPS_USED 0: the simulated receiver
           FS_EKF_ACTION)                           reports no fix (EKF2 stops position
                                                    aiding; commander falls back to Descend)
========== ======================================== =========================================

The :class:`FaultInjector` watches every telemetry sample; after the injection it ends the
recording once the vehicle has landed and disarmed, or has held still (under
:data:`STILL_MPS`) outside the mission mode for :data:`HOLD_END_S` vehicle seconds (Brake,
Loiter, PX4's Hold: a safe hold, waiting for a pilot), both judged by the height above the
home it took off from (:meth:`FaultInjector.height_m`), not the relative altitude, which a
DO_SET_HOME moving home up to the vehicle turns to 0 in the air. :func:`score_fault`
measures the flight after the injection: its least clearance from every zone (exact between
samples), where it ended and how far from home, and what the autopilot said and did. "Home"
is the one the vehicle last reported (HOME_POSITION, which it sends as a mission's
DO_SET_HOME moves it): what its return flew to, wherever the vehicle really was when it took
it; without a report, the home in force on the leg it was flying when the fault came
(:meth:`Flight.home_of`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from validator.errors import InputError
from validator.flight import Finding, Home
from validator.geometry import segment_point_distance
from validator.mavlink.connection import Connection
from validator.mavlink.telemetry import Recorder, Telemetry, telemetry_track, vehicle_time_s
from validator.mavlink.wire import mavlink
from validator.site import Site
from validator.zones import polyline_clearance_m

if TYPE_CHECKING:
    from validator.failsafe import FailsafeReport
    from validator.flight import Flight
    from validator.mavlink.driver import Watch
    from validator.mavlink.link import Link
    from validator.plan_format import Plan
    from validator.replay import TrackReport
    from validator.validation import Validation

TRIGGER_RADIUS_M = 10.0  # the fault fires at the closest sample to the point within this
HOLD_END_S = 30.0  # vehicle seconds held still outside the mission: a safe hold
STILL_MPS = 0.3
LANDED_ALT_M = 1.0  # above the takeoff's home: lower is on the ground, or landing
SET_MESSAGE_INTERVAL = mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
SIMSTATE_ID = mavlink.MAVLINK_MSG_ID_SIMSTATE
HOME_POSITION_ID = mavlink.MAVLINK_MSG_ID_HOME_POSITION
HOME_EVERY_US = 1e6  # besides the one sent as it moves: a lost one is sent again
# PX4 SIH's own position: HIL_STATE_QUATERNION reads vehicle_global_position_groundtruth
HIL_STATE_ID = mavlink.MAVLINK_MSG_ID_HIL_STATE_QUATERNION
CURRENT_MODE_ID = mavlink.MAVLINK_MSG_ID_CURRENT_MODE
TRUTH_INTERVAL_US = 1e5  # the truth at 10 Hz, as often as the telemetry

# What each fault sets on the vehicle, and whether our GCS heartbeats stop. A sped-up ArduCopter
# flies with FS_GCS_TIMEOUT widened for our wall-clock heartbeats
# (validator.mavlink.sitl_process.sped_up_link_params): the loss puts back its 5 s default.
GCS_LOSS = "stop heartbeats"
_ARDUPILOT: dict[str, dict[str, float | str]] = {
    "rc-loss": {"SIM_RC_FAIL": 1.0},
    "gcs-loss": {"FS_GCS_TIMEOUT": 5.0, GCS_LOSS: "yes"},
    "battery-low": {"SIM_BATT_VOLTAGE": 10.3},
    "gps-loss": {"SIM_GPS_DISABLE": 1.0},
}
_PX4: dict[str, dict[str, float | str]] = {
    "gcs-loss": {GCS_LOSS: "yes"},
    "battery-low": {"SIM_BAT_DRAIN": 1.0, "SIM_BAT_MIN_PCT": 2.0},
    # SensorGpsSim reports fix_type 0 below 4 satellites: the receiver stays, its fix goes
    "gps-loss": {"SIM_GPS_USED": 0.0},
}


def fault_settings(kind: str, px4: bool, field: str = "--fault") -> dict[str, float | str]:
    """The parameters that inject ``kind`` (and :data:`GCS_LOSS`: stop our heartbeats);
    :class:`InputError` for a fault the autopilot's simulator cannot produce (``field``
    names the option)."""
    table = _PX4 if px4 else _ARDUPILOT
    if kind not in table:
        raise InputError(f"{field} {kind}: not simulated on {'PX4 SIH' if px4 else 'ArduCopter'}"
                         f" (choose from {', '.join(table)})")
    return table[kind]


@dataclass
class FaultInjector:
    """Injects ``kind`` when the vehicle passes ``target_xy_m`` (site metres; ``to_local``
    converts a sample's latitude and longitude), then says when the flight that follows ended.
    Call it with the recorder on every sample: it returns the end reason, or None."""

    link: Connection
    kind: str
    target_xy_m: tuple[float, float]
    to_local: Any  # Site.frame.to_local
    px4: bool
    injected_s: float = math.nan
    injected_xy_m: tuple[float, float] | None = None
    how: str = ""
    _best: float = math.inf
    _still_since: float = math.nan
    _seen: int = 0
    # the home (m above sea level) in force when the vehicle was first seen armed: the ground
    # it took off from, which a later DO_SET_HOME does not move
    _takeoff_home_amsl_m: float = math.nan
    truth: list[tuple[float, float, float]] = field(default_factory=list)  # t_s, lat, lon
    homes: list[tuple[float, float, float]] = field(default_factory=list)  # HOME_POSITION's
    _t_s: float = math.nan

    def __post_init__(self) -> None:
        # Both simulators report their own position (ArduPilot SIMSTATE, PX4 SIH
        # HIL_STATE_QUATERNION, off until asked for): after a GPS loss GLOBAL_POSITION_INT is
        # only the estimate, so the score reads the truth when it has it
        self.link.listeners.append(self._take_truth)
        self.link.command(SET_MESSAGE_INTERVAL, float(HIL_STATE_ID if self.px4 else SIMSTATE_ID),
                          TRUTH_INTERVAL_US)
        if self.px4:  # the failsafe's mode change as it happens, not on the next heartbeat
            self.link.command(SET_MESSAGE_INTERVAL, float(CURRENT_MODE_ID), TRUTH_INTERVAL_US)
        self.link.command(SET_MESSAGE_INTERVAL, float(HOME_POSITION_ID), HOME_EVERY_US)

    @property
    def truth_source(self) -> str:
        return "simulator truth (" + ("HIL_STATE_QUATERNION" if self.px4 else "SIMSTATE") + ")"

    def _take_truth(self, m: Any) -> None:
        kind = m.get_type()
        if kind == "HOME_POSITION":  # only the last is used: its time does not matter
            if m.latitude or m.longitude:  # 0, 0: no home yet
                self.homes.append((self._t_s, m.latitude * 1e-7, m.longitude * 1e-7))
            return
        clock_s = vehicle_time_s(m)  # the truth carries no time of its own
        if clock_s is not None:
            self._t_s = clock_s if not self._t_s >= clock_s else self._t_s  # later only
        elif not math.isfinite(self._t_s):
            return
        elif kind == "SIMSTATE" and (m.lat or m.lng):
            self.truth.append((self._t_s, m.lat * 1e-7, m.lng * 1e-7))
        elif kind == "HIL_STATE_QUATERNION" and (m.lat or m.lon):
            self.truth.append((self._t_s, m.lat * 1e-7, m.lon * 1e-7))

    def __call__(self, rec: Recorder) -> str | None:
        if not rec.rows or len(rec.rows) == self._seen:
            return None
        self._seen = len(rec.rows)
        t, lat, lon, _, vn, ve, vd = rec.rows[-1][:7]
        if rec.armed and math.isnan(self._takeoff_home_amsl_m):
            self._takeoff_home_amsl_m = rec.home_amsl_m
        height_m = self.height_m(rec)
        if math.isnan(self.injected_s):
            if rec.mission_mode is None or not rec.armed:
                return None
            xy = np.asarray(self.to_local(lat, lon), dtype=float)
            d = float(np.hypot(*(xy - np.asarray(self.target_xy_m))))
            if d < TRIGGER_RADIUS_M and d <= self._best:
                self._best = d  # still closing in
            elif self._best < TRIGGER_RADIUS_M:
                self._inject(rec, float(t), (float(xy[0]), float(xy[1])))
            return None
        if not rec.armed and height_m < LANDED_ALT_M:
            return "landed and disarmed after the fault"
        if rec.custom_mode == rec.mission_mode:
            self._still_since = math.nan
            return None
        if math.hypot(vn, ve, vd) < STILL_MPS and height_m >= LANDED_ALT_M:  # not a descent
            if math.isnan(self._still_since):
                self._still_since = float(t)
            elif t - self._still_since >= HOLD_END_S:
                return f"holding still for {HOLD_END_S:g} s after the fault"
        else:
            self._still_since = math.nan
        return None

    def height_m(self, rec: Recorder) -> float:
        """The last sample's height (m) above the home the vehicle took off from: its relative
        altitude, moved by as much as a DO_SET_HOME has moved its home since (the relative
        altitude alone when either home is not known)."""
        rel_alt_m = float(rec.rows[-1][3])
        moved_m = rec.home_amsl_m - self._takeoff_home_amsl_m
        return rel_alt_m + moved_m if math.isfinite(moved_m) else rel_alt_m

    def _inject(self, rec: Recorder, t_s: float, xy: tuple[float, float]) -> None:
        from validator.mavlink.param_protocol import set_params

        settings = fault_settings(self.kind, self.px4)
        self.injected_s, self.injected_xy_m = t_s, xy
        values = {k: float(v) for k, v in settings.items() if k != GCS_LOSS}
        if values:
            set_params(self.link, values)
        how = [f"{k} {v:g}" for k, v in values.items()]
        if GCS_LOSS in settings:
            # Connection sends its GCS heartbeat from recv(): silence it on this link only
            self.link._heartbeat_if_due = lambda: None  # type: ignore[method-assign]
            how.append("our GCS heartbeats stopped")
        self.how = ", ".join(how)


@dataclass(frozen=True)
class FaultReport:
    """The flight after a fault: when and where it was injected, the least clearance of the
    track from each zone after it (negative: inside), where and how it ended, the modes the
    autopilot chose and what it said."""

    kind: str
    how: str
    position_source: str  # "simulator truth (SIMSTATE)" (PX4: HIL_STATE_QUATERNION) or the estimate
    injected_s: float
    injected_xy_m: tuple[float, float] | None
    target_xy_m: tuple[float, float]
    clearance_m: dict[str, float]
    end_state: str
    end_xy_m: tuple[float, float]
    end_from_home_m: float
    modes: tuple[str, ...]
    messages: tuple[str, ...]
    coast: Coast | None = None
    track_xy_m: tuple[tuple[float, float], ...] = ()  # after the fault, a point a second
    home: str = "home"  # which home end_from_home_m is from (fault_home)
    home_xy_m: tuple[float, float] | None = None

    @property
    def entered_zone(self) -> bool:
        return any(c < 0 for c in self.clearance_m.values())

    def as_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "how": self.how, "position_source": self.position_source,
                "injected_s": self.injected_s,
                "injected_xy_m": None if self.injected_xy_m is None else
                list(self.injected_xy_m), "target_xy_m": list(self.target_xy_m),
                "clearance_m": dict(self.clearance_m), "entered_zone": self.entered_zone,
                "end_state": self.end_state, "end_xy_m": list(self.end_xy_m),
                "end_from_home_m": self.end_from_home_m, "home": self.home,
                "home_xy_m": None if self.home_xy_m is None else list(self.home_xy_m),
                "modes": list(self.modes),
                "messages": list(self.messages),
                "coast": None if self.coast is None else dataclasses.asdict(self.coast),
                "track_xy_m": [list(p) for p in self.track_xy_m]}


@dataclass(frozen=True)
class Coast:
    """How far the true track went after the autopilot's own failsafe took over (its first
    mode change after the fault): the measurement behind the position-loss model
    (:mod:`validator.position_loss`). ``delay_s`` from the fault to that mode change;
    ``speed_mps`` the true ground speed then; ``along_m`` / ``across_m`` where the track ended
    along and across that velocity; ``duration_s`` until it ended."""

    mode: str
    delay_s: float
    speed_mps: float
    along_m: float
    across_m: float
    duration_s: float


def measure_coast(t: NDArray[np.float64], xy: NDArray[np.float64], t_fault_s: float,
                  mode_changes: Sequence[tuple[float, str]]) -> Coast | None:
    """The :class:`Coast` of a true track (``t`` (S,), ``xy`` (S, 2) site metres) after the
    first mode change at or after ``t_fault_s``; None without one, or without a track there."""
    change = next(((tc, m) for tc, m in mode_changes if tc >= t_fault_s), None)
    if change is None or len(t) < 3:
        return None
    tc, mode = change
    i = int(np.searchsorted(t, tc))
    if i <= 0 or i >= len(t) - 1:
        return None
    v = (xy[i] - xy[i - 1]) / max(float(t[i] - t[i - 1]), 1e-6)
    speed = float(np.hypot(*v))
    u = v / speed if speed > 1e-6 else np.array([1.0, 0.0])
    d = xy[-1] - xy[i]
    return Coast(mode, float(tc - t_fault_s), speed, float(d @ u),
                 float(u[0] * d[1] - u[1] * d[0]), float(t[-1] - tc))


def _every_second(t: NDArray[np.float64], xy: NDArray[np.float64]
                  ) -> tuple[tuple[float, float], ...]:
    """The track thinned to a point a second (and its last), rounded to 0.1 m."""
    keep = np.flatnonzero(np.diff(np.floor(t), prepend=-np.inf) > 0)
    keep = np.union1d(keep, [len(t) - 1])
    return tuple((round(float(x), 1), round(float(y), 1)) for x, y in xy[keep])


def _track_clearances(site: Site, xy: np.ndarray) -> dict[str, float]:
    """The least clearance of the polyline through ``xy`` (S, 2) from each zone."""
    if len(xy) == 1:
        xy = np.vstack([xy, xy])
    out = {}
    for name, c, r in zip(site.nfz_names, site.nfz_xy_m, site.nfz_radius_m, strict=True):
        out[name] = float(np.min(segment_point_distance(xy[:-1], xy[1:], c)) - r)
    for z in site.polygon_zones:
        out[z.name] = polyline_clearance_m(z, xy)[0]
    return out


def fault_home(injector: FaultInjector, telemetry: Telemetry, site: Site, flight: Flight
               ) -> tuple[NDArray[np.float64], str]:
    """The home a return after ``injector``'s fault flies to (site metres) and its name: the
    one the vehicle last reported, else the one in force on the leg of ``flight`` it was
    flying at the fault (the plan's, before the fault or without one)."""
    if injector.homes:
        _, lat, lon = injector.homes[-1]
        return (np.asarray(site.frame.to_local(lat, lon), dtype=float).reshape(2),
                "the home the vehicle reported")
    home = Home(flight.home_xy_m)
    if math.isfinite(injector.injected_s) and telemetry.samples >= 2:
        track = telemetry_track(telemetry, flight, site, ardupilot=not injector.px4,
                                source="fault")
        at = int(np.searchsorted(track.t_s, injector.injected_s - telemetry.flight_start_s,
                                 side="right")) - 1
        if 0 <= at < track.leg.size and track.leg[at] >= 0:
            home = flight.home_of(int(track.leg[at]))
    return home.xy_m, home.label


def score_fault(injector: FaultInjector, telemetry: Telemetry, site: Site, flight: Flight,
                end_reason: str) -> FaultReport:
    """Score the flight after ``injector``'s fault (see the module doc) of ``flight``."""
    home_xy_m, home = fault_home(injector, telemetry, site, flight)
    t0 = injector.injected_s
    if len(injector.truth) > 1:
        t, lat, lon = (np.asarray(c, dtype=float) for c in zip(*injector.truth, strict=True))
        source = injector.truth_source
    else:
        t, lat, lon = telemetry.t_s, telemetry.lat_deg, telemetry.lon_deg
        source = "the autopilot's estimate (GLOBAL_POSITION_INT)"
    after = t >= t0 if math.isfinite(t0) else np.zeros(t.size, bool)
    xy = np.asarray(site.frame.to_local(lat, lon), dtype=float).reshape(-1, 2)
    end = xy[-1] if len(xy) else home_xy_m
    clearance = _track_clearances(site, xy[after]) if np.any(after) else {}
    if not math.isfinite(t0):
        state = f"fault never injected ({end_reason})"
    elif "landed" in end_reason:
        state = "landed"
    elif "holding" in end_reason:
        state = "safe hold"
    else:
        state = end_reason
    modes = tuple(m for t, m in telemetry.mode_changes if math.isfinite(t0) and t >= t0)
    said = tuple(m for t, m in telemetry.messages if math.isfinite(t0) and t >= t0)
    coast = measure_coast(t, xy, t0, telemetry.mode_changes) if math.isfinite(t0) else None
    track = _every_second(t[after], xy[after]) if np.any(after) else ()
    return FaultReport(injector.kind, injector.how, source, t0, injector.injected_xy_m,
                       injector.target_xy_m, clearance, state,
                       (float(end[0]), float(end[1])), float(np.hypot(*(end - home_xy_m))),
                       modes, said[:20], coast, track, home,
                       (float(home_xy_m[0]), float(home_xy_m[1])))


def fault_watch(kind: str, plan: Plan, site: Site, flight: Flight,
                vehicle_params: Mapping[str, float] | None, made: list[FaultInjector], *,
                autopilot: bool, failsafe: FailsafeReport | None = None,
                field: str = "--fault", site_source: str | None = None
                ) -> Callable[[Link], Watch]:
    """The fault injector for ``fly_and_score``, aimed at the point of ``plan`` (resolved as
    ``flight``) whose straight return (a GPS loss: whose coast) comes closest to a
    zone of ``site`` under ``vehicle_params`` (``failsafe``: their audit, if made already);
    appended to ``made`` once the link is open. ``autopilot`` says the flight is on an
    autopilot SITL (the built-in vehicle has no failsafes); ``field`` names the option and
    ``site_source`` the site file in the refusals."""
    if not autopilot:
        raise InputError(f"{field}: needs an autopilot SITL (--sitl-binary, $ARDUPILOT_SITL or "
                         "--connect): the built-in vehicle has no failsafes")
    from validator.failsafe import audit_failsafes

    px4 = plan.firmware_type == 12  # MAV_AUTOPILOT_PX4
    fault_settings(kind, px4, field)  # refuse a fault the simulator cannot produce before flying
    fs = failsafe or audit_failsafes(plan, site, flight, vehicle_params or {})
    worst = fs.worst_return
    if worst is None:
        where = site_source or f"site {site.name!r}"
        raise InputError(f"{field}: {where} has no zone: no worst point to inject at")
    target = worst.xy_m
    if kind == "gps-loss":  # its failsafe path is the coast, not a return
        from validator.position_loss import worst_position_loss_point

        coast = worst_position_loss_point(flight, site, vehicle_params,
                                          autopilot="px4" if px4 else "ardupilot")
        if coast is not None:
            target = (float(coast[0][0]), float(coast[0][1]))

    def make(link: Link) -> Watch:
        made.append(FaultInjector(link, kind, target, site.frame.to_local, px4))
        return made[-1]

    return make


def fault_lines(fault: Mapping[str, Any]) -> list[str]:
    """A fault flight's report (:meth:`FaultReport.as_dict`) in words, a line each: what was
    injected and when, what the autopilot flew, how it ended, the zone it came closest to (or
    entered)."""
    said = [f"{fault['kind']} injected ({fault['how']}) at t = {fault['injected_s']:.1f} s",
            f"then flew {', '.join(fault['modes']) or 'the mission on'}",
            f"ended {fault['end_state']}, {fault['end_from_home_m']:.1f} m from "
            f"{fault.get('home', 'home')}"]
    clear = fault["clearance_m"]
    if clear:
        zone = min(clear, key=clear.get)
        said.append(f"entered {zone} {-clear[zone]:.2f} m deep" if clear[zone] < 0
                    else f"closest to a zone: {zone}, {clear[zone]:.2f} m")
    return said


def fault_findings(rep: FaultReport) -> tuple[Finding, ...]:
    """The violations of the flight after a fault: a zone entered, or an end neither landed
    nor holding."""
    found = [Finding("violation", f"after the {rep.kind} fault the vehicle entered {zone} "
                                  f"{-c:.2f} m deep", None)
             for zone, c in rep.clearance_m.items() if c < 0]
    if rep.end_state not in ("landed", "safe hold"):
        found.append(Finding("violation", f"after the {rep.kind} fault: {rep.end_state}", None))
    return tuple(found)


def with_fault(report: TrackReport, rep: FaultReport) -> TrackReport:
    """``report`` (the flight's) with the violations of the flight after the fault."""
    found = fault_findings(rep)
    return dataclasses.replace(report, findings=(*report.findings, *found)) if found else report


def record_fault(v: Validation, injector: FaultInjector, telemetry: Telemetry) -> None:
    """The fault flight's score into the report: ``extra["fault"]``, and its violations
    (:func:`fault_findings`) into the flight's."""
    rep = score_fault(injector, telemetry, v.site, v.flight, telemetry.end_reason)
    v.extra["fault"] = rep.as_dict()
    if v.sitl is not None:
        v.sitl = with_fault(v.sitl, rep)
