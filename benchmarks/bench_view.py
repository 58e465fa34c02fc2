"""HTML view benchmark: what ``--html`` costs on top of planning, the file's size, and how fast
headless Chromium shows it.

Run by hand (figures, not pass/fail):  .venv/bin/python benchmarks/bench_view.py [--runs 5]

Prints, for the quick start's site (samples/realistic.yaml, default options):
- the median wall time of planning and export (``plan_and_build``, the replay), then of writing
  the view (``mission_view``: figure, frames, JSON, plotly.js inlined) on top of it.
  Target: the view in <= 1 s;
- the page's size (MB; plotly.js is about 4.8 MB of it);
- the median time headless Chromium takes from navigation until the plot and its slider
  frames are there, and the console errors it logged. Targets: <= 2 s, 0 errors
  (needs chromium and chromedriver: scripts/install-browser.sh).
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))  # tests.browser, run from anywhere

from mission_planner.autopilot_params import recommended_params  # noqa: E402
from mission_planner.flight_report import replay_mission  # noqa: E402
from mission_planner.pipeline import mission_view, plan_and_build  # noqa: E402
from tests.browser import WAIT_FOR_PLOT, chromium, find_browser  # noqa: E402
from validator.errors import CommandParser  # noqa: E402
from validator.site import load_site  # noqa: E402


def main() -> None:
    ap = CommandParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--site", type=Path, default=REPO / "samples/realistic.yaml")
    args = ap.parse_args()
    site = load_site(args.site)
    plan_s, view_s = [], []
    page = ""
    for _ in range(args.runs):
        t0 = time.perf_counter()
        mission = plan_and_build(site)
        flight = replay_mission(mission, recommended_params(mission))
        t1 = time.perf_counter()
        page = mission_view(mission, flight, "mission.plan")
        t2 = time.perf_counter()
        plan_s.append(t1 - t0)
        view_s.append(t2 - t1)
    print(f"{args.site.name}: planning + export {statistics.median(plan_s):.2f} s, "
          f"the view on top {statistics.median(view_s):.3f} s "
          f"(min {min(view_s):.3f}, max {max(view_s):.3f}; {args.runs} runs)")
    size = len(page.encode())
    print(f"page: {size / 1e6:.2f} MB")
    found = find_browser()
    if isinstance(found, str):
        print(f"browser: skipped, {found}")
        return
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "view.html"
        path.write_text(page, encoding="utf-8")
        loads, errors = [], 0
        with chromium(*found) as browser:
            for _ in range(args.runs):
                browser.get("about:blank")
                browser.get_log("browser")
                t0 = time.perf_counter()
                browser.get(path.as_uri())
                ok = browser.execute_async_script(WAIT_FOR_PLOT)
                loads.append(time.perf_counter() - t0)
                errors += sum(e["level"] == "SEVERE" for e in browser.get_log("browser"))
                if not ok:
                    print("browser: the plot never appeared")
                    return
    print(f"headless Chromium: loaded in {statistics.median(loads):.2f} s median "
          f"(min {min(loads):.2f}, max {max(loads):.2f}), {errors} console errors "
          f"over {args.runs} loads")


if __name__ == "__main__":
    main()
