"""One Monte-Carlo trial: a random site, one scheme, one planner run, one table row.

A trial is named by a :class:`TrialSpec` (the seed and parameters of :func:`random_site` plus the
scheme). :func:`run_trial` never raises for a failure of the site or the planner: the row then
carries the error, so a study keeps every trial it was asked for.

Outage (the paper's section IV): some straight leg q[n-1]→q[n] of the planned cycle enters an
NFZ *as published* (safety buffer not counted). The spectral efficiency of a trial is its
minimum average rate over the GNs, set to zero on outage.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

from mission_planner.study.sites import PAPER_AREA_M, random_site

if TYPE_CHECKING:
    from mission_planner.optimize import PlannerOptions

# Columns of the trial table, in order. Every column but ``solve_seconds`` (wall time) is a
# function of the spec and the planner options alone.
SPEC_COLUMNS = ("seed", "scheme", "num_gns", "num_nfzs", "radius_m", "slots", "buffer_m", "area_m")
RESULT_COLUMNS = (
    "min_rate_bps_hz",
    "spectral_efficiency_bps_hz",
    "nfz_clearance_min_m",
    "outage",
    "iterations",
    "solve_seconds",
    "error",
)
TABLE_COLUMNS = ("key", *SPEC_COLUMNS, *RESULT_COLUMNS)
# A study record: one flat row of a trial log (a JSON line) and of its table, by column.
Cell = str | int | float | bool | None
Row = dict[str, Cell]


def cell_float(value: Cell) -> float:
    """A numeric cell as a float; an empty one (None, "": a failed trial's result) as NaN."""
    if value is None or value == "":
        return math.nan
    if isinstance(value, str):
        raise ValueError(f"expected a number, got {value!r}")
    return float(value)
WALL_TIME_COLUMNS = ("solve_seconds",)


@dataclass(frozen=True)
class TrialSpec:
    """A trial: ``random_site(seed, ...)`` with these parameters, planned with ``scheme``."""

    seed: int
    scheme: str
    num_gns: int = 4
    num_nfzs: int = 3
    radius_m: float = 30.0
    slots: int = 50
    buffer_m: float = 0.0
    area_m: float = PAPER_AREA_M

    def __post_init__(self) -> None:
        # 30 and 30.0 must name the same trial (and the same table cell).
        for name in ("seed", "num_gns", "num_nfzs", "slots"):
            object.__setattr__(self, name, int(getattr(self, name)))
        for name in ("radius_m", "buffer_m", "area_m"):
            object.__setattr__(self, name, float(getattr(self, name)))
        object.__setattr__(self, "scheme", str(self.scheme))

    @property
    def key(self) -> str:
        """A stable text id; a study directory remembers finished trials by it."""
        return (
            f"{self.scheme}/seed={self.seed}/K={self.num_gns}/M={self.num_nfzs}"
            f"/R={self.radius_m!r}/N={self.slots}/buffer={self.buffer_m!r}/area={self.area_m!r}"
        )


def _one_line(err: BaseException) -> str:
    text = " ".join(str(err).split())
    return f"{type(err).__name__}: {text}" if text else type(err).__name__


def run_trial(spec: TrialSpec, options: PlannerOptions | None = None) -> Row:
    """Run one trial and return its table row (keys :data:`TABLE_COLUMNS`).

    ``options`` is a :class:`mission_planner.optimize.PlannerOptions` (None: the paper's
    model, :data:`~mission_planner.optimize.PAPER_OPTIONS`).
    A failure (bad parameters, solver error) is returned as a row whose ``error`` is a one-line
    message and whose result columns are None. Units: rates in bps/Hz, clearance in metres
    (negative: the leg enters the zone), ``solve_seconds`` the wall time of the planner.
    """
    from mission_planner.optimize import PAPER_OPTIONS, plan

    options = options if options is not None else PAPER_OPTIONS
    row: Row = {"key": spec.key, **asdict(spec)}
    row.update(dict.fromkeys(RESULT_COLUMNS))
    row["error"] = ""
    start = time.perf_counter()
    try:
        site = random_site(
            spec.seed,
            num_gns=spec.num_gns,
            num_nfzs=spec.num_nfzs,
            radius_m=spec.radius_m,
            slots=spec.slots,
            area_m=spec.area_m,
            buffer_m=spec.buffer_m,
        )
        solution = plan(site, scheme=spec.scheme, options=options)
        clearance = solution.nfz_clearance_min_m
        min_rate = solution.min_rate_bps_hz
        outage = bool(clearance < 0.0)
        row.update(
            min_rate_bps_hz=min_rate,
            spectral_efficiency_bps_hz=0.0 if outage else min_rate,
            nfz_clearance_min_m=clearance,
            outage=outage,
            iterations=int(solution.iterations),
        )
    except Exception as err:  # a failed trial is a result, not the end of the study
        row["error"] = _one_line(err)
    row["solve_seconds"] = time.perf_counter() - start
    return row


@dataclass(frozen=True)
class PartialPoint:
    """A sweep point that lost some of its trials, not all: it keeps a result, averaged over
    the trials left, which may lean to the easier sites (those the planner did not fail on).
    ``trials`` the point's trials run, ``failed`` those that failed, ``error`` the first
    one's (in trial order); ``by_scheme``: (scheme, failed, trials) of each scheme that lost
    some, when the point runs its sites under more than one (Fig. 4), the totals theirs."""

    point: str
    trials: int
    failed: int
    error: str
    by_scheme: tuple[tuple[str, int, int], ...] = ()

    def warning(self) -> str:
        """One line for stderr: ``radius sweep R=90 m: 1 of 2 trials failed under proposed,
        1 of 2 under conventional; ...``."""
        lost = (", ".join(f"{f} of {n}" + (" trials failed" if i == 0 else "") + f" under {s}"
                          for i, (s, f, n) in enumerate(self.by_scheme))
                or f"{self.failed} of {self.trials} trials failed")
        return (f"{self.point}: {lost}; its result averages the trials left "
                f"(first: {self.error})")


def is_failed(row: Row) -> bool:
    """True when the trial ended in an error (its result columns are empty)."""
    return bool(row.get("error"))
