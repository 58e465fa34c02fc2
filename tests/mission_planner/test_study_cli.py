"""nfz-study: bad input is one line and exit 2 with no output; a small study runs."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
import yaml

from mission_planner.study.cli import main
from mission_planner.study.sites import random_site
from validator.site import site_to_dict

SMALL = ["--trials", "1", "--radii", "50", "--counts", "3", "--radius", "50", "--slots", "10",
         "--workers", "1", "--quiet"]
FAST = ["--max-iterations", "10"]


def _radii(radii: str) -> list[str]:
    """:data:`SMALL` sweeping the radii ``radii``."""
    small = list(SMALL)
    small[small.index("--radii") + 1] = radii
    return small


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--trials", "0"], "--trials"),
        (["--radii", "10,x"], "--radii"),
        (["--radii", "10,,20"], "--radii"),  # had been read as 10,20
        (["--radii", "10,inf"], "--radii"),
        (["--counts", "-1"], "--counts"),
        (["--slots", "1"], "--slots"),
        (["--workers", "0"], "--workers"),
        (["--scheduler", "localhost:8786"], "--scheduler"),
        (["--format", "xlsx"], "--format"),
        (["--max-iterations", "0"], "--max-iterations"),
        (["--bogus"], "--bogus"),
    ],
)
def test_fig4_bad_option_is_one_line_exit_2_and_no_output(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], named: str
) -> None:
    out = tmp_path / "out"
    assert main(["fig4", "-o", str(out), *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and named in err
    assert not out.exists()


def test_fig4_radius_no_site_can_hold_is_exit_2_and_no_output(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """It ran, failed every trial of that radius and exited 0 with a warning."""
    out = tmp_path / "out"
    assert main(["fig4", "-o", str(out), *_radii("1e9"), *FAST]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("nfz-study: --radii: a zone of radius 1e+09")
    assert not out.exists()


def test_fig4_zones_that_cannot_lie_apart_are_exit_2_and_no_output(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Three 190 m zones never pack in the 400 m square: every trial of that point failed and
    the study exited 0 with a warning, the 10 m point's results looking like the whole."""
    out = tmp_path / "out"
    assert main(["fig4", "-o", str(out), *_radii("10,190"), *FAST]) == 2
    assert capsys.readouterr().err == ("nfz-study: --radii: 3 zones of radius 190 m cannot lie "
                                       "apart in the 400 m square of the sites (at most 1 fit)\n")
    assert not out.exists()


def test_a_sweep_point_whose_every_trial_failed_is_exit_1_and_the_others_are_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """It exited 0 with a warning: the 50 m point's results looked like the whole figure."""
    # three zones of radius 110 m pass the packing bound, yet fit only up to 101.7 m: every
    # draw fails
    out = tmp_path / "out"
    assert main(["fig4", "-o", str(out), *_radii("50,110"), *FAST]) == 1
    (verdict,) = capsys.readouterr().err.splitlines()
    assert verdict.startswith("nfz-study: no result at 1 of 3 sweep points (every trial failed): "
                              "radius sweep R=110 m (InputError: num_nfzs: cannot place 3 ")
    with (out / "fig4_summary.csv").open() as f:
        summary = list(csv.DictReader(f))
    worked = [r for r in summary if float(r["radius_m"]) == 50]
    assert len(worked) == 4 and all(float(r["min_rate_bps_hz"]) > 0 for r in worked)
    assert {float(r["radius_m"]) for r in summary if r["failed"] == r["trials"]} == {110.0}
    assert (out / "fig4a_spectral_efficiency.png").exists()


