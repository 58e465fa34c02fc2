"""Golden files: the same plans, parameter files and reports come out as before.

For the sample sites and a few benchmark sites, planned as ``plan-mission`` plans them
(the front door: :func:`mission_planner.api.plan_mission`, :func:`~mission_planner.api.
write_mission`) with
``--dynamics none`` and ``--dynamics vehicle`` and exported with a few option sets, the
written ``.plan``, ``.param`` and report JSON are compared with the files stored under
``tests/golden/<case>/`` (the ``.plan`` and ``.param`` as written; the report without the keys
in :data:`REPORT_LEFT_OUT`). The ``.waypoints`` export of each case is read back and compared
with the stored ``.plan`` as well (the same items, fence and rally).

Regenerate after an intended change, and review the diff like code::

    UPDATE_GOLDEN=1 .venv/bin/python -m pytest -q tests/test_golden.py

Each site is planned in a child process with numpy's and OpenBLAS's x86 kernels held to
x86-64-v3 (AVX2, :data:`REFERENCE_NUMERICS`). Repeated runs on one machine agree bit for bit,
but across CPUs the last bits of numpy's AVX-512 ``log``/``exp`` and of OpenBLAS's AVX-512
kernels differ, and 30 iterations of a non-convex descent amplify them into another local
optimum: on an AVX-512 machine the sample's ``--dynamics none`` plan moved by metres and its
min rate by -0.3 % (2.3558 -> 2.3482 bps/Hz), far beyond any tolerance below. Held to AVX2
kernels, an AVX-512 machine reproduces the files written on an AVX2 one bit for bit. Other
architectures (aarch64) have other kernels and skip the test.

Tolerances: a difference beyond them is a change a vehicle or a reader of the report would
notice. Another solver or BLAS build may move a solution by more than solver noise, and a
``--dynamics vehicle`` plan whose speed search sits on an edge could pick another candidate
speed (README, *The optimiser*): regenerate then, and say so.

- coordinates ``*_deg``: 3e-7° (three steps of MAVLink's int32 1e-7°, about 3 cm);
- lengths, positions, radii, clearances ``*_m``: 1 cm;
- holds and durations ``*_s``: 1 ms (ArduPilot holds are whole seconds, so a hold that moves
  by a second fails);
- everything else that is a real number (speeds, rates, powers, ratios, parameter values):
  1e-4 relative (plus 1e-9 absolute, for values that should be 0);
- counts, commands, frames, flags, names and messages: exactly.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import platform
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from mission_planner.api import (
    Mission,
    MissionOptions,
    build_mission,
    plan_mission,
    recommended_params,
    replay_mission,
    write_mission,
)
from mission_planner.study.sites import random_site
from validator.autopilot.param_file import parse_params
from validator.plan_format import Cmd, Plan, loads_plan
from validator.site import Site, load_site
from validator.waypoints_format import read_waypoints

REPO = Path(__file__).resolve().parents[1]
GOLDEN = Path(__file__).resolve().parent / "golden"
UPDATE = os.environ.get("UPDATE_GOLDEN") == "1"

# Report keys not compared: wall-clock time, the optimiser's path to its result, and the
# solution arrays the .plan already carries (nfzMission).
REPORT_LEFT_OUT = ("solve_seconds", "history", "trajectory_m", "delta_s", "power_w", "schedule")

# numpy's dispatch groups above AVX2 switched off, OpenBLAS on its Haswell (AVX2) kernels; names
# a CPU lacks are ignored. Read when numpy loads, so only a fresh process can be held to them.
REFERENCE_NUMERICS = {"NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
                      "OPENBLAS_CORETYPE": "Haswell"}

ABS_TOL = {"deg": 3e-7, "m": 0.01, "s": 1e-3}  # by the unit a key name ends in
REL_TOL = 1e-4
TINY = 1e-9


def _site(name: str) -> Site:
    if name in ("paper-default", "realistic"):
        return load_site(REPO / "samples" / f"{name}.yaml")
    if name == "random0":  # benchmarks/bench_dynamics.py and bench_safety.py: random_site(0)
        return random_site(0, buffer_m=2.0)
    if name == "realistic1":  # bench_dynamics.py --realistic: realistic_site(1)
        return random_site(1, buffer_m=3.0, max_speed_mps=9.4, period_s=231.0, slots=64)
    raise KeyError(name)


VARIANTS = {
    "": MissionOptions(),  # plan-mission's defaults
    "px4-polygon-3cycles": MissionOptions(autopilot="px4", cycles=3, operating_area="polygon"),
    "circle-2cycles-nomerge": MissionOptions(cycles=2, operating_area="circle", merge_legs=False),
}


@dataclass(frozen=True)
class Case:
    site: str
    dynamics: str
    variant: str = ""

    @property
    def name(self) -> str:
        return "-".join(p for p in (self.site, self.dynamics, self.variant) if p)


# (site, dynamics, autopilot) -> the option sets its one solution is exported with. One test
# per solution, so each site is planned once (the slow part). A dynamics-aware plan is timed
# for its autopilot (as plan-mission --autopilot does), so its variants share that autopilot.
PLANS = {
    ("paper-default", "none", "ardupilot"): ("", "px4-polygon-3cycles"),
    ("paper-default", "vehicle", "ardupilot"): ("", "circle-2cycles-nomerge"),
    ("realistic", "none", "ardupilot"): ("",),
    ("realistic", "vehicle", "ardupilot"): ("",),
    ("realistic", "vehicle", "px4"): ("px4-polygon-3cycles",),
    ("random0", "none", "ardupilot"): ("", "circle-2cycles-nomerge"),
    ("realistic1", "none", "ardupilot"): ("",),
    ("realistic1", "vehicle", "ardupilot"): ("",),
}


def _write_outputs(case: Case, mission: Mission, folder: Path, fmt: str = "plan") -> None:
    """Write what plan-mission writes for ``case`` (mission, parameter file, report) into
    ``folder``, through the front door."""
    mission = dataclasses.replace(build_mission(mission.solution, VARIANTS[case.variant]),
                                  position_loss_berth=mission.position_loss_berth)
    params = recommended_params(mission)
    write_mission(mission, folder / f"mission.{fmt}", fmt=fmt, report=folder / "report.json",
                  params=folder / "mission.param", autopilot_params=params,
                  flight=replay_mission(mission, params), force=True)


# ---------------------------------------------------------------------------- comparison


def _unit(key: str) -> str | None:
    suffix = key.rpartition("_")[2]
    return suffix if suffix in ABS_TOL else None


def differences(golden: Any, new: Any, path: str = "", unit: str | None = None) -> Iterator[str]:
    """Every difference beyond the tolerances between two JSON-like trees, one line each.

    A value's unit is the suffix of the nearest enclosing key that has one (``_deg``, ``_m``,
    ``_s``), so the points of ``trajectory_m`` are compared in metres.
    """
    if isinstance(golden, dict) and isinstance(new, dict):
        if list(golden) != list(new):
            yield f"{path}: keys {list(golden)} != {list(new)}"
            return
        for k in golden:
            yield from differences(golden[k], new[k], f"{path}.{k}" if path else k,
                                   _unit(k) or unit)
    elif isinstance(golden, list) and isinstance(new, list):
        if len(golden) != len(new):
            yield f"{path}: {len(golden)} entries != {len(new)}"
            return
        for i, (a, b) in enumerate(zip(golden, new, strict=True)):
            yield from differences(a, b, f"{path}[{i}]", unit)
    elif (isinstance(golden, float) and isinstance(new, float | int)
          and not isinstance(new, bool)):
        a, b = golden, float(new)
        if math.isnan(a) or math.isnan(b):
            if math.isnan(a) != math.isnan(b):
                yield f"{path}: {a!r} != {b!r}"
            return
        tol = ABS_TOL[unit] if unit else max(TINY, REL_TOL * abs(a))
        if not abs(a - b) <= tol:
            yield f"{path}: {a!r} != {b!r} (tolerance {tol:g}{' ' + unit if unit else ''})"
    elif type(golden) is not type(new) or golden != new:
        yield f"{path}: {golden!r} != {new!r}"


# Mission-item parameters (0-based index) named by what they mean, so they get their unit.
_PARAM_NAMES = {(int(Cmd.NAV_WAYPOINT), 0): "hold_s", (int(Cmd.DO_CHANGE_SPEED), 1): "speed_mps"}


def plan_view(plan: Plan, *, with_metadata: bool = True) -> dict[str, Any]:
    """What a plan tells the vehicle, with units in the names: home, items, fence, rally (and
    the file-level settings and planner metadata unless ``with_metadata`` is False)."""
    items = []
    for it in plan.items:
        view: dict[str, Any] = {"command": it.command, "frame": it.frame,
                                "autocontinue": it.autocontinue}
        for k in range(4):
            view[_PARAM_NAMES.get((it.command, k), f"param{k + 1}")] = float(it.params[k])
        view.update(lat_deg=float(it.lat_deg), lon_deg=float(it.lon_deg), alt_m=float(it.alt_m))
        items.append(view)

    def point(p: tuple[float, float, float] | None) -> dict[str, float] | None:
        return None if p is None else {"lat_deg": p[0], "lon_deg": p[1], "alt_m": p[2]}

    out: dict[str, Any] = {
        "home": {"lat_deg": plan.home_lat_deg, "lon_deg": plan.home_lon_deg,
                 "alt_m": plan.home_alt_m},
        "items": items,
        "circles": [{"lat_deg": c.lat_deg, "lon_deg": c.lon_deg, "radius_m": c.radius_m,
                     "inclusion": c.inclusion} for c in plan.circles],
        "polygons": [{"vertices_deg": [list(v) for v in p.vertices_deg],
                      "inclusion": p.inclusion} for p in plan.polygons],
        "rally": [point(p) for p in plan.rally],
        "breach_return": point(plan.breach_return),
    }
    if with_metadata:
        out.update(firmware_type=plan.firmware_type, vehicle_type=plan.vehicle_type,
                   cruise_speed_mps=plan.cruise_speed_mps, hover_speed_mps=plan.hover_speed_mps,
                   extra=plan.extra)
    return out


def _report_view(text: str | bytes) -> dict[str, Any]:
    return {k: v for k, v in json.loads(text).items() if k not in REPORT_LEFT_OUT}


def _params_view(text: str | bytes) -> dict[str, Any]:
    # A list of pairs: the order is part of the file (FENCE_ENABLE last).
    values = parse_params(text if isinstance(text, str) else text.decode())
    return {"params": [[name, value] for name, value in values.items()]}


def _nan_as_zero(tree: Any) -> Any:
    """``tree`` as a .waypoints file keeps it: a NaN parameter is written as 0."""
    if isinstance(tree, dict):
        return {k: _nan_as_zero(v) for k, v in tree.items()}
    if isinstance(tree, list):
        return [_nan_as_zero(v) for v in tree]
    return 0.0 if isinstance(tree, float) and math.isnan(tree) else tree


# ---------------------------------------------------------------------------- the test


def write_plans(site: str, dynamics: str, autopilot: str, out: Path) -> None:
    """Plan ``site`` once and write each of its variants' files into ``out/<case name>/``: the
    ``.plan`` outputs, and the ``.waypoints`` ones in ``wpl/`` beside them."""
    planned = plan_mission(_site(site), "proposed", MissionOptions(autopilot=autopilot),
                           dynamics=dynamics)
    for variant in PLANS[site, dynamics, autopilot]:
        assert (VARIANTS[variant].autopilot == autopilot) or dynamics == "none"
        case = Case(site, dynamics, variant)
        for fmt, folder in (("plan", out / case.name), ("waypoints", out / case.name / "wpl")):
            folder.mkdir(parents=True)
            _write_outputs(case, planned, folder, fmt)


def _written_with_reference_numerics(key: tuple[str, str, str], out: Path) -> None:
    child = ("import sys; from pathlib import Path; from tests.test_golden import write_plans; "
             "write_plans(*sys.argv[1:4], Path(sys.argv[4]))")
    env = {**os.environ, **REFERENCE_NUMERICS}
    done = subprocess.run([sys.executable, "-c", child, *key, str(out)], cwd=REPO, env=env,
                          capture_output=True, text=True, check=False)
    assert done.returncode == 0, f"planning {key} failed:\n{done.stderr[-3000:]}"


def _case_differences(case: Case, written: Path) -> list[str]:
    folder = GOLDEN / case.name
    files = {p.name: p.read_text(encoding="utf-8") for p in written.iterdir() if p.is_file()}
    assert sorted(files) == ["mission.param", "mission.plan", "report.json"]
    files["report.json"] = json.dumps(_report_view(files["report.json"]), indent=1) + "\n"
    if UPDATE:
        folder.mkdir(parents=True, exist_ok=True)
        for name, text in files.items():
            (folder / name).write_text(text, encoding="utf-8")
    golden = {name: (folder / name).read_text(encoding="utf-8") for name in files}

    golden_plan = loads_plan(golden["mission.plan"], "golden")
    found = [f"mission.plan: {d}" for d in differences(
        plan_view(golden_plan), plan_view(loads_plan(files["mission.plan"], "new")))]
    found += [f"mission.param: {d}" for d in differences(
        _params_view(golden["mission.param"]), _params_view(files["mission.param"]))]
    found += [f"report.json: {d}" for d in differences(
        json.loads(golden["report.json"]), json.loads(files["report.json"]))]
    # The same mission as QGC WPL 110 files, read back: the same items, fence and rally.
    found += [f"mission.waypoints: {d}" for d in differences(
        _nan_as_zero(plan_view(golden_plan, with_metadata=False)),
        plan_view(read_waypoints(written / "wpl" / "mission.waypoints"), with_metadata=False))]
    return [f"tests/golden/{case.name}: {d}" for d in found]


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"),
                    reason="the golden files hold x86-64 numerics (AVX2 kernels); "
                           f"this is {platform.machine()}")
@pytest.mark.parametrize(("site", "dynamics", "autopilot"),
                         [pytest.param(*key, id="-".join(key)) for key in PLANS])
def test_outputs_match_the_golden_files(site: str, dynamics: str, autopilot: str,
                                        tmp_path: Path) -> None:
    _written_with_reference_numerics((site, dynamics, autopilot), tmp_path)
    found: list[str] = []
    for variant in PLANS[site, dynamics, autopilot]:
        case = Case(site, dynamics, variant)
        found += _case_differences(case, tmp_path / case.name)
    assert not found, "differs from the golden files:\n" + "\n".join(found[:40])


def test_the_comparison_sees_a_change_beyond_each_tolerance() -> None:
    golden = {"lat_deg": 37.5, "radius_m": 31.0, "hold_s": 4.0, "speed_mps": 7.0, "n": 3,
              "trajectory_m": [[1.0, 2.0]], "name": "GN1", "x": float("nan")}
    same = {"lat_deg": 37.5 + 2e-7, "radius_m": 31.009, "hold_s": 4.0005, "speed_mps": 7.0006,
            "n": 3, "trajectory_m": [[1.009, 2.0]], "name": "GN1", "x": float("nan")}
    assert list(differences(golden, same)) == []
    moved = {"lat_deg": 37.5 + 4e-7, "radius_m": 31.02, "hold_s": 5.0, "speed_mps": 7.001,
             "n": 4, "trajectory_m": [[1.0, 2.02]], "name": "GN2", "x": 0.0}
    assert [d.split(":")[0] for d in differences(golden, moved)] == [
        "lat_deg", "radius_m", "hold_s", "speed_mps", "n", "trajectory_m[0][1]", "name", "x"]
    assert list(differences({"a": 1.0}, {"b": 1.0})) == [": keys ['a'] != ['b']"]
