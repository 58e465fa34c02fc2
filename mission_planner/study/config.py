"""What a Fig. 4 study runs: its options (the paper's by default), its points and trials."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mission_planner.optimize.solution import SCHEMES as PLANNER_SCHEMES
from mission_planner.study.sites import PAPER_AREA_M, check_zone_fits, check_zones_pack
from mission_planner.study.trials import TrialSpec
from validator.errors import InputError

SCHEMES = ("proposed", "conventional")  # the paper's pair, compared by default


@dataclass(frozen=True)
class Fig4Config:
    """The parameters of a Fig. 4 study (the paper's values by default)."""

    trials: int = 100
    radii_m: tuple[float, ...] = (10.0, 20.0, 30.0, 40.0, 50.0)
    counts: tuple[int, ...] = (1, 2, 3, 4, 5)
    seed: int = 0
    slots: int = 50
    num_gns: int = 4
    radius_m: float = 30.0  # the radius of every zone in the count sweep
    num_nfzs: int = 3  # the zone count in the radius sweep
    buffer_m: float = 0.0
    area_m: float = PAPER_AREA_M
    schemes: tuple[str, ...] = field(default=SCHEMES)

    def check(self) -> None:
        """Raise :class:`InputError` naming the first bad option."""
        if self.trials < 1:
            raise InputError(f"--trials: must be >= 1, got {self.trials}")
        if not self.radii_m or any(not r > 0 for r in self.radii_m):
            raise InputError(f"--radii: need radii > 0 m, got {list(self.radii_m)}")
        if not self.counts or any(m < 0 for m in self.counts):
            raise InputError(f"--counts: need counts >= 0, got {list(self.counts)}")
        if self.seed < 0:
            raise InputError(f"--seed: must be >= 0, got {self.seed}")
        if self.slots < 2:
            raise InputError(f"--slots: must be >= 2, got {self.slots}")
        if self.num_gns < 1:
            raise InputError(f"--gns: must be >= 1, got {self.num_gns}")
        if self.slots < self.num_gns:  # one node per slot: the planner refuses fewer
            raise InputError(f"--slots: must be >= --gns ({self.num_gns}), got {self.slots}")
        if not self.radius_m > 0:
            raise InputError(f"--radius: must be > 0 m, got {self.radius_m}")
        for radius_m in self.radii_m:
            check_zone_fits(radius_m, self.area_m, "--radii")
        check_zone_fits(self.radius_m, self.area_m, "--radius")
        if self.num_nfzs < 0:
            raise InputError(f"--count: must be >= 0, got {self.num_nfzs}")
        # a point whose zones cannot lie apart in the square would fail every trial it runs
        for radius_m in self.radii_m:
            check_zones_pack(self.num_nfzs, radius_m, self.area_m, "--radii")
        for count in self.counts:
            check_zones_pack(count, self.radius_m, self.area_m, "--counts")
        if self.buffer_m < 0:
            raise InputError(f"--buffer-m: must be >= 0, got {self.buffer_m}")
        for s in self.schemes:
            if s not in PLANNER_SCHEMES:
                raise InputError(f"schemes: unknown scheme {s!r} "
                                 f"(expected {', '.join(PLANNER_SCHEMES)})")

    def points(self) -> list[tuple[str, float, int]]:
        """(sweep, radius_m, num_nfzs) of every point, radius sweep first."""
        return [("radius", float(r), self.num_nfzs) for r in self.radii_m] + [
            ("count", float(self.radius_m), int(m)) for m in self.counts
        ]

    def spec(self, index: int, radius_m: float, num_nfzs: int, scheme: str) -> TrialSpec:
        """Trial ``index`` of the point (``radius_m``, ``num_nfzs``) under ``scheme``."""
        return TrialSpec(seed=trial_seed(self.seed, index), scheme=scheme, num_gns=self.num_gns,
                         num_nfzs=num_nfzs, radius_m=radius_m, slots=self.slots,
                         buffer_m=self.buffer_m, area_m=self.area_m)

    def specs(self) -> list[TrialSpec]:
        """Every trial, trial index outermost so an interrupted study covers all points evenly."""
        out = [
            self.spec(i, radius, count, scheme)
            for i in range(self.trials)
            for _, radius, count in self.points()
            for scheme in self.schemes
        ]
        return list(dict.fromkeys(out))


def trial_seed(study_seed: int, index: int) -> int:
    """The site seed of trial ``index`` of a study: well mixed, reproducible, 32-bit."""
    return int(np.random.SeedSequence([study_seed, index]).generate_state(1, dtype=np.uint32)[0])
