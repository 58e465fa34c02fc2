"""Progress a person can read while a plan is made: one line on the terminal (tqdm), rewritten
in place, naming what runs: the candidate top speed of the vehicle search (k of at most n),
Algorithm 1's iteration within it, the objective and the time so far.

Algorithm 1 counts its iterations afresh for each candidate speed, so a bare iteration count
would run 10, 5, 15, 10 and read like a bug; the candidate beside it says why. Nothing is
shown when stderr is not a terminal (a log or a pipe gets the result lines only), nor with
``--quiet``. Studies show their trials with tqdm too (:mod:`.study.executors`).
"""

from __future__ import annotations

import sys
from typing import TextIO


class PlanProgress:
    """The planner's ``progress`` callback (:func:`mission_planner.optimize.plan`), drawn as one
    line. ``enabled`` None: only when ``file`` (default stderr) is a terminal. Close it (or use
    it as a context manager) to clear the line."""

    def __init__(self, prog: str = "plan-mission", *, enabled: bool | None = None,
                 file: TextIO | None = None) -> None:
        from tqdm import tqdm

        self.prog = prog
        self.stage = ""
        self._bar = tqdm(total=None, bar_format="{desc} ({elapsed})", leave=False,
                         file=file or sys.stderr,
                         disable=None if enabled is None else not enabled)

    @property
    def shown(self) -> bool:
        return not self._bar.disable

    def candidate(self, number: int, most: int, speed_mps: float) -> None:
        """The vehicle search starts candidate ``number`` (of at most ``most``) at this top
        speed (:class:`mission_planner.optimize.flyable.SearchProgress`)."""
        self.stage = f"candidate {number} of at most {most} (top speed {speed_mps:.2f} m/s), "
        self._show(f"{self.stage}starting")

    def __call__(self, iteration: int, objective: float) -> None:
        self._show(f"{self.stage}iteration {iteration}, objective {objective:.6g}")

    def _show(self, text: str) -> None:
        self._bar.set_description_str(f"{self.prog}: {text}", refresh=True)

    def close(self) -> None:
        self._bar.close()

    def __enter__(self) -> PlanProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
