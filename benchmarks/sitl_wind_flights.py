"""Fly realistic plans in ArduCopter SITL wind and record each flight's summary figures.

Run by hand where an ArduCopter SITL binary exists (one flight at a time, lockstepped):

    .venv/bin/python benchmarks/sitl_wind_flights.py --binary /opt/sitl/arducopter \
        --out tests/data/arducopter-sitl-wind/flights.json

For each site and wind: the plan made for that wind (``plan-mission --wind``) and the site's
still-air plan, both flown with ``validate-mission --sitl-binary BINARY --wind W`` (SITL's
SIM_WIND_SPD / DIR / TURB, SIM_WIND_T 1) and replayed in the same wind by the arducopter model
(the prediction). Per flight it keeps figures, not logs: T, the predicted and the flown cycle,
the replayed and the flown min rate (per flown second), the flown and the replayed clearance of
every zone, the cross-track deviation (max, rms), how the flight ended, the site's buffer and
the buffer the plan was made with (larger in wind: :func:`validator.wind_track.wind_buffer_m`).
Flights already in ``--out`` are skipped (re-run to resume); the file is rewritten after each
flight. Then the per-flight table is printed (``--table`` prints it from ``--out`` alone).
"""

from __future__ import annotations

import contextlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from validator.errors import CommandParser

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
DATA = ROOT / "tests" / "data" / "arducopter-sitl-wind"
SITES = {
    "realistic": ROOT / "samples" / "realistic.yaml",
    "orchard": DATA / "sites" / "orchard.yaml",
    "harbour": DATA / "sites" / "harbour.yaml",
}
# wind speed m/s @ from degrees , turbulence m/s
WINDS = ("0@0", "4@270,1", "6@270,1.5", "8@0,2", "6@135,1.5", "8@45,2", "3@200,0.5",
         "7@315,2")


