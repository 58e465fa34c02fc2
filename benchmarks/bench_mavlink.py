"""MAVLink benchmark: upload speed against packet loss, and a SITL flight against the replay.

Run by hand (figures, not pass/fail):  .venv/bin/python benchmarks/bench_mavlink.py

Prints
- wall time to upload and verify (download and compare) a plan of ``--waypoints`` waypoints
  with a fence and a rally point to the built-in SITL vehicle over loopback UDP, at 0, 10 and
  20 % packet loss each way (seeded), with the ground station's default 0.5 s retry;
- wall time of flying the same plan on the built-in vehicle at ``--speedup``, the vehicle
  seconds flown, and the largest distance between the flown track and the validator's
  arducopter replay of the plan (same model; the difference is sampling and takeoff).
"""

from __future__ import annotations

import socket
import time

import numpy as np

from validator.errors import CommandParser
from validator.flight import resolve_flight
from validator.mavlink.driver import builtin_vehicle, fly_mission
from validator.mavlink.link import Link, LinkError, upload_plan, upload_to
from validator.mavlink.sim import SitlVehicle, VehicleConfig
from validator.mavlink.telemetry import telemetry_track
from validator.motion.limits import site_limits
from validator.motion.profile import make_profile
from validator.plan_format import Cmd, FenceCircle, Frame, MissionItem, Plan
from validator.replay import replay
from validator.site import parse_site

SITE = {
    "name": "bench", "origin": {"lat": -35.363261, "lon": 149.16523, "alt": 584.0},
    "uav": {"altitude": 30.0, "max_speed": 10.0, "period": 100.0, "slots": 20},
    "radio": {"p_avg_dbm": 20.0, "p_peak_dbm": 26.0206, "beta0_db": -30.0, "noise_dbm": -70.0},
    "ground_nodes": [{"name": "GN1", "x": 0.0, "y": 100.0}],
    "no_fly_zones": [{"name": "NFZ1", "x": 100.0, "y": -100.0, "radius": 20.0}],
}


def bench_plan(n: int) -> Plan:
    site = parse_site(SITE)
    angles = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    xy = np.column_stack([60 * np.cos(angles), 60 + 60 * np.sin(angles)])
    lat, lon = site.frame.to_geodetic(xy)
    items = [MissionItem(int(Cmd.NAV_TAKEOFF), [0, 0, 0, 0, -35.363261, 149.16523, 30.0]),
             MissionItem(int(Cmd.DO_CHANGE_SPEED), [1, 8.0, -1, 0, 0, 0, 0], int(Frame.MISSION))]
    items += [MissionItem(int(Cmd.NAV_WAYPOINT), [0, 0, 0, 0, float(a), float(b), 30.0])
              for a, b in zip(lat, lon, strict=True)]
    items.append(MissionItem(int(Cmd.NAV_LAND), [0, 0, 0, 0, -35.363261, 149.16523, 0.0]))
    zlat, zlon = site.frame.to_geodetic(np.array([100.0, -100.0]))
    return Plan(items, -35.363261, 149.16523, 584.0,
                circles=[FenceCircle(float(zlat), float(zlon), 21.0)],
                rally=[(-35.363261, 149.16523, 30.0)])


def main() -> None:
    parser = CommandParser(description=__doc__.splitlines()[0])
    parser.add_argument("--waypoints", type=int, default=40)
    parser.add_argument("--speedup", type=float, default=50.0)
    args = parser.parse_args()
    plan = bench_plan(args.waypoints)
    home = (plan.home_lat_deg, plan.home_lon_deg, plan.home_alt_m)
    print(f"upload + verify, {len(plan.items) + 1} mission + 1 fence + 1 rally items")
    for loss in (0.0, 0.1, 0.2):
        vehicle = SitlVehicle("udpin:127.0.0.1:0", VehicleConfig(home, loss=loss, seed=1)).start()
        try:
            with Link(f"udpout:127.0.0.1:{vehicle.address[1]}", timeout_s=10) as link:
                t0 = time.perf_counter()
                upload_to(link, plan, require_fence=False)  # the transfer is what is timed
                print(f"  loss {loss:4.0%}: {time.perf_counter() - t0:6.2f} s")
        finally:
            vehicle.stop()

    site = parse_site(SITE)
    profile = make_profile("arducopter", site_limits(site))
    flight = resolve_flight(plan, site)
    with builtin_vehicle(plan, profile=profile, speedup=args.speedup) as url:
        with Link(url, timeout_s=10) as link:
            upload_to(link, plan, require_fence=False)
            t0 = time.perf_counter()
            tel = fly_mission(link, plan, time_limit_s=3600)
            wall = time.perf_counter() - t0
    flown = telemetry_track(tel, flight, site, ardupilot=True, source="sitl")
    model = replay(flight, profile)
    reached = {seq - 1: t - tel.takeoff_start_s for t, seq in tel.reached}
    first_wp = 2
    shift = model.item_reached_s(flight, first_wp)[0] - reached[first_wp]
    sel = flown.t_s >= reached[first_wp]
    xy_model = np.column_stack([np.interp(flown.t_s[sel] + shift, model.t_s, model.xy_m[:, i])
                                for i in range(2)])
    gap = float(np.max(np.hypot(*(flown.xy_m[sel] - xy_model).T)))
    print(f"SITL flight at x{args.speedup:g}: {wall:.1f} s wall for "
          f"{tel.t_s[-1] - tel.mission_start_s:.1f} vehicle s ({tel.samples} samples, "
          f"{tel.end_reason}); largest distance from the replay {gap:.3f} m")


    for timeout_s in (1.0, 3.0):
        port = _free_udp_port()
        t0 = time.perf_counter()
        try:
            upload_plan(plan, f"udpout:127.0.0.1:{port}", timeout_s=timeout_s)
        except LinkError:
            pass
        print(f"dead link with --timeout {timeout_s:g}: failed after "
              f"{time.perf_counter() - t0:.2f} s")


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


if __name__ == "__main__":
    main()
