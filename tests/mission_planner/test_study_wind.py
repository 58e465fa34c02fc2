"""nfz-study wind: the sweep's trials, its table and figure, and its refusals."""

from __future__ import annotations

import csv
import json
from dataclasses import replace

import pytest

from mission_planner.study.cli import main
from mission_planner.study.store import LOG_NAME
from mission_planner.study.wind import WIND_COLUMNS, missing_points, run_wind_trial, wind_specs
from validator.errors import InputError
from validator.site import load_site

SAMPLE = "samples/realistic.yaml"


def test_specs_run_still_air_once() -> None:
    specs = wind_specs(load_site(SAMPLE), (0.0, 5.0), (0.0, 90.0, 450.0 - 360.0), 1.0)
    assert [(s.speed_mps, s.from_deg, s.turbulence_mps) for s in specs] == [
        (0.0, 0.0, 0.0), (5.0, 0.0, 1.0), (5.0, 90.0, 1.0)]
    assert len({s.key for s in specs}) == 3


@pytest.mark.parametrize("args,msg", [
    (((-1.0,), (0.0,)), "--speeds"), (((1.0,), (400.0,)), "--directions"),
])
def test_specs_refuse_bad_figures(args, msg) -> None:
    with pytest.raises(InputError, match=msg):
        wind_specs(load_site(SAMPLE), *args)


def test_a_wind_beyond_the_vehicle_is_a_failed_row_not_a_crash() -> None:
    """The study refuses such a wind before any trial; a spec made by hand still gives a row."""
    (calm,) = wind_specs(load_site(SAMPLE), (0.0,), (45.0,))
    row = run_wind_trial(replace(calm, speed_mps=12.0, from_deg=45.0))
    assert "top airspeed" in row["error"] and row["flown_min_rate_bps_hz"] is None


@pytest.mark.parametrize(("autopilot", "speed", "top"),
                         [("ardupilot", "10", "10.00"), ("px4", "9.9", "9.81")])
def test_specs_refuse_a_wind_at_the_top_airspeed_of_the_autopilot(autopilot, speed, top
                                                                  ) -> None:
    """It failed trial by trial, late; the planner's rule (the autopilot's top airspeed,
    validator.motion.speed_model) now refuses it up front."""
    with pytest.raises(InputError) as err:
        wind_specs(load_site(SAMPLE), (0.0, 4.0, float(speed)), (45.0,), autopilot=autopilot)
    assert str(err.value) == (f"--speeds: {speed} m/s from 45° is at or above the vehicle's "
                              f"top airspeed {top} m/s; it can neither hold position nor fly "
                              "upwind")


def test_specs_accept_a_wind_just_below_the_top_airspeed() -> None:
    assert len(wind_specs(load_site(SAMPLE), (9.9,), (45.0,), autopilot="ardupilot")) == 1


def test_specs_refuse_a_wind_at_the_airspeed_held_through_its_gusts() -> None:
    with pytest.raises(InputError, match=r"^--speeds: 9\.9 m/s from 45°, turbulence 2 m/s is at "
                                         r"or above the airspeed the vehicle holds through its "
                                         r"gusts, 9\.78 m/s"):
        wind_specs(load_site(SAMPLE), (9.9,), (45.0,), turbulence_mps=2.0)


def test_a_wind_at_the_top_airspeed_is_exit_2_before_any_trial(tmp_path, capsys) -> None:
    out = tmp_path / "w"
    assert main(["wind", SAMPLE, "-o", str(out), "--speeds", "0,12", "--directions", "45",
                 "--workers", "1", "--quiet"]) == 2
    assert capsys.readouterr().err == ("nfz-study: --speeds: 12 m/s from 45° is at or above "
                                       "the vehicle's top airspeed 10.00 m/s; it can neither "
                                       "hold position nor fly upwind\n")
    assert not out.exists()


def test_a_wind_whose_trial_failed_is_named_as_missing() -> None:
    rows = [{"speed_mps": 0.0, "from_deg": 0.0, "error": "SolverError: x"},
            {"speed_mps": 5.0, "from_deg": 90.0, "error": ""},
            {"speed_mps": 12.0, "from_deg": 45.0, "error": "InputError: wind: too strong"}]
    assert missing_points(rows) == [("still air", "SolverError: x"),
                                    ("wind 12 m/s from 45°", "InputError: wind: too strong")]


def test_a_wind_with_no_result_is_exit_1_and_its_table_is_written(tmp_path, capsys) -> None:
    """A wind whose trial failed (here logged by an earlier run) is a hole in the figure."""
    out = tmp_path / "w"
    (spec,) = wind_specs(load_site(SAMPLE), (5.0,), (45.0,))
    row = dict.fromkeys(WIND_COLUMNS) | {"key": spec.key, "speed_mps": 5.0, "from_deg": 45.0,
                                         "error": "InputError: uav: no flyable cycle"}
    out.mkdir()
    (out / LOG_NAME).write_text(json.dumps(row) + "\n")
    assert main(["wind", SAMPLE, "-o", str(out), "--speeds", "5", "--directions", "45",
                 "--workers", "1", "--quiet"]) == 1
    assert capsys.readouterr().err == (
        "nfz-study: no result at 1 of 1 sweep points (every trial failed): wind 5 m/s from 45° "
        "(InputError: uav: no flyable cycle)\n")
    assert "no flyable cycle" in (out / "wind_trials.csv").read_text()
    assert (out / "wind.png").exists()


def test_wind_study_writes_its_table_and_figure(tmp_path, capsys) -> None:
    out = tmp_path / "w"
    code = main(["wind", SAMPLE, "-o", str(out), "--speeds", "0,5", "--directions", "270",
                 "--workers", "1", "--quiet"])
    assert code == 0
    rows = list(csv.DictReader((out / "wind_trials.csv").open()))
    assert [float(r["speed_mps"]) for r in rows] == [0.0, 5.0]
    windy = rows[1]
    assert abs(float(windy["cycle_ratio"]) - 1.0) < 0.05  # planned for it: on time
    assert float(windy["blind_cycle_ratio"]) > 1.05  # the still-air plan runs late
    assert float(rows[0]["cycle_ratio"]) == pytest.approx(float(rows[0]["blind_cycle_ratio"]))
    # take-off to landing: in still air both plans are the one plan; in wind each its own
    assert float(rows[0]["mission_s"]) == pytest.approx(float(rows[0]["blind_mission_s"]))
    assert float(windy["mission_s"]) != pytest.approx(float(windy["blind_mission_s"]))
    assert all(100.0 < float(r[k]) < 900.0 for r in rows for k in ("mission_s", "blind_mission_s"))
    assert (out / "wind.png").read_bytes()[:4] == b"\x89PNG"
    # run again: resumed, nothing re-run
    assert main(["wind", SAMPLE, "-o", str(out), "--speeds", "0,5", "--directions", "270",
                 "--workers", "1", "--quiet"]) == 0
    assert "0 run now, 2 from" in capsys.readouterr().out
