"""The safety gate at scale: plan many random and adversarial sites, check every written plan.

Run by hand (figures, not pass/fail; slow: ~10 s per site on a quiet 2-core machine):

    .venv/bin/python benchmarks/bench_safety.py                # 500 sites, both dynamics modes
    .venv/bin/python benchmarks/bench_safety.py --sites 40 --jobs 2

Sites cycle through the generators below: ``random`` (the study's ``random_site``, with a
buffer) and adversarial ones (zones clustered into narrow passages, home next to a zone, ground
nodes between two zones or on a zone's buffer ring, large radii, tiny periods, many slots) and
``polygon`` (the study's ``random_polygon_site``: convex and non-convex polygon zones).
Each site is planned as ``plan-mission`` does with ``--dynamics none`` and ``--dynamics
vehicle``. A mission the gate passes is "written": its ``.plan`` text is read back, audited
against the site and replayed (ArduCopter model at the recommended parameters). It is *unsafe*
when a planned leg comes closer to a zone than radius + buffer − 1 cm, the audit finds a
violation, or the replayed track enters a zone or an exclusion fence. Everything else is a
refusal: by the site reader (InputError: the generator drew an impossible site), by the planner
(InputError, exit 2) or by the gate (``Mission.problems``, exit 1). Any other exception is a
crash. Prints the counts, refusals by class, the worst clearances and the time per site.
"""

from __future__ import annotations

import collections
import math
import re
import time
import traceback
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from mission_planner.flight_report import replay_mission
from mission_planner.pipeline import plan_and_build
from mission_planner.study.sites import PAPER_ORIGIN, random_polygon_site, random_site
from validator.audit import audit
from validator.errors import CommandParser, InputError
from validator.flight import resolve_flight
from validator.plan_format import dumps_plan, loads_plan
from validator.site import Site, parse_site

TOLERANCE_M = 0.01  # the audit's tolerance (MAVLink's 1e-7° rounding)
DYNAMICS = ("none", "vehicle")


def _site(name: str, zones: list[tuple[float, float, float]], gns: list[tuple[float, float]],
          home: tuple[float, float], *, buffer_m: float = 2.0, period_s: float = 50.0,
          slots: int = 50, max_speed: float = 30.0) -> Site:
    lat0, lon0, alt0 = PAPER_ORIGIN
    return parse_site({
        "name": name,
        "origin": {"lat": lat0, "lon": lon0, "alt": alt0},
        "home": {"x": home[0], "y": home[1]},
        "uav": {"altitude": 30.0, "max_speed": max_speed, "period": period_s, "slots": slots},
        "radio": {"p_avg_dbm": 20.0, "p_peak_dbm": 26.0206, "beta0_db": -30.0,
                  "noise_dbm": -70.0},
        "ground_nodes": [{"name": f"GN{k + 1}", "x": x, "y": y} for k, (x, y) in enumerate(gns)],
        "no_fly_zones": [{"name": f"NFZ{m + 1}", "x": x, "y": y, "radius": r}
                         for m, (x, y, r) in enumerate(zones)],
        "safety": {"buffer_m": buffer_m},
    }, name)


def _pt(rng: np.random.Generator, lo: float = 0.0, hi: float = 400.0) -> tuple[float, float]:
    x, y = rng.uniform(lo, hi, 2)
    return float(x), float(y)


def gen_random(seed: int, rng: np.random.Generator) -> Site:
    return random_site(seed, buffer_m=float(rng.choice([0.0, 2.0, 5.0])))


def gen_passage(seed: int, rng: np.random.Generator) -> Site:
    """Two or three zones in a row, gaps between their buffered edges of 0.5-10 m."""
    r, buf = float(rng.uniform(20, 50)), 2.0
    gap = float(rng.uniform(0.5, 10.0))
    n = int(rng.integers(2, 4))
    zones = [(200.0, 60.0 + r + i * (2 * r + 2 * buf + gap), r) for i in range(n)]
    gap_y = 60.0 + r + (2 * r + 2 * buf + gap) / 2
    dy = rng.uniform(-20, 20, 2)
    gns = [(60.0, gap_y + float(dy[0])), (340.0, gap_y + float(dy[1])), _pt(rng)]
    gns = [g for g in gns if all(math.hypot(g[0] - x, g[1] - y) > zr for x, y, zr in zones)]
    return _site(f"passage-{seed}", zones, gns, (20.0, gap_y), buffer_m=buf)


