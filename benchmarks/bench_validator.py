"""Validator benchmark: audit + replay speed on a 50-slot plan, and the arducopter calibration.

Run by hand (figures, not pass/fail):  .venv/bin/python benchmarks/bench_validator.py

Prints
- median wall time (of ``--runs``) of each stage for a 50-slot service plan on
  samples/paper-default.yaml, laid out like our exporter's (a waypoint per moving slot with
  its DO_CHANGE_SPEED, hovers as holds, DO_JUMP for the other cycles) with 1 and 3 cycles:
  resolving the plan, the exact audit, and replay + scoring with each profile at 20 Hz.
  Target: audit + arducopter replay of the 3-cycle plan in well under 1 s;
- the ``validate-mission --replay --json`` command end to end (a fresh process, imports
  included);
- when the shared ArduCopter SITL flights of our plans are beside the repository
  (``../shared/data/arducopter-sitl-2``): per flight, the arducopter replay (at the flown
  .param) against the flight: cycle, whole mission (arming to land complete), top speed,
  cross-track RMS and the min rate along the track. Targets: mission within 5 %, cycle 3 %;
- per recorded PX4 v1.15.4 SIH flight of our plans (``tests/data/px4-sih``): the px4 replay
  against the flight, the same figures, and the flown cycle over T.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from validator.audit import audit
from validator.errors import CommandParser
from validator.flight import resolve_flight
from validator.motion.limits import site_limits
from validator.motion.profile import flown_params, make_profile
from validator.plan_format import Cmd, FenceCircle, Frame, MissionItem, Plan, write_plan
from validator.replay import TrackReport, replay, score_track
from validator.site import Site, load_site

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the tests' flight loader
from tests.validator import px4_flights, sitl_flights  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "samples" / "paper-default.yaml"


def service_trajectory(site: Site) -> tuple[np.ndarray, np.ndarray, list[str | None]]:
    """A closed 50-slot tour GN1 -> GN2 -> GN3 -> GN4 around the NFZs, hovering at each GN."""
    gn = {name: xy for name, xy in zip(site.gn_names, site.gn_xy_m, strict=True)}
    corners = [gn["GN1"], (190.0, 380.0), gn["GN2"], (380.0, 210.0), gn["GN3"], (210.0, 40.0),
               gn["GN4"], (60.0, 215.0), gn["GN1"]]
    hover_at = {0: "GN1", 2: "GN2", 4: "GN3", 6: "GN4"}
    moving_slots = 50 - len(hover_at)
    seg = [np.hypot(*(np.subtract(b, a))) for a, b in zip(corners[:-1], corners[1:], strict=True)]
    per = np.maximum(1, np.round(np.array(seg) / sum(seg) * moving_slots)).astype(int)
    per[-1] += moving_slots - per.sum()
    q: list[np.ndarray] = [np.asarray(corners[0], dtype=float)]
    delta: list[float] = []
    sched: list[str | None] = []
    speed = 0.85 * site.max_speed_mps
    for i, (a, b) in enumerate(zip(corners[:-1], corners[1:], strict=True)):
        if i in hover_at:
            q.append(q[-1].copy())
            delta.append(3.0)
            sched.append(hover_at[i])
        for f in np.linspace(0, 1, per[i] + 1)[1:]:
            q.append(np.asarray(a) + f * (np.asarray(b) - np.asarray(a)))
            delta.append(seg[i] / per[i] / speed)
            near = min(site.gn_names, key=lambda n: float(np.hypot(*(q[-1] - gn[n]))))
            sched.append(near)
    return np.array(q), np.array(delta), sched


def exporter_like_plan(site: Site, cycles: int) -> Plan:
    q, delta, sched = service_trajectory(site)

    def nav(xy: Any, cmd: int = Cmd.NAV_WAYPOINT, hold: float = 0.0,
            alt: float = site.altitude_m) -> MissionItem:
        lat, lon = site.frame.to_geodetic(np.asarray(xy, dtype=float))
        return MissionItem(int(cmd), [hold, 0, 0, float("nan"), float(lat), float(lon), alt],
                           int(Frame.GLOBAL_RELATIVE_ALT))

    def spd(v: float) -> MissionItem:
        return MissionItem(int(Cmd.DO_CHANGE_SPEED), [1.0, v, -1.0, 0, 0, 0, 0], 2)

    home = site.home_xy_m
    items = [nav(home, Cmd.NAV_TAKEOFF), spd(site.max_speed_mps), nav((40.0, 200.0)), nav(q[0])]
    first = len(items)
    n = 1
    while n < len(q):
        m, hold = n + 1, 0.0
        while m < len(q) and np.hypot(*(q[m] - q[n])) < 1e-6:
            hold += delta[m - 1]
            m += 1
        length = float(np.hypot(*(q[n] - q[n - 1])))
        if length > 1e-6:
            items.append(spd(length / delta[n - 1]))
        else:
            hold += delta[n - 1]
        items.append(nav(q[n], hold=float(round(hold))))
        n = m
    closing = len(items) - 1
    if cycles > 1:
        items.append(MissionItem(int(Cmd.DO_JUMP), [first + 1.0, cycles - 1.0, 0, 0, 0, 0, 0], 2))
    items += [spd(site.max_speed_mps), nav((40.0, 200.0)), nav(home, Cmd.NAV_LAND, alt=0.0)]
    circles = []
    for xy, r in zip(site.nfz_xy_m, site.nfz_radius_m, strict=True):
        lat, lon = site.frame.to_geodetic(xy)
        circles.append(FenceCircle(float(lat), float(lon), float(r), inclusion=False))
    lat, lon = site.frame.to_geodetic(home)
    return Plan(items=items, home_lat_deg=float(lat), home_lon_deg=float(lon),
                home_alt_m=site.frame.alt0_m, circles=circles, extra={
                    "format": 1, "site": site.name, "scheme": "proposed",
                    "trajectory_m": q.tolist(), "delta_s": delta.tolist(),
                    "power_w": [site.p_avg_w] * len(delta), "schedule": sched,
                    "cycle_items": [first, closing], "cycles": cycles})


def timed(fn: Callable[[], Any], runs: int) -> tuple[float, Any]:
    times, out = [], None
    for _ in range(runs):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def speed_figures(runs: int) -> None:
    site = load_site(SAMPLE)
    print(f"50-slot plan on {SAMPLE.name} (median of {runs} runs, 20 Hz replay)")
    print(f"  {'cycles':>6} {'items':>6} {'legs':>5} {'resolve':>9} {'audit':>9} "
          f"{'profile':>10} {'replay+score':>13} {'samples':>8} {'flown/T':>8} "
          f"{'audit+replay':>13}")
    for cycles in (1, 3):
        plan = exporter_like_plan(site, cycles)
        t_res, flight = timed(partial(resolve_flight, plan, site), runs)
        t_aud, rep = timed(partial(audit, plan, site, flight), runs)
        assert rep.ok, [f.message for f in rep.violations]
        for name in ("ideal", "arducopter", "px4"):
            prof = make_profile(name, site_limits(site))

            def run(prof: Any = prof, flight: Any = flight, plan: Plan = plan) -> Any:
                track = replay(flight, prof)
                return track, score_track(track, flight, site, plan)

            t_rep, (track, scored) = timed(run, runs)
            ratio = scored.cycle.ratio if scored.cycle else float("nan")
            print(f"  {cycles:>6} {len(plan.items):>6} {len(flight.legs):>5} "
                  f"{t_res * 1e3:>7.1f}ms {t_aud * 1e3:>7.1f}ms {name:>10} "
                  f"{t_rep * 1e3:>11.1f}ms {track.t_s.size:>8} {ratio:>8.2f} "
                  f"{(t_res + t_aud + t_rep) * 1e3:>11.1f}ms")


def cli_figure() -> None:
    site = load_site(SAMPLE)
    with tempfile.TemporaryDirectory() as tmp:
        plan_path = Path(tmp) / "bench.plan"
        write_plan(exporter_like_plan(site, 3), plan_path)
        exe = Path(sys.executable).with_name("validate-mission")
        cmd = [str(exe), str(plan_path), "--site", str(SAMPLE), "--replay", "--json",
               str(Path(tmp) / "out.json")]
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        dt = time.perf_counter() - t0
    print(f"validate-mission --replay --json, 3 cycles, fresh process: {dt:.2f} s "
          f"(exit {proc.returncode})")


CALIBRATION_HEADER = (f"{'cycle (s)':>15} {'err':>7} {'cycle/T':>8} {'mission (s)':>15} {'err':>7} "
                      f"{'top speed (m/s)':>16} {'cross-track RMS (m)':>20} "
                      f"{'min rate (bps/Hz)':>18}")


def calibration_row(name: str, model: TrackReport, flown: TrackReport, flown_cycle_s: float,
                    flown_mission_s: float) -> str:
    """One flight: predicted / flown cycle, cycle over T, mission, top speed, cross-track and
    min rate (``flown_cycle_s`` and ``flown_mission_s`` as the data set measures them)."""
    assert model.cycle is not None
    cyc, mission = model.cycle.flown_cycle_s, model.duration_s
    ratio = flown.cycle.ratio if flown.cycle is not None else float("nan")
    rates = (f"{model.throughput.flown_min:.3f}/{flown.throughput.flown_min:.3f}"
             if model.throughput and flown.throughput else "-")
    return (f"  {name:<24} {cyc:>7.1f}/{flown_cycle_s:<7.1f} {cyc / flown_cycle_s - 1:>+7.1%} "
            f"{ratio:>8.3f} "
            f"{mission:>7.1f}/{flown_mission_s:<7.1f} {mission / flown_mission_s - 1:>+7.1%} "
            f"{model.speed_max_mps:>7.2f}/{flown.speed_max_mps:<8.2f} "
            f"{model.cross_track_rms_m:>9.2f}/{flown.cross_track_rms_m:<10.2f} {rates:>18}")


def calibration() -> None:
    """Predicted (arducopter replay at the flown .param) vs flown, per shared SITL flight."""
    if not sitl_flights.available():
        print(f"calibration: shared SITL flights not found at {sitl_flights.DATA}; skipped")
        return
    print("arducopter replay vs ArduCopter 4.5.6 SITL (../shared/data/arducopter-sitl-2; "
          "predicted / flown; mission = arming to land complete)")
    print(f"  {'flight':<24} {CALIBRATION_HEADER}")
    for name in sitl_flights.names():
        rec = sitl_flights.load(name)
        prof = make_profile("arducopter", site_limits(rec.site), rec.params)
        model = score_track(replay(rec.flight, prof), rec.flight, rec.site, rec.plan)
        flown = score_track(rec.track(), rec.flight, rec.site, rec.plan)
        print(calibration_row(name, model, flown, rec.cycle_s, rec.mission_s))


def px4_calibration() -> None:
    """Predicted (px4 replay at the flown parameter file) vs flown, per recorded PX4 SIH
    flight (tests/data/px4-sih)."""
    print("px4 replay vs PX4 v1.15.4 SIH (tests/data/px4-sih; predicted / flown; mission = "
          "takeoff to disarm)")
    print(f"  {'flight':<24} {CALIBRATION_HEADER}")
    for name in px4_flights.names():
        rec = px4_flights.load(name)
        prof = make_profile("px4", site_limits(rec.site), flown_params("px4", rec.params))
        model = score_track(replay(rec.flight, prof), rec.flight, rec.site, rec.plan)
        flown = score_track(rec.track(), rec.flight, rec.site, rec.plan)
        assert flown.cycle is not None
        print(calibration_row(name, model, flown, flown.cycle.flown_cycle_s, rec.mission_s))


def main() -> None:
    parser = CommandParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    speed_figures(args.runs)
    print()
    cli_figure()
    print()
    calibration()
    print()
    px4_calibration()


if __name__ == "__main__":
    main()