def test_a_study_whose_every_trial_failed_exits_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["--trials", "1", "--radii", "110", "--counts", "3", "--radius", "110",
            "--workers", "1", "--quiet"]
    assert main(["fig4", "-o", str(tmp_path / "out"), *argv]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot place 3" in err
    assert "no result at 2 of 2 sweep points" in err  # the one point, in both sweeps


def test_a_sweep_point_that_lost_some_trials_is_exit_1_one_line_each_and_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """It exited 0 with one warning for the whole study: the point's estimate averaged the
    sites left, which may lean to the easier ones, and looked like the one asked for."""
    # three zones of 90 m: trial 0's site cannot be drawn (seed 0), trial 1's can
    argv = ["--trials", "2", "--radii", "90", "--counts", "3", "--radius", "90", "--slots", "10",
            "--workers", "1", "--quiet", *FAST]
    out = tmp_path / "out"
    assert main(["fig4", "-o", str(out), *argv]) == 1
    why = ("1 of 2 trials failed under proposed, 1 of 2 under conventional; its result averages "
           "the trials left (first: InputError: num_nfzs: cannot place 3 non-overlapping zones "
           "of radius 90 m in a 400 m square (seed 2968811710, stuck at zone 3))")
    assert capsys.readouterr().err.splitlines() == [f"nfz-study: radius sweep R=90 m: {why}",
                                                   f"nfz-study: count sweep M=3: {why}"]
    with (out / "fig4_summary.csv").open() as f:
        summary = list(csv.DictReader(f))
    assert {(r["trials"], r["failed"]) for r in summary} == {("2", "1")}
    assert all(r["first_error"].startswith("InputError: num_nfzs: cannot place 3 ")
               and float(r["min_rate_bps_hz"]) > 0 for r in summary)
    assert (out / "fig4b_outage.png").exists()


def test_unreachable_scheduler_is_exit_2_and_no_output(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    # Port 9 (discard) on loopback: nothing listens there.
    assert main(["fig4", "-o", str(out), *SMALL, *FAST, "--scheduler", "tcp://127.0.0.1:9"]) == 2
    assert "--scheduler" in capsys.readouterr().err
    assert not out.exists()


def test_fig3_bad_site_file_is_exit_2_and_no_output(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    site = tmp_path / "site.yaml"
    data = site_to_dict(random_site(0, slots=10))
    data["no_fly_zones"][1]["radius"] = -3.0
    site.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    assert main(["fig3", str(site), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no_fly_zones[1]" in err
    assert not out.exists()


@pytest.mark.parametrize(("study", "name"), [("fig3", "fig3_summary.csv"),
                                            ("wind", "wind_trials.csv")])
def test_a_study_refuses_to_write_over_the_site_s_airspace_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], study: str, name: str
) -> None:
    samples = Path(__file__).parents[2] / "samples"
    zones = tmp_path / name  # the airspace file, named as a file the study writes
    zones.write_bytes((samples / "airfield-airspace.geojson").read_bytes())
    site = tmp_path / "airfield.yaml"
    site.write_text((samples / "airfield.yaml").read_text().replace(
        "airspace: airfield-airspace.geojson", f"airspace: {name}"))
    before = zones.read_bytes()
    argv = [study, str(site), "-o", str(tmp_path), "--max-iterations", "2"] if study == "fig3" \
        else [study, str(site), "-o", str(tmp_path), "--speeds", "0", "--directions", "0",
              "--workers", "1", "--quiet"]
    assert main(argv) == 2
    assert capsys.readouterr().err == (f"nfz-study: {zones}: is an input of this command "
                                       "(the site's airspace file)\n")
    assert zones.read_bytes() == before


def test_fig4_runs_and_a_rerun_resumes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert main(["fig4", "-o", str(out), *SMALL, *FAST]) == 0
    said = capsys.readouterr()
    assert "2 run now, 0 from" in said.out and said.err == ""  # no trial failed: nothing to say
    with (out / "trials.csv").open() as f:
        assert sorted(r["scheme"] for r in csv.DictReader(f)) == ["conventional", "proposed"]
    assert main(["fig4", "-o", str(out), *SMALL, *FAST]) == 0
    assert "0 run now, 2 from" in capsys.readouterr().out


def test_fig4_refuses_to_mix_planner_settings_in_one_directory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    assert main(["fig4", "-o", str(out), *SMALL, *FAST]) == 0
    capsys.readouterr()
    assert main(["fig4", "-o", str(out), *SMALL, "--max-iterations", "11"]) == 2
    assert "planner_options" in capsys.readouterr().err


def test_empty_output_is_refused_not_the_working_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["fig4", "-o", "", *SMALL, *FAST]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "-o/--output: empty path" in err
    assert list(tmp_path.iterdir()) == []