def gen_home_at_zone(seed: int, rng: np.random.Generator) -> Site:
    """Home a few centimetres to a metre outside a zone's buffer."""
    r, buf = float(rng.uniform(20, 60)), float(rng.choice([0.5, 2.0, 5.0]))
    ang = float(rng.uniform(0, 2 * math.pi))
    d = r + buf + float(rng.uniform(0.01, 1.0))
    home = (200.0 + d * math.cos(ang), 200.0 + d * math.sin(ang))
    gns = [(200.0 - (r + 60) * math.cos(ang), 200.0 - (r + 60) * math.sin(ang)), _pt(rng),
           _pt(rng)]
    gns = [g for g in gns if math.hypot(g[0] - 200, g[1] - 200) > r]
    return _site(f"home-at-zone-{seed}", [(200.0, 200.0, r)], gns, home, buffer_m=buf)


def gen_gn_between(seed: int, rng: np.random.Generator) -> Site:
    """A ground node in the gap between two zones; another on a zone's buffer ring."""
    r, buf = float(rng.uniform(20, 50)), 2.0
    gap = float(rng.uniform(1.0, 15.0))
    zones = [(200.0 - r - gap / 2, 200.0, r), (200.0 + r + gap / 2, 200.0, r)]
    ring = (zones[0][0], 200.0 + r + float(rng.uniform(0.0, buf)))
    return _site(f"gn-between-{seed}", zones, [(200.0, 200.0), ring, _pt(rng, 0, 100)],
                 (200.0, 20.0), buffer_m=buf)


def gen_large_radii(seed: int, rng: np.random.Generator) -> Site:
    """Few zones covering much of the area, ground nodes wherever there is room."""
    r = float(rng.uniform(80, 150))
    zones = [(200.0, 200.0, r)]
    if rng.random() < 0.5:
        zones.append((200.0 + 2 * r + 10.0, 200.0, r * 0.6))
    gns: list[tuple[float, float]] = []
    while len(gns) < 4:
        g = _pt(rng, -100, 500)
        if all(math.hypot(g[0] - x, g[1] - y) > zr + 1 for x, y, zr in zones):
            gns.append(g)
    return _site(f"large-radii-{seed}", zones, gns, (200.0, 200.0 - r - 10.0))


def gen_tiny_period(seed: int, rng: np.random.Generator) -> Site:
    """Paper sites with a period of 1-10 s (and some with few slots)."""
    return random_site(seed, buffer_m=2.0, period_s=float(rng.uniform(1.0, 10.0)),
                       slots=int(rng.choice([5, 10, 50])))


def gen_many_slots(seed: int, rng: np.random.Generator) -> Site:
    return random_site(seed, buffer_m=2.0, slots=int(rng.choice([100, 150])),
                       num_gns=int(rng.integers(4, 9)), num_nfzs=int(rng.integers(3, 6)),
                       radius_m=float(rng.uniform(15, 35)))


def gen_polygon(seed: int, rng: np.random.Generator) -> Site:
    """Polygon zones, about half of them non-convex (the study's random_polygon_site)."""
    return random_polygon_site(seed, buffer_m=float(rng.choice([0.0, 2.0, 5.0])),
                               num_zones=int(rng.integers(2, 5)))


GENERATORS: dict[str, Callable[[int, np.random.Generator], Site]] = {
    "random": gen_random, "passage": gen_passage, "home-at-zone": gen_home_at_zone,
    "gn-between": gen_gn_between, "large-radii": gen_large_radii,
    "tiny-period": gen_tiny_period, "many-slots": gen_many_slots, "polygon": gen_polygon,
}


@dataclass
class Outcome:
    site: str
    dynamics: str
    verdict: str  # written | unsafe | refused | crash
    refusal: str = ""
    leg_margin_m: float = math.inf  # planned leg clearance minus (buffer - tolerance)
    replay_clearance_m: float = math.inf  # replayed track clearance from the published radius
    detail: list[str] = field(default_factory=list)


def _refusal_class(message: str) -> str:
    """The field an InputError names (text before the first colon after the source)."""
    words = re.sub(r"\(seed \d+[^)]*\)", "", message)
    return re.sub(r"[\d.]+", "#", words.split(":")[1].strip() if ":" in words else words)[:60]


def check_site(generator: str, seed: int) -> list[Outcome]:
    rng = np.random.default_rng([seed, sorted(GENERATORS).index(generator)])
    name = f"{generator}-{seed}"
    try:
        site = GENERATORS[generator](seed, rng)
    except InputError as err:
        return [Outcome(name, d, "refused", "site: " + _refusal_class(str(err))) for d in DYNAMICS]
    return [_check(site, name, dyn) for dyn in DYNAMICS]


