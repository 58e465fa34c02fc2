"""The six commands agree (issue 30 item 4): every ``--help`` ends with the one exit-status
table, the shared flags are where they belong, an old spelling works with one deprecation line,
bad input is one line and exit 2, Ctrl-C is one line and 130, a read-back mismatch is a verdict
(1). The entry functions are called in-process; one console script runs as a process."""

from __future__ import annotations

import argparse
import subprocess
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import pytest

import mission_planner.cli as plan_cli
import mission_planner.study.cli as study_cli
import validator.cli as validate_cli
import validator.mavlink.cli as mavlink_cli
from validator.cli_common import EXIT_STATUS, LINK_TIMEOUT_S

ROOT = Path(__file__).parents[1]
PLAN = ROOT / "tests/data/failsafe/plans/river-ardupilot.plan"
SITE = ROOT / "samples/paper-default.yaml"

Main = Callable[[Sequence[str] | None], int]

# prog -> (entry function, module holding its work function, the work function's name)
COMMANDS: dict[str, tuple[Main, object, str]] = {
    "plan-mission": (plan_cli.plan_mission_main, plan_cli, "_plan"),
    "validate-mission": (validate_cli.validate_mission_main, validate_cli, "_validate"),
    "upload-mission": (mavlink_cli.upload_mission_main, mavlink_cli, "_upload"),
    "download-mission": (mavlink_cli.download_mission_main, mavlink_cli, "_download"),
    "sitl-vehicle": (mavlink_cli.sitl_vehicle_main, mavlink_cli, "_sitl_vehicle"),
    "nfz-study": (study_cli.main, study_cli, "_main"),
}

# the argv whose --help each parser answers (nfz-study: each subcommand too)
HELPS = [(prog, []) for prog in COMMANDS] + [("nfz-study", [sub])
                                              for sub in ("fig3", "fig4", "wind")]


def test_the_console_scripts_are_the_six() -> None:
    import tomllib

    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert set(scripts) == set(COMMANDS)


@pytest.mark.parametrize(("prog", "sub"), HELPS)
def test_help_ends_with_the_exit_status_table(prog: str, sub: list[str], capsys) -> None:
    main = COMMANDS[prog][0]
    assert main([*sub, "--help"]) == 0
    assert capsys.readouterr().out.rstrip().endswith(EXIT_STATUS)


def _help(prog: str, sub: Sequence[str] = ()) -> str:
    parser = {"plan-mission": plan_cli._parser, "validate-mission": validate_cli.build_parser,
              "upload-mission": mavlink_cli.upload_parser,
              "download-mission": mavlink_cli.download_parser,
              "sitl-vehicle": mavlink_cli.sitl_parser, "nfz-study": study_cli.build_parser}[prog]()
    if sub:
        subs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        parser = subs.choices[sub[0]]
    return parser.format_help()


LINK = ("--connect", "--sysid", "--signing-key")
FLAGS = [
    ("plan-mission", (), ("-o", "--output", "--autopilot", "--quiet", "--params-out")),
    ("validate-mission", (), (*LINK, "--timeout", "--autopilot", "--profile", "--quiet",
                              "--params")),
    ("upload-mission", (), (*LINK, "--timeout", "--quiet", "--params")),
    ("download-mission", (), (*LINK, "--timeout", "-o", "--output", "--quiet", "--params-out")),
    ("sitl-vehicle", (), (*LINK, "--autopilot", "--profile", "--quiet")),
    ("nfz-study", ("fig3",), ("-o", "--output", "--quiet")),
    ("nfz-study", ("fig4",), ("-o", "--output", "--quiet")),
    ("nfz-study", ("wind",), ("-o", "--output", "--quiet", "--autopilot")),
]
OLD = ("--sitl-url", "--sitl-timeout", "--sitl-sysid", "--listen", "--set-params",
       "--no-progress", "--out", "--json")