def _run(argv: list[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(argv, capture_output=True, text=True, check=False)


def _plan(site: Path, out: Path, wind: str | None) -> dict[str, Any]:
    argv = [str(BIN / "plan-mission"), str(site), "-o", str(out), "--quiet",
            "--report", str(out.with_suffix(".report.json"))]
    if wind is not None:
        argv += ["--wind", wind]
    done = _run(argv)
    if done.returncode != 0:
        raise RuntimeError(f"plan-mission {site.name} --wind {wind}: {done.stderr.strip()}")
    return dict(json.loads(out.with_suffix(".report.json").read_text()))


def _fly(plan: Path, site: Path, wind: str, binary: str, speedup: float) -> dict[str, Any]:
    report = plan.with_suffix(f".flown-{wind.replace('@', 'at').replace(',', 't')}.json")
    vehicle = ["--sitl"] if binary == "builtin" else ["--sitl-binary", binary]
    done = _run([str(BIN / "validate-mission"), str(plan), "--site", str(site), "--params",
                 str(plan.with_suffix(".param")), *vehicle, "--wind", wind,
                 "--sitl-speedup", f"{speedup:g}", "--report", str(report)])
    if not report.exists():
        raise RuntimeError(f"validate-mission {plan.name} --wind {wind}: {done.stderr.strip()}")
    return dict(json.loads(report.read_text()))


def _summary(site: str, wind: str, kind: str, flown: dict[str, Any]) -> dict[str, Any]:
    replay, sitl = flown["replay"], flown["sitl"]
    w = flown["wind"]["flown_in"] or {"speed_mps": 0.0, "from_deg": 0.0, "turbulence_mps": 0.0}

    def cycle(rep: dict[str, Any] | None) -> float | None:
        c = (rep or {}).get("cycle")
        return None if not c else float(c["flown_cycle_s"])

    def rate(rep: dict[str, Any] | None) -> float | None:
        t = (rep or {}).get("throughput")
        return None if not t else float(t["flown_min_bps_hz"])

    zones = {z["nfz"]: z["clearance_m"] for z in (sitl or {}).get("nfz", [])}
    modelled = {z["nfz"]: z["clearance_m"] for z in (replay or {}).get("nfz", [])}
    period = (replay or {}).get("cycle", {}) or {}
    return {
        "site": site, "wind": wind, "plan": kind,
        "wind_speed_mps": w["speed_mps"], "wind_from_deg": w["from_deg"],
        "turbulence_mps": w["turbulence_mps"],
        "planned_for": flown["wind"]["planned_for"],
        "period_s": period.get("planned_period_s"),
        "predicted_cycle_s": cycle(replay), "flown_cycle_s": cycle(sitl),
        "replayed_min_rate_bps_hz": rate(replay), "flown_min_rate_bps_hz": rate(sitl),
        "planned_min_rate_bps_hz": ((replay or {}).get("throughput") or {}).get(
            "planned_min_bps_hz"),
        "flown_clearance_m": zones, "replayed_clearance_m": modelled,
        "cross_track_max_m": (sitl or {}).get("cross_track_max_m"),
        "cross_track_rms_m": (sitl or {}).get("cross_track_rms_m"),
        "fence_breach_samples": flown.get("sitl_flight", {}).get("fence_breach_samples"),
        "end": flown.get("sitl_flight", {}).get("end"),
        "buffer_m": None,
        # Where the min-rate node loses (per node) and when (each waypoint's arrival against
        # the plan's, flown and replayed): the figures a miss is diagnosed from.
        "flown_rate_by_gn": _by_gn(sitl), "replayed_rate_by_gn": _by_gn(replay),
        "flown_lag_s": _lags(sitl), "replayed_lag_s": _lags(replay),
    }


def _by_gn(rep: dict[str, Any] | None) -> dict[str, float]:
    t = (rep or {}).get("throughput") or {}
    return {g["gn"]: float(g["flown_bps_hz"]) for g in t.get("per_gn", [])}


def _lags(rep: dict[str, Any] | None) -> dict[str, float]:
    # keyed by item number (validator.item_numbers, QGroundControl's); the flights-*.json
    # recorded before December 2026 key them by the 0-based index, one less
    lags = (rep or {}).get("waypoint_lag", [])
    return {str(w["item"]): round(float(w["lag_s"]), 2) for w in lags}


def table(flights: list[dict[str, Any]]) -> str:
    """The per-flight table (markdown)."""
    lines = ["| site | wind (m/s @ from, turb) | plan | cycle / T | predicted / flown cycle | "
             "least clearance (m) | flown / report's min rate | flown min rate |",
             "|---|---|---|---|---|---|---|---|"]
    for f in flights:
        t, pred, flown = f["period_s"], f["predicted_cycle_s"], f["flown_cycle_s"]
        clear = min(f["flown_clearance_m"].values(), default=float("nan"))
        # the report's prediction (its replay in the plan's wind), as targets() measures
        rate = f["flown_min_rate_bps_hz"]
        planned = f.get("report_min_rate_bps_hz") or f["replayed_min_rate_bps_hz"]
        lines.append(
            f"| {f['site']} | {f['wind']} | {f['plan']} | "
            f"{flown / t:.3f} | {pred / flown:.3f} | {clear:.2f} | "
            f"{(rate / planned if rate and planned else float('nan')):.3f} | "
            f"{rate if rate is not None else float('nan'):.4f} |"
            if t and pred and flown else f"| {f['site']} | {f['wind']} | {f['plan']} | "
            f"(no cycle flown: {f['end']}) | | | | |")
    return "\n".join(lines)


def targets(flights: list[dict[str, Any]]) -> str:
    """Issue 26's targets over the windy flights of plans made for their wind: each aware
    flight against the report's prediction (its replay in the plan's wind, when recorded)
    and against the still-air plan flown in the same wind at the same site."""
    blind = {(f["site"], f["wind"]): f for f in flights if f["plan"] == "blind"}
    aware = [f for f in flights if f["plan"] == "aware" and f["wind_speed_mps"] > 0
             and f["flown_cycle_s"]]
    counts = {"cycle within 5 % of T": 0, "predicted cycle within 3 % of flown": 0,
              "no flown point inside the site's buffer": 0,
              "flown min rate >= 0.97 of the report's": 0,
              "min rate per flown second >= the still-air plan's": 0}
    compared = 0
    for f in aware:
        report = f.get("report_min_rate_bps_hz") or f["replayed_min_rate_bps_hz"]
        rate = f["flown_min_rate_bps_hz"] or 0.0
        checks = [abs(f["flown_cycle_s"] / f["period_s"] - 1) <= 0.05,
                  abs(f["predicted_cycle_s"] / f["flown_cycle_s"] - 1) <= 0.03,
                  min(f["flown_clearance_m"].values()) >= f["buffer_m"],
                  report is not None and rate >= 0.97 * report]
        other = blind.get((f["site"], f["wind"]))
        if other is not None:
            compared += 1
            checks.append(rate >= (other["flown_min_rate_bps_hz"] or 0.0))
        for key, ok in zip(counts, checks, strict=False):
            counts[key] += int(ok)
    return "\n".join([f"{len(aware)} windy flights of plans made for their wind:"]
                     + [f"- {k}: {v} of {compared if k.startswith('min rate') else len(aware)}"
                        for k, v in counts.items()])


def main() -> None:
    ap = CommandParser(description=__doc__.splitlines()[0])
    ap.add_argument("--binary", help="ArduCopter SITL binary ('builtin': the model vehicle, "
                    "to try the script)")
    ap.add_argument("--out", type=Path, default=DATA / "flights.json")
    ap.add_argument("--sites", nargs="*", default=list(SITES), choices=list(SITES))
    ap.add_argument("--winds", nargs="*", default=list(WINDS))
    ap.add_argument("--speedup", type=float, default=10.0)
    ap.add_argument("--blind", action="store_true", help="also fly each site's still-air plan")
    ap.add_argument("--only-blind", action="store_true",
                    help="fly only the still-air plans in wind (they do not change with the "
                    "wind model, so they can be flown apart)")
    ap.add_argument("--table", action="store_true", help="only print the table of --out")
    ap.add_argument("--keep-plans", type=Path,
                    help="write the plans (and their .param) into this directory and keep them "
                    "(default: a temporary one)")
    args = ap.parse_args()
    flights: list[dict[str, Any]] = json.loads(args.out.read_text()) if args.out.exists() else []
    if not args.table:
        if not args.binary:
            ap.error("--binary is needed to fly")
        done = {(f["site"], f["wind"], f["plan"]) for f in flights}
        with contextlib.ExitStack() as stack:
            if args.keep_plans:
                args.keep_plans.mkdir(parents=True, exist_ok=True)
                tmp = str(args.keep_plans)
            else:
                tmp = stack.enter_context(tempfile.TemporaryDirectory(prefix="nfz-wind-"))
            for name in args.sites:
                site = SITES[name]
                blind = Path(tmp) / f"{name}-still.plan"
                blind_report = None
                for wind in args.winds:
                    kinds = ["aware"] + (["blind"] if args.blind and wind != "0@0" else [])
                    if args.only_blind:
                        kinds = ["blind"] if wind != "0@0" else []
                    for kind in kinds:
                        if (name, wind, kind) in done:
                            continue
                        try:
                            if kind == "blind" or wind == "0@0":
                                if blind_report is None:
                                    blind_report = _plan(site, blind, None)
                                plan, planned = blind, blind_report
                            else:
                                plan = Path(tmp) / f"{name}-{wind.replace('@', 'at')}.plan"
                                planned = _plan(site, plan, wind)
                            flown = _fly(plan, site, wind, args.binary, args.speedup)
                        except RuntimeError as err:
                            print(f"{name} {wind} {kind}: {err}", file=sys.stderr)
                            continue
                        row = _summary(name, wind, kind, flown)
                        row["buffer_m"] = float(_site_buffer(site))
                        row["plan_buffer_m"] = float(planned["buffer_m"])
                        # The report's prediction: its replay in the wind the plan was made for
                        row["report_min_rate_bps_hz"] = (planned.get("flight") or {}).get(
                            "replayed_min_rate_bps_hz")
                        row["report_cycle_s"] = (planned.get("flight") or {}).get(
                            "replayed_cycle_s")
                        flights.append(row)
                        args.out.write_text(json.dumps(flights, indent=1) + "\n")
                        print(table([row]).splitlines()[-1], flush=True)
    print(table(flights))
    print(targets(flights))


def _site_buffer(site: Path) -> float:
    from validator.site import load_site

    return load_site(site).buffer_m


if __name__ == "__main__":
    main()
