"""Every command reports a user's mistake the same way: one line ``PROG: MESSAGE`` naming the
file, exit status 2 (issue 12: one error path)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import pytest

from mission_planner.cli import plan_mission_main
from mission_planner.study.cli import main as nfz_study_main
from validator.cli import validate_mission_main
from validator.errors import InputError, report_error
from validator.mavlink.cli import upload_mission_main

Main = Callable[[Sequence[str]], int]


@pytest.mark.parametrize(("prog", "main", "argv"), [
    ("plan-mission", plan_mission_main, ["{missing}", "-o", "{tmp}/m.plan"]),
    ("validate-mission", validate_mission_main, ["{missing}", "--site", "{missing}"]),
    ("upload-mission", upload_mission_main, ["{missing}", "--connect", "udpin:127.0.0.1:9",
                                             "--timeout", "1"]),
    ("nfz-study", nfz_study_main, ["fig3", "{missing}", "-o", "{tmp}/out"]),
])
def test_a_missing_file_is_one_line_naming_it_exit_2(prog: str, main: Main, argv: list[str],
                                                     tmp_path, capsys) -> None:
    missing = str(tmp_path / "nowhere.yaml")
    args = [a.format(missing=missing, tmp=tmp_path) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith(f"{prog}: ") and "nowhere.yaml" in err[0]
    assert not err[0].startswith(f"{prog}: error:")


def test_report_error_names_the_file_of_an_os_error(capsys) -> None:
    assert report_error("x", FileNotFoundError(2, "No such file or directory", "a.plan")) == 2
    assert capsys.readouterr().err == "x: a.plan: No such file or directory\n"
    assert report_error("x", InputError("bad\nvalue")) == 2
    assert capsys.readouterr().err == "x: bad\\nvalue\n"


@pytest.mark.parametrize(("prog", "main"), [
    ("plan-mission", plan_mission_main),
    ("validate-mission", validate_mission_main),
    ("upload-mission", upload_mission_main),
    ("nfz-study", nfz_study_main),
])
def test_a_command_line_mistake_is_one_line_exit_2(prog: str, main: Main, capsys) -> None:
    with pytest.raises(SystemExit) as exit_:
        status = main(["--no-such-option"])
        raise SystemExit(status)
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"{prog}: ")


def test_a_failed_link_is_a_user_error_but_not_bad_input() -> None:
    from validator.errors import UserError
    from validator.mavlink.connection import LinkError

    assert issubclass(LinkError, UserError) and not issubclass(LinkError, InputError)
    assert issubclass(InputError, UserError)


def test_a_bad_airspace_file_is_one_line_naming_it_and_nothing_is_written(tmp_path,
                                                                         capsys) -> None:
    from pathlib import Path

    sample = Path(__file__).parents[1] / "samples" / "paper-default.yaml"
    site = tmp_path / "site.yaml"
    site.write_text(sample.read_text() + "airspace: zones.geojson\n")
    (tmp_path / "zones.geojson").write_text('{"type": "FeatureCollection", "features": [{"type": '
                                            '"Feature", "properties": {"name": "R"}, "geometry":'
                                            ' {"type": "LineString", "coordinates": []}}]}')
    assert plan_mission_main([str(site), "-o", str(tmp_path / "m.plan")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"plan-mission: {tmp_path / 'zones.geojson'}: features[0] (R).geometry: a "
                   "LineString cannot be a zone (Polygon, MultiPolygon, or Point with radius_m)"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["site.yaml", "zones.geojson"]


@pytest.mark.parametrize("value", ["inf", "nan", "0"])
def test_a_timeout_that_never_ends_is_refused(value: str, tmp_path, capsys) -> None:
    # inf had been taken: a link that waits forever for a vehicle that does not answer
    assert upload_mission_main([str(tmp_path / "m.plan"), "--connect", "udpout:127.0.0.1:9",
                                "--timeout", value]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--timeout" in err and "finite number > 0" in err
