"""Trial specs, trial rows, the Fig. 4 design and its statistics (no solver runs here)."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import pytest

from mission_planner.study.config import Fig4Config, trial_seed
from mission_planner.study.fig4 import missing_points, summarize
from mission_planner.study.stats import mean_interval, proportion_interval
from mission_planner.study.trials import TABLE_COLUMNS, TrialSpec, is_failed, run_trial
from validator.errors import InputError


def test_spec_key_does_not_depend_on_int_or_float_parameters() -> None:
    a = TrialSpec(seed=3, scheme="proposed", radius_m=30, buffer_m=0)
    b = TrialSpec(seed=3, scheme="proposed", radius_m=30.0, buffer_m=0.0)
    assert a == b and a.key == b.key


def test_spec_key_names_every_parameter() -> None:
    base = TrialSpec(seed=3, scheme="proposed")
    others = [
        TrialSpec(seed=4, scheme="proposed"),
        TrialSpec(seed=3, scheme="conventional"),
        TrialSpec(seed=3, scheme="proposed", num_gns=5),
        TrialSpec(seed=3, scheme="proposed", num_nfzs=4),
        TrialSpec(seed=3, scheme="proposed", radius_m=31.0),
        TrialSpec(seed=3, scheme="proposed", slots=51),
        TrialSpec(seed=3, scheme="proposed", buffer_m=1.0),
        TrialSpec(seed=3, scheme="proposed", area_m=500.0),
    ]
    assert len({base.key, *(o.key for o in others)}) == len(others) + 1


def test_a_site_that_cannot_be_made_is_a_failed_row_not_an_exception() -> None:
    row = run_trial(TrialSpec(seed=1, scheme="proposed", num_nfzs=10, radius_m=100.0))
    assert set(row) == set(TABLE_COLUMNS)
    assert is_failed(row)
    assert row["error"].startswith("InputError: num_nfzs")
    assert row["min_rate_bps_hz"] is None and row["outage"] is None


def test_trial_seeds_are_reproducible_and_distinct() -> None:
    seeds = [trial_seed(0, i) for i in range(1000)]
    assert seeds == [trial_seed(0, i) for i in range(1000)]
    assert len(set(seeds)) == 1000
    assert trial_seed(1, 0) not in seeds[:10]


def test_fig4_design_runs_the_shared_point_once_and_pairs_schemes() -> None:
    config = Fig4Config(trials=2, radii_m=(10.0, 30.0), counts=(1, 3))
    specs = config.specs()
    # (R=30, M=3) is in both sweeps: 2 trials x 3 distinct points x 2 schemes.
    assert len(specs) == 2 * 3 * 2 == len({s.key for s in specs})
    for seed in {s.seed for s in specs}:
        mine = [s for s in specs if s.seed == seed]
        assert sorted(s.scheme for s in mine) == ["conventional"] * 3 + ["proposed"] * 3


def test_fig4_design_takes_trials_outermost() -> None:
    specs = Fig4Config(trials=3).specs()
    seeds = [s.seed for s in specs]
    assert seeds == sorted(seeds, key=[trial_seed(0, i) for i in range(3)].index)


@pytest.mark.parametrize(
    ("change", "option"),
    [
        ({"trials": 0}, "--trials"),
        ({"radii_m": (10.0, -5.0)}, "--radii"),
        ({"radii_m": (10.0, 1e9)}, "--radii: a zone of radius 1e\\+09 m does not fit"),
        ({"radius_m": 200.0}, "--radius: a zone of radius 200 m does not fit"),
        ({"radii_m": (10.0, 190.0)}, "--radii: 3 zones of radius 190 m cannot lie apart"),
        ({"counts": (1, 50)}, "--counts: 50 zones of radius 30 m cannot lie apart"),
        ({"counts": (-1,)}, "--counts"),
        ({"slots": 1}, "--slots"),
        ({"slots": 3, "num_gns": 4}, "--slots: must be >= --gns"),
        ({"seed": -2}, "--seed"),
        ({"buffer_m": -1.0}, "--buffer-m"),
    ],
)
def test_bad_fig4_options_are_named(change: dict[str, Any], option: str) -> None:
    with pytest.raises(InputError, match=option):
        Fig4Config(**change).check()


def _rows(config: Fig4Config, scheme: str, results: list[tuple[float, bool] | None]
          ) -> list[dict[str, Any]]:
    out = []
    for i, res in enumerate(results):
        spec = config.spec(i, config.radius_m, config.num_nfzs, scheme)
        row: dict[str, Any] = {"key": spec.key, **spec.__dict__, "solve_seconds": 1.0}
        if res is None:
            row.update(error="SolverError: x", min_rate_bps_hz=None, outage=None,
                       spectral_efficiency_bps_hz=None)
        else:
            rate, outage = res
            row.update(error="", min_rate_bps_hz=rate, outage=outage,
                       spectral_efficiency_bps_hz=0.0 if outage else rate)
        out.append(row)
    return out


def test_summary_zeroes_outages_and_leaves_failures_out() -> None:
    config = Fig4Config(trials=4, radii_m=(30.0,), counts=(3,), slots=10)
    rows = _rows(config, "proposed", [(1.0, False), (2.0, False), (3.0, False), None]) + _rows(
        config, "conventional", [(2.0, True), (2.0, False), (4.0, True), (1.0, False)]
    )
    summary = {(r["sweep"], r["scheme"]): r for r in summarize(rows, config)}
    prop, conv = summary[("radius", "proposed")], summary[("radius", "conventional")]
    assert (prop["trials"], prop["failed"], prop["outages"]) == (4, 1, 0)
    assert prop["spectral_efficiency_bps_hz"] == pytest.approx(2.0)
    assert conv["outage_probability"] == pytest.approx(0.5)
    assert conv["spectral_efficiency_bps_hz"] == pytest.approx(0.75)
    assert conv["min_rate_bps_hz"] == pytest.approx(2.25)
    assert summary[("count", "conventional")]["outages"] == 2


def test_a_point_whose_every_trial_failed_is_missing_and_one_that_kept_some_is_not() -> None:
    config = Fig4Config(trials=2, radii_m=(30.0, 40.0, 50.0), counts=(3,), slots=10)
    at_40, at_50 = replace(config, radius_m=40.0), replace(config, radius_m=50.0)
    rows = (_rows(config, "proposed", [None, (1.0, False)])  # one trial left: a result
            + _rows(config, "conventional", [None, None])  # none: a hole in its curve
            + _rows(at_40, "proposed", [None, None]) + _rows(at_40, "conventional", [None, None])
            + _rows(at_50, "proposed", [(1.0, False)] * 2)
            + _rows(at_50, "conventional", [(1.0, True)] * 2))  # every trial an outage
    # the 30 m, 3-zone point is in both sweeps, so both figures have its hole
    assert missing_points(rows, config) == [
        ("radius sweep R=30 m (conventional)", "SolverError: x"),
        ("radius sweep R=40 m", "SolverError: x"),
        ("count sweep M=3 (conventional)", "SolverError: x"),
    ]
    kept = (_rows(config, "proposed", [None, (1.0, False)])
            + _rows(config, "conventional", [(1.0, True), None]))
    assert missing_points(kept, replace(config, radii_m=(30.0,))) == []


def test_wilson_interval_of_no_outages_is_not_a_point() -> None:
    low, high = proportion_interval(0, 20)
    assert low == 0.0 and 0.0 < high < 0.25


def test_proportion_interval_contains_the_estimate() -> None:
    low, high = proportion_interval(7, 20)
    assert low < 0.35 < high


def test_mean_interval_narrows_with_more_values() -> None:
    few = mean_interval([1.0, 2.0, 3.0])
    many = mean_interval([1.0, 2.0, 3.0] * 10)
    assert few[0] < 2.0 < few[1]
    assert many[1] - many[0] < few[1] - few[0]


def test_mean_interval_of_one_value_is_undefined() -> None:
    assert all(math.isnan(v) for v in mean_interval([1.0]))
