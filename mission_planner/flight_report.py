"""What the nodes really get: a mission replayed as its autopilot flies it, before take-off.

:func:`replay_mission` flies an exported mission with the validator's flight model
(:func:`validator.replay.replay`: the ``arducopter`` profile for ArduPilot plans, ``px4`` for
PX4) set to the recommended parameters (:mod:`.autopilot_params`), and scores the track with
:func:`validator.replay.score_track`, the same scorer that judges SITL and real telemetry.
:class:`FlightCheck` holds the result; :meth:`FlightCheck.as_dict` is the report's ``"flight"``
section and :meth:`FlightCheck.warning` the one-line warning when the flown cycle is more than
10 % longer (or shorter) than T.

Rates are spectral efficiencies (bps/Hz): planned = the paper's model over T on the exported
trajectory (slot n served from its end point q[n]); replayed = integrated along the modelled
track over the flown cycle (per flown second). Part of their gap is the paper model's own
discretisation (a slot scored at its end point), the rest what the flight costs. Times in
seconds, clearances in metres from each NFZ's published radius (negative = inside).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from mission_planner.autopilot_params import AutopilotParams, recommended_params
from mission_planner.mission import Mission
from validator.flight import Flight, resolve_flight
from validator.motion.fly import REPLAY_STEP_S
from validator.motion.limits import site_limits
from validator.motion.profile import Profile, flown_params, make_profile
from validator.plan_format import Autopilot
from validator.replay import Track, TrackReport, replay, score_replay

CYCLE_OVERRUN_WARN = 0.10  # warn when the flown cycle is off T by more than this fraction


@dataclass(frozen=True)
class FlightCheck:
    """A mission's replay: the profile and parameters flown, and the validator's report."""

    profile: Profile
    params: dict[str, float]
    period_s: float
    report: TrackReport
    flight: Flight | None = None  # the mission as the validator resolves it, and its track:
    track: Track | None = None  # what a view draws

    @property
    def planned_min_rate_bps_hz(self) -> float | None:
        tp = self.report.throughput
        return tp.planned_min if tp is not None else None

    @property
    def replayed_min_rate_bps_hz(self) -> float | None:
        tp = self.report.throughput
        return tp.flown_min if tp is not None else None

    @property
    def replayed_cycle_s(self) -> float | None:
        c = self.report.cycle
        return c.flown_cycle_s if c is not None else None

    @property
    def cycle_ratio(self) -> float | None:
        """Replayed cycle / T (1.0 = flown exactly as planned)."""
        flown = self.replayed_cycle_s
        return flown / self.period_s if flown is not None and self.period_s > 0 else None

    @property
    def min_rate_ratio(self) -> float | None:
        """Replayed min rate / planned min rate."""
        planned, flown = self.planned_min_rate_bps_hz, self.replayed_min_rate_bps_hz
        return flown / planned if planned and flown is not None else None

    @property
    def problems(self) -> tuple[str, ...]:
        """Why the flown mission must not be written, one line each: every violation the
        replay finds (a zone or fence entered, a flight longer than the UAV's endurance)."""
        return tuple(f.message for f in self.report.violations)

    @property
    def clearance_by_nfz_m(self) -> dict[str, float]:
        return {p.name: p.clearance_m for p in self.report.nfz}

    def warning(self, tolerance: float = CYCLE_OVERRUN_WARN) -> str | None:
        """One line when the replayed cycle is off T by more than ``tolerance`` (a fraction):
        longer, so nodes wait, or shorter, so the plan's timing is not kept either."""
        ratio = self.cycle_ratio
        if ratio is None:
            return (f"the {self.profile.name} replay did not complete a service cycle: the "
                    "flown timing is unknown")
        if abs(ratio - 1.0) <= tolerance:
            return None
        rate = ""
        if self.min_rate_ratio is not None:
            rate = (f"; min rate {self.replayed_min_rate_bps_hz:.4f} bps/Hz flown vs "
                    f"{self.planned_min_rate_bps_hz:.4f} planned")
        return (f"the {self.profile.name} replay flies the cycle in {self.replayed_cycle_s:.1f} s,"
                f" {ratio:.2f} x T = {self.period_s:g} s{rate}")

    def as_dict(self) -> dict[str, object]:
        """The report's ``"flight"`` section."""
        c = self.report.cycle
        clearances = self.clearance_by_nfz_m
        tp = self.report.throughput
        return {
            "profile": self.profile.name,
            "params": dict(self.params),
            "planned_min_rate_bps_hz": self.planned_min_rate_bps_hz,
            "replayed_min_rate_bps_hz": self.replayed_min_rate_bps_hz,
            "min_rate_ratio": self.min_rate_ratio,
            "planned_cycle_s": self.period_s,
            "replayed_cycle_s": self.replayed_cycle_s,
            "replayed_cycles_s": list(c.flown_cycles_s) if c is not None else [],
            "cycle_ratio": self.cycle_ratio,
            "replayed_mission_s": self.report.duration_s,  # take-off to landing
            "replayed_clearance_by_nfz_m": clearances,
            "replayed_clearance_min_m": min(clearances.values()) if clearances else None,
            "fence_entries": len(self.report.fence_entries),
            "cross_track_max_m": self.report.cross_track_max_m,
            "speed_max_mps": self.report.speed_max_mps,
            "per_gn": tp.as_dict()["per_gn"] if tp is not None else [],
            "warning": self.warning(),
            "problems": list(self.problems),  # why plan-mission refuses it (--force: written)
            "findings": [f.as_dict() for f in self.report.findings],
        }


def refusals(mission: Mission, flight: FlightCheck | None = None) -> tuple[str, ...]:
    """Why ``mission`` must not be written, one line each (empty: it may be): the safety
    gate's ``Mission.problems``, and with its replay ``flight`` that replay's
    (:attr:`FlightCheck.problems`)."""
    return mission.problems + (flight.problems if flight is not None else ())


def replay_mission(
    mission: Mission,
    params: AutopilotParams | Mapping[str, float] | None = None,
    *,
    profile: str | None = None,
    dt_s: float = REPLAY_STEP_S,
) -> FlightCheck:
    """Fly ``mission`` with the validator's model of its autopilot and score the track.

    ``params`` (autopilot names and units) default to :func:`recommended_params`; ``profile``
    to ``arducopter`` for ArduPilot missions and ``px4`` for PX4. Samples every ``dt_s`` s.
    """
    site = mission.solution.site
    if params is None:
        params = recommended_params(mission)
    values = dict(params.values if isinstance(params, AutopilotParams) else params)
    name = profile or Autopilot.named(mission.options.autopilot).profile_name
    values = flown_params(name, values)
    prof = make_profile(name, site_limits(site), values)
    flight = resolve_flight(mission.plan, site, "mission")
    track = replay(flight, prof, dt_s=dt_s)
    report = score_replay(track, flight, site, mission.plan, prof)
    return FlightCheck(prof, values, site.period_s, report, flight, track)


__all__ = ["CYCLE_OVERRUN_WARN", "FlightCheck", "refusals", "replay_mission"]
