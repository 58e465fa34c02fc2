"""Upload with read-back over a bad link: how many uploads verify, how many fail cleanly, and
whether any reports a mission the vehicle does not hold, at 5, 10, 20 and 30 % packet loss.

Run by hand (figures, not pass/fail)::

    .venv/bin/python benchmarks/bench_lossy_link.py                   # real ArduCopter SITL
    .venv/bin/python benchmarks/bench_lossy_link.py --rates 0.2 --tries 20
    .venv/bin/python benchmarks/bench_lossy_link.py --builtin         # the built-in vehicle

The plan is ``samples/realistic.yaml`` planned by ``plan-mission`` (its ``.plan`` and
``.param``, as a user makes them). The vehicle is ArduCopter SITL (``--sitl-binary``, else
``$ARDUPILOT_SITL``, else ``/opt/sitl/arducopter``), one instance for all tries, at speed-up 1,
or with ``--builtin`` the project's simulated vehicle. Between the tool and the vehicle runs
:class:`validator.mavlink.lossy_relay.LossyRelay` with ``LinkFaults.lossy(rate)``: the rate of
packets dropped each way, a quarter as many duplicated and as many reordered, up to 50 ms of
delay; try ``k`` uses seed ``k``. Each try is one ``upload_plan`` (mission, fence, rally, the
``.param``, then every list read back). After each try the lists are read again over a clean
link: an upload reported as verified whose lists the vehicle does not hold is a FALSE
SUCCESS (there must be none). Before each try the vehicle's lists are cleared, so a verified
upload cannot lean on the previous one.

Prints one line per try, then the table: rate, tries, verified, failed (one-line error),
false successes, median and largest wall seconds of a verified upload.
"""

from __future__ import annotations

import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from validator.autopilot.param_file import read_params
from validator.errors import CommandParser
from validator.mavlink.link import Link, LinkError, upload_plan, verify_lists
from validator.mavlink.lossy_relay import LinkFaults, LossyRelay
from validator.mavlink.wire import MissionType, plan_to_wire
from validator.plan_format import Plan, read_plan

REPO = Path(__file__).resolve().parents[1]
DOCUMENTED_SITL = Path("/opt/sitl/arducopter")


def planned(tmp: Path) -> tuple[Plan, dict[str, float]]:
    exe = shutil.which("plan-mission", path=str(Path(sys.executable).parent)) or "plan-mission"
    out = tmp / "realistic.plan"
    subprocess.run([exe, str(REPO / "samples" / "realistic.yaml"), "-o", str(out)], check=True,
                   capture_output=True)
    return read_plan(out), read_params(out.with_suffix(".param"))


@contextmanager
def vehicle(plan: Plan, builtin: bool, binary: str | None) -> Iterator[str]:
    home = (plan.home_lat_deg, plan.home_lon_deg, plan.home_alt_m)
    if builtin:
        from validator.mavlink.sim import SitlVehicle, VehicleConfig

        v = SitlVehicle("udpin:127.0.0.1:0", VehicleConfig(home=home)).start()
        try:
            yield f"udpout:127.0.0.1:{v.address[1]}"
        finally:
            v.stop()
        return
    from validator.mavlink.driver import wait_until_ready
    from validator.mavlink.sitl_process import ardupilot_sitl, find_defaults

    path = Path(binary or os.environ.get("ARDUPILOT_SITL") or DOCUMENTED_SITL)
    with ardupilot_sitl(path, home, speedup=1.0, defaults=find_defaults(path)) as url:
        with Link(url, timeout_s=30) as link:
            wait_until_ready(link)  # a booting vehicle refuses missions: not what is measured
        yield url


def clear(url: str) -> None:
    """Empty all three lists over the clean link (MISSION_CLEAR_ALL, per type)."""
    with Link(url, timeout_s=10) as link:
        ts, tc = link.target
        for mtype in MissionType:
            for msg in link.exchange(
                    lambda m=int(mtype): link.mav.mission_clear_all_send(ts, tc, m),
                    ["MISSION_ACK"], lambda a, m=int(mtype): a.mission_type == m):
                if msg is not None:
                    break


def holds(url: str, plan: Plan) -> bool:
    """Whether the vehicle holds the plan's three lists, read over the clean link."""
    with Link(url, timeout_s=10) as link:
        try:
            verify_lists(link, plan_to_wire(plan, home_item=link.vehicle.is_ardupilot))
        except LinkError:
            return False
    return True


def main() -> None:
    parser = CommandParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rates", type=float, nargs="+", default=[0.05, 0.1, 0.2, 0.3])
    parser.add_argument("--tries", type=int, default=5, help="uploads per rate (default 5)")
    parser.add_argument("--timeout", type=float, default=10.0, help="upload --timeout, s")
    parser.add_argument("--builtin", action="store_true", help="the built-in vehicle")
    parser.add_argument("--sitl-binary", help="ArduCopter SITL binary")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        plan, params = planned(Path(tmp))
    counts = {t.label: len(plan_to_wire(plan, home_item=True).of(t)) for t in MissionType}
    print(f"plan: samples/realistic.yaml by plan-mission, {counts} items, {len(params)} "
          f"parameters; vehicle: {'built-in' if args.builtin else 'ArduCopter SITL'}")
    rows = []
    with vehicle(plan, args.builtin, args.sitl_binary) as url:
        for rate in args.rates:
            ok: list[float] = []
            failed = false = 0
            for seed in range(args.tries):
                clear(url)
                with LossyRelay(url, LinkFaults.lossy(rate), seed=seed,
                                duration_s=10 * args.timeout + 300) as relay:
                    t0 = time.monotonic()
                    try:
                        upload_plan(plan, relay.url, timeout_s=args.timeout, params=params)
                        verdict = "verified"
                    except LinkError as err:
                        verdict = f"failed: {err}"
                    wall_s = time.monotonic() - t0
                    down, up = relay.stats
                if verdict == "verified":
                    if holds(url, plan):
                        ok.append(wall_s)
                    else:
                        false += 1
                        verdict = "FALSE SUCCESS: the vehicle does not hold the plan"
                else:
                    failed += 1
                print(f"  loss {rate:.0%} seed {seed}: {verdict} ({wall_s:.1f} s; dropped "
                      f"{down.dropped}/{down.passed + down.dropped} up, "
                      f"{up.dropped}/{up.passed + up.dropped} down)", flush=True)
            rows.append((rate, args.tries, len(ok), failed, false,
                         statistics.median(ok) if ok else float("nan"),
                         max(ok) if ok else float("nan")))
    print()
    print("| loss each way | tries | verified | failed (one line) | false success "
          "| median s | max s |")
    print("|---|---|---|---|---|---|---|")
    for rate, n, good, bad, false_n, med, worst in rows:
        print(f"| {rate:.0%} | {n} | {good} | {bad} | {false_n} | {med:.1f} | {worst:.1f} |")


if __name__ == "__main__":
    main()