@pytest.mark.parametrize(("prog", "sub", "flags"), FLAGS)
def test_the_shared_flags_are_where_they_belong_and_old_names_are_hidden(
        prog: str, sub: tuple[str, ...], flags: tuple[str, ...]) -> None:
    text = _help(prog, sub)
    words = set(text.replace(",", " ").replace("[", " ").replace("]", " ").split())
    for flag in flags:
        assert flag in words, f"{prog} {' '.join(sub)}: no {flag}"
    assert not words & set(OLD), f"{prog}: an old spelling is listed in --help"
    if "--autopilot" in flags:
        assert "--autopilot {ardupilot,px4}" in text


def test_the_link_timeout_is_the_link_s_own_default() -> None:
    from validator.mavlink.connection import DEFAULT_TIMEOUT_S

    assert LINK_TIMEOUT_S == DEFAULT_TIMEOUT_S


def _upload(argv: list[str]) -> argparse.Namespace:
    return mavlink_cli.upload_parser().parse_args(["x.plan", "--connect", "tcp:h:1", *argv])


def _validate(argv: list[str]) -> argparse.Namespace:
    return validate_cli.build_parser().parse_args(["x.plan", "--site", "s.yaml", *argv])


def _download(argv: list[str]) -> argparse.Namespace:
    return mavlink_cli.download_parser().parse_args(["--connect", "tcp:h:1", "-o", "o.plan",
                                                     *argv])


def _sitl(argv: list[str]) -> argparse.Namespace:
    return mavlink_cli.sitl_parser().parse_args(["--home=1,2,3", *argv])


def _plan(argv: list[str]) -> argparse.Namespace:
    return plan_cli._parser().parse_args(["s.yaml", "-o", "m.plan", *argv])


def _fig4(argv: list[str]) -> argparse.Namespace:
    return study_cli.build_parser().parse_args(["fig4", *argv])


# (parse, old argv, new spelling in the warning, attribute, value it must hold)
ALIASES = [
    (_validate, ["--sitl-url", "tcp:h:1"], "--connect", "connect", "tcp:h:1"),
    (_validate, ["--sitl-timeout", "3"], "--timeout", "timeout", 3.0),
    (_validate, ["--sitl-sysid", "7"], "--sysid", "sysid", 7),
    (_validate, ["--json", "r.json"], "--report", "report", "r.json"),
    (_sitl, ["--listen", "14551"], "--connect", "connect", "14551"),
    (_upload, ["--set-params", "v.param"], "--params", "params", "v.param"),
    (_download, ["--params", "v.param"], "--params-out", "params_out", "v.param"),
    (_plan, ["--params", "v.param"], "--params-out", "params_out", Path("v.param")),
    (_plan, ["--no-progress"], "--quiet", "quiet", True),
    (_fig4, ["--out", "d", "--no-progress"], "--output", "output", "d"),
]


@pytest.mark.parametrize(("parse", "argv", "new", "attr", "value"), ALIASES,
                         ids=[a[1][0] + "-" + a[0].__name__ for a in ALIASES])
def test_an_old_spelling_works_and_warns_once(parse, argv: list[str], new: str, attr: str,
                                               value: object, capsys) -> None:
    switches = all(a.startswith("-") for a in argv)  # a value given twice is refused
    args = parse(argv + argv if switches else argv)  # a switch given twice: still one line
    got = getattr(args, attr)
    assert got == (Path(str(value)) if isinstance(got, Path) else value)  # outputs: Path
    err = capsys.readouterr().err.splitlines()
    assert f"warning: {argv[0]} is deprecated; use {new}" in err
    assert err.count(f"warning: {argv[0]} is deprecated; use {new}") == 1


@pytest.mark.parametrize("parse", [_validate, _sitl])
def test_profile_is_the_ideal_model_and_an_old_autopilot_word_is_deprecated(parse,
                                                                            capsys) -> None:
    from validator.plan_format import Autopilot

    assert parse(["--profile", "ideal"]).profile == "ideal"
    assert capsys.readouterr().err == ""
    args = parse(["--profile", "arducopter"])
    assert args.autopilot is Autopilot.ARDUPILOTMEGA and args.profile is None
    assert capsys.readouterr().err == ("warning: --profile arducopter is deprecated; use "
                                       "--autopilot ardupilot\n")
    assert parse(["--autopilot", "px4"]).autopilot is Autopilot.PX4


