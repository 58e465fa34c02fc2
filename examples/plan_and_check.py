# %% [markdown]
# # Plan a mission, check it, fly it: the front door from a notebook
#
# Plans the quick start's site (`samples/realistic.yaml`) for ArduPilot, replays it with the
# validator's model of ArduCopter, writes the files `plan-mission` writes, audits the written
# plan as a third party would, flies it on a vehicle and scores the recorded track again, using
# only the front door (`mission_planner.api`, which re-exports `validator.api`'s calls).
#
# Run it whole:  `.venv/bin/python examples/plan_and_check.py [OUT_DIR] [--quick]`
# (default OUT_DIR `example-out`; `--quick` plans with the paper's kinematic model and flies
# the built-in model vehicle at 50x: seconds instead of a minute), or cell by cell (`# %%`) in
# VS Code or Jupyter. The vehicle is `$ARDUPILOT_SITL` (a real ArduCopter SITL binary) when set
# and not `--quick`, else the built-in model vehicle.
# Units: metres, seconds, m/s; rates in bps/Hz.

# %%
import sys
from pathlib import Path

from mission_planner import api

REPO = Path(__file__).resolve().parents[1]
QUICK = "--quick" in sys.argv[1:]
OUT = Path(next((a for a in sys.argv[1:] if not a.startswith("--")), "example-out"))
OUT.mkdir(parents=True, exist_ok=True)

# %% Load the site: ground nodes, no-fly zones, the vehicle's limits, the radio
site = api.load_site(REPO / "samples" / "realistic.yaml")
print(f"{site.name}: {site.num_gns} ground nodes, {site.num_nfzs} no-fly zones, "
      f"T = {site.period_s:g} s, buffer {site.buffer_m:g} m")

# %% Plan: optimise the service cycle (Algorithm 1) and lay it out as an ArduPilot mission
options = api.MissionOptions(autopilot="ardupilot", cycles=1)
mission = api.plan_mission(site, "proposed", options,
                           dynamics="none" if QUICK else "vehicle")
print(f"{len(mission.plan.items)} items, planned min rate "
      f"{mission.solution.min_rate_bps_hz:.4f} bps/Hz, safe: {mission.safe}")

# %% Replay it with the model of ArduCopter at the parameters the vehicle will be given
params = api.recommended_params(mission)
flight = api.replay_mission(mission, params)
print(f"replayed cycle {flight.replayed_cycle_s:.1f} s for T = {flight.period_s:g} s; "
      f"replayed min rate {flight.replayed_min_rate_bps_hz:.4f} bps/Hz")
if flight.warning():
    print("warning:", flight.warning())
for problem in flight.problems:  # e.g. longer than the site's uav.endurance: write refuses it
    print("unsafe:", problem)

# %% Write the plan, its parameter file, the report and the interactive view (all or none)
written = api.write_mission(mission, OUT / "mission.plan", autopilot_params=params,
                            flight=flight, report=OUT / "report.json",
                            html=OUT / "view.html")
print("wrote", ", ".join(p.name for p in written.files))

# %% Audit the written plan against the site, as the validator judges any plan
plan = api.read_plan(written.mission)
audit = api.audit_plan(plan, site, source=str(written.mission))
for zone in audit.nfz:
    print(f"  {zone.name}: closest leg {zone.clearance_m:.2f} m from the zone")
print("audit:", "CLEAR" if not audit.violations else f"{len(audit.violations)} violation(s)")

# %% Replay the written plan (the validator's own replay, from the file alone)
replayed = api.replay_plan(plan, site, params=params.values)
cycle = replayed.report.cycle
print(f"replay ({replayed.profile.name}): cycle "
      + (f"{cycle.flown_cycle_s:.1f} s" if cycle else "not completed")
      + f", {len(replayed.report.violations)} violation(s)")

# %% Fly it on a vehicle, with the parameter file set on it first
vehicle = api.VehicleChoice("builtin", speedup_x=50.0) if QUICK else api.choose_vehicle(plan)
print("flying on", vehicle.describe())
flown = api.fly_plan(plan, site, vehicle, params=params.values)
print(f"flown by {flown.vehicle} ({flown.kind}): {flown.telemetry.samples} samples, "
      f"ended {flown.telemetry.end_reason}; {len(flown.report.violations)} violation(s)")

# %% Keep the recorded track, and score it again later from the file
track_file = OUT / "flown.csv.gz"
api.write_track(track_file, flown.recorded, ("plan mission.plan",))
again = api.score_recorded(plan, site, track_file)
print("recorded flight, scored again:",
      ", ".join(f"{z.name} {z.clearance_m:.2f} m" for z in again.nfz))
