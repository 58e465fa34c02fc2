"""Studies of the paper's claims: Fig. 3 (one site, both schemes) and Fig. 4 (Monte Carlo).

- ``sites``: :func:`random_site`, the seeded paper-style site generator (also used by benchmarks).
- ``trials``: one trial = (seed, parameters, scheme) -> one table row, errors included.
- ``executors``: :func:`~mission_planner.study.executors.run_trials` on local processes or Dask,
  resumable through ``store`` (the study directory's log, manifest and table files).
- ``fig3``, ``fig4``: the studies; ``stats``: confidence intervals; ``plots``: the figures.
- ``cli``: ``nfz-study``.
"""

from mission_planner.study.sites import random_site

__all__ = ["random_site"]