# a parser, the argv it accepts as it stands (positionals and required options)
PARSERS: list[tuple[str, Callable[[], argparse.ArgumentParser], list[str]]] = [
    ("plan-mission", plan_cli._parser, ["s.yaml", "-o", "m.plan"]),
    ("validate-mission", validate_cli.build_parser, ["x.plan", "--site", "s.yaml"]),
    ("upload-mission", mavlink_cli.upload_parser, ["x.plan", "--connect", "tcp:h:1"]),
    ("download-mission", mavlink_cli.download_parser, ["--connect", "tcp:h:1", "-o", "o.plan"]),
    ("sitl-vehicle", mavlink_cli.sitl_parser, ["--home", "1,2,3"]),
    ("nfz-study fig3", study_cli.build_parser, ["fig3", "s.yaml", "-o", "d"]),
    ("nfz-study fig4", study_cli.build_parser, ["fig4", "-o", "d"]),
    ("nfz-study wind", study_cli.build_parser, ["wind", "s.yaml", "-o", "d"]),
]
REPEATABLE = (argparse._AppendAction, argparse._AppendConstAction, argparse._CountAction)
VALUES = ("1", "1,2,3", "px4", "ideal", "tcp:h:1")  # one of them suits each option


def _options(parser: argparse.ArgumentParser, argv: list[str]) -> list[argparse.Action]:
    """The options of the (sub)command ``argv`` names that take a value."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if subs:
        parser = subs[0].choices[argv[0]]
    return [a for a in parser._actions if a.option_strings and a.nargs != 0]


def _refusal(parser: argparse.ArgumentParser, argv: list[str]) -> str | None:
    """The error parsing ``argv`` gives (None when it parses)."""
    import contextlib
    import io

    from validator.errors import InputError

    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            parser.parse_args(argv)
    except SystemExit:
        return err.getvalue()
    except InputError as exc:  # nfz-study's parser raises it for the command to print
        return str(exc)
    return None


def _without(argv: list[str], dest: str, options: list[argparse.Action]) -> list[str]:
    """``argv`` with the options that set ``dest`` (aliases too) and their values taken out."""
    spellings = {s for a in options if a.dest == dest for s in a.option_strings}
    out: list[str] = []
    it = iter(argv)
    for a in it:
        if a in spellings:
            next(it)
        else:
            out.append(a)
    return out


@pytest.mark.parametrize(("name", "build", "argv"), PARSERS, ids=[p[0] for p in PARSERS])
def test_every_option_that_takes_one_value_refuses_a_second(
        name: str, build: Callable[[], argparse.ArgumentParser], argv: list[str]) -> None:
    parser = build()
    options = _options(parser, argv)
    for action in options:
        if isinstance(action, REPEATABLE):
            continue
        base, flag = _without(argv, action.dest, options), action.option_strings[-1]
        value = next((v for v in (*(action.choices or ()), *VALUES)
                      if _refusal(parser, [*base, flag, v]) is None), None)
        assert value is not None, f"{name} {flag}: no test value parses"
        refusal = _refusal(parser, [*base, flag, value, flag, value])
        assert refusal is not None and f"{flag} given twice" in refusal, f"{name} {flag}"


@pytest.mark.parametrize(("name", "build", "argv"), PARSERS, ids=[p[0] for p in PARSERS])
def test_an_option_meant_to_repeat_keeps_every_value(
        name: str, build: Callable[[], argparse.ArgumentParser], argv: list[str]) -> None:
    parser = build()
    for action in _options(parser, argv):
        if isinstance(action, argparse._AppendAction):
            flag = action.option_strings[-1]
            args = parser.parse_args([*argv, flag, "A=1", flag, "B=2"])
            assert getattr(args, action.dest)[-2:] == ["A=1", "B=2"], f"{name} {flag}"


def test_a_flag_given_twice_is_one_line_exit_2_before_any_work(monkeypatch, capsys) -> None:
    monkeypatch.setattr(plan_cli, "_plan", lambda _args: pytest.fail("planned"))
    argv = ["s.yaml", "-o", "a.plan", "--wind", "5@270", "--wind", "7@90"]
    assert plan_cli.plan_mission_main(argv) == 2
    assert capsys.readouterr().err == "plan-mission: --wind given twice\n"


BAD = {
    "plan-mission": ["{tmp}/none.yaml", "-o", "{tmp}/m.plan"],
    "validate-mission": ["{tmp}/none.plan", "--site", str(SITE)],
    "upload-mission": ["{tmp}/none.plan", "--connect", "udpin:127.0.0.1:9", "--timeout", "1"],
    "download-mission": ["--connect", "{tmp}/none.serial", "-o", "{tmp}/m.plan"],
    "sitl-vehicle": ["--home", "1,2"],
    "nfz-study": ["fig3", "{tmp}/none.yaml", "-o", "{tmp}/out"],
}


@pytest.mark.parametrize("prog", COMMANDS)
def test_bad_input_is_one_line_exit_2_and_no_output(prog: str, tmp_path, capsys) -> None:
    main = COMMANDS[prog][0]
    assert main([a.format(tmp=tmp_path) for a in BAD[prog]]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"{prog}: ") and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("prog", COMMANDS)
def test_a_bad_flag_value_is_one_line_exit_2(prog: str, capsys) -> None:
    main = COMMANDS[prog][0]
    argv = (["wind", "s.yaml", "-o", "d"] if prog == "nfz-study" else []) + ["--autopilot",
                                                                            "inav"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"{prog}: ")


PARSES = {  # argv each parser accepts (the work function, replaced, never sees it)
    "plan-mission": ["s.yaml", "-o", "m.plan"],
    "validate-mission": ["x.plan", "--site", "s.yaml"],
    "upload-mission": ["x.plan", "--connect", "tcp:h:1"],
    "download-mission": ["--connect", "tcp:h:1", "-o", "o.plan"],
    "sitl-vehicle": ["--home", "1,2,3"],
    "nfz-study": ["fig3", "s.yaml", "-o", "d"],
}


@pytest.mark.parametrize("prog", COMMANDS)
def test_ctrl_c_is_one_line_and_130(prog: str, monkeypatch, capsys) -> None:
    main, module, work = COMMANDS[prog]

    def interrupted(*_args: object) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(module, work, interrupted)
    assert main(PARSES[prog]) == 130
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"{prog}: interrupted")


def test_a_read_back_mismatch_is_a_verdict_exit_1(monkeypatch, capsys) -> None:
    import validator.mavlink.link as link

    def differs(*_args: object, **_kwargs: object) -> None:
        raise link.ReadBackMismatch("read-back differs from the upload: mission item 3")

    monkeypatch.setattr(link, "upload_plan", differs)
    assert mavlink_cli.upload_mission_main([str(PLAN), "--connect", "tcp:h:1"]) == 1
    assert capsys.readouterr().err == ("upload-mission: read-back differs from the upload: "
                                       "mission item 3\n")


def test_plan_mission_prints_its_result_on_stdout(tmp_path, capsys) -> None:
    out = tmp_path / "m.plan"
    assert plan_cli.plan_mission_main([str(SITE), "-o", str(out), "--dynamics", "none",
                                       "--quiet"]) == 0
    printed = capsys.readouterr()
    assert printed.out.startswith(f"plan-mission: wrote {out}") and "wrote" not in printed.err


def test_a_console_script_as_a_process(tmp_path) -> None:
    """The installed ``validate-mission``: bad input is one line and 2, no traceback."""
    script = Path(sys.executable).with_name("validate-mission")
    if not script.exists():
        pytest.skip(f"{script}: the project is not installed in this interpreter's environment")
    proc = subprocess.run([str(script), str(tmp_path / "none.plan"), "--site", str(SITE),
                           "--sitl-timeout", "1"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    lines = proc.stderr.splitlines()
    assert lines[0] == "warning: --sitl-timeout is deprecated; use --timeout"
    assert len(lines) == 2 and lines[1].startswith("validate-mission: ") and "none.plan" in lines[1]