def _check(site: Site, name: str, dynamics: str) -> Outcome:
    try:
        mission = plan_and_build(site, dynamics=dynamics)
        if mission.problems:
            return Outcome(name, dynamics, "refused",
                           "gate: " + re.sub(r"[\d.]+", "#", mission.problems[0])[:60])
        plan = loads_plan(dumps_plan(mission.plan), name)  # the file as written
        flight = resolve_flight(plan, site, name)
        report = audit(plan, site, flight, source=name)
        check = replay_mission(mission)
    except InputError as err:
        return Outcome(name, dynamics, "refused", "input: " + _refusal_class(str(err)))
    except Exception as err:  # noqa: BLE001 - a crash is what we count
        tb = traceback.format_exc(limit=-3).splitlines()
        return Outcome(name, dynamics, "crash", f"{type(err).__name__}: {err}"[:120],
                       detail=tb)
    out = Outcome(name, dynamics, "written")
    if site.zone_names and report.leg_clearance_m.size:
        out.leg_margin_m = float(report.leg_clearance_m.min()) - (site.buffer_m - TOLERANCE_M)
    out.replay_clearance_m = min(check.clearance_by_nfz_m.values(), default=math.inf)
    bad = [f.message for f in report.violations] + [f.message for f in check.report.violations]
    if out.leg_margin_m < 0:
        bad.append(f"planned leg {-out.leg_margin_m:.3f} m inside the buffered zone")
    if bad:
        out.verdict, out.detail = "unsafe", bad
    return out


def main(argv: list[str] | None = None) -> None:
    ap = CommandParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sites", type=int, default=500)
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    ap.add_argument("--generators", nargs="+", choices=list(GENERATORS), default=list(GENERATORS),
                    metavar="NAME", help=f"cycle through these only (default all: "
                                         f"{', '.join(GENERATORS)})")
    args = ap.parse_args(argv)
    names = list(args.generators)
    tasks = [(names[i % len(names)], i // len(names)) for i in range(args.sites)]
    started = time.perf_counter()
    outcomes: list[Outcome] = []
    with ProcessPoolExecutor(args.jobs) as pool:
        for i, result in enumerate(pool.map(check_site, *zip(*tasks, strict=True))):
            outcomes += result
            for o in result:
                if o.verdict in ("unsafe", "crash"):
                    print(f"  {o.verdict.upper()} {o.site} ({o.dynamics}): {o.refusal} "
                          f"{'; '.join(o.detail[-3:])}", flush=True)
            if (i + 1) % 5 == 0:
                print(f"  {i + 1}/{len(tasks)} sites, {time.perf_counter() - started:.0f} s",
                      flush=True)
    elapsed = time.perf_counter() - started
    report(outcomes, args.sites, elapsed, args.jobs)


def report(outcomes: list[Outcome], sites: int, elapsed_s: float, jobs: int) -> None:
    verdicts = collections.Counter(o.verdict for o in outcomes)
    print(f"\n{sites} sites x {len(DYNAMICS)} dynamics modes = {len(outcomes)} plans in "
          f"{elapsed_s:.0f} s ({elapsed_s * jobs / max(sites, 1):.1f} s of one core per site)")
    for dyn in DYNAMICS:
        c = collections.Counter(o.verdict for o in outcomes if o.dynamics == dyn)
        print(f"  --dynamics {dyn:<8} written {c['written']}, unsafe {c['unsafe']}, "
              f"refused {c['refused']}, crashes {c['crash']}")
    print(f"  total: written {verdicts['written']}, UNSAFE {verdicts['unsafe']}, "
          f"refused {verdicts['refused']}, CRASHES {verdicts['crash']}")
    by_gen: dict[str, collections.Counter[str]] = collections.defaultdict(collections.Counter)
    for o in outcomes:
        by_gen[o.site.rsplit("-", 1)[0]][o.verdict] += 1
    print("  by generator: " + "; ".join(
        f"{g} {dict(c)}" for g, c in sorted(by_gen.items())))
    refusals = collections.Counter(o.refusal for o in outcomes if o.verdict == "refused")
    if refusals:
        print("  refusals by class:")
        for cls, n in refusals.most_common():
            print(f"    {n:>4}  {cls}")
    written = [o for o in outcomes if o.verdict in ("written", "unsafe")]
    legs = [o.leg_margin_m for o in written if math.isfinite(o.leg_margin_m)]
    flown = [o.replay_clearance_m for o in written if math.isfinite(o.replay_clearance_m)]
    if legs:
        print(f"  worst planned leg: {min(legs) + 0.0:+.4f} m beyond radius + buffer - 1 cm")
    if flown:
        print(f"  worst replayed track: {min(flown):+.3f} m from the published radius")
    for o in outcomes:
        if o.verdict == "crash":
            print(f"  crash {o.site} ({o.dynamics}): {o.refusal}")
            print("\n".join("      " + line for line in o.detail))


if __name__ == "__main__":
    main()
