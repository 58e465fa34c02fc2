"""The benchmarks' command lines keep the commands' conventions: a flag's value given twice is
refused, one line, exit 2 (argparse kept the last of ``--repeat 3 --repeat 1`` without a word).

Parse only: each benchmark's ``main`` is stopped where it parses, so none of them runs.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path
from typing import Any

import pytest

from validator.errors import CommandParser

BENCHMARKS = sorted(p for p in (Path(__file__).resolve().parents[1] / "benchmarks").glob("*.py")
                    if "def main(" in p.read_text(encoding="utf-8"))


class _Parsing(Exception):
    """Raised where a benchmark's ``main`` parses its command line: no further."""

    def __init__(self, parser: argparse.ArgumentParser) -> None:
        super().__init__()
        self.parser = parser


def _parser(path: Path, monkeypatch: pytest.MonkeyPatch) -> argparse.ArgumentParser:
    """The parser ``path``'s ``main`` builds, taken from it as it starts to parse."""
    monkeypatch.setattr(sys, "path", list(sys.path))  # some benchmarks add their folder
    spec = importlib.util.spec_from_file_location(f"_benchmark_{path.stem}", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)  # its dataclasses look it up there
    spec.loader.exec_module(module)

    def stop(self: argparse.ArgumentParser, *_args: Any, **_kwargs: Any) -> None:
        raise _Parsing(self)

    # on the base class: a benchmark that went back to a plain parser is stopped all the same
    with monkeypatch.context() as patch:
        patch.setattr(argparse.ArgumentParser, "parse_args", stop)
        with pytest.raises(_Parsing) as parsing:
            module.main()
    return parsing.value.parser


def _exit(parser: argparse.ArgumentParser, argv: list[str],
          capsys: pytest.CaptureFixture[str]) -> tuple[object, str]:
    """(exit status, stderr) of parsing ``argv``; status None when it parses."""
    try:
        parser.parse_args(argv)
    except SystemExit as done:
        return done.code, capsys.readouterr().err
    return None, capsys.readouterr().err


@pytest.mark.parametrize("path", BENCHMARKS, ids=[p.stem for p in BENCHMARKS])
def test_a_benchmark_refuses_a_flag_s_value_given_twice(
        path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    parser = _parser(path, monkeypatch)
    assert isinstance(parser, CommandParser)
    options = [a for a in parser._actions if a.option_strings and a.nargs != 0
               and not isinstance(a, argparse._AppendAction)]
    assert options, "no option takes a value: nothing was checked"
    for action in options:
        flag = action.option_strings[-1]
        value = str(next(iter(action.choices))) if action.choices else "1"
        assert _exit(parser, [flag, value], capsys) == (None, ""), flag
        assert _exit(parser, [flag, value, flag, value], capsys) == (
            2, f"{parser.prog}: {flag} given twice\n")
    assert _exit(parser, ["--bogus"], capsys) == (
        2, f"{parser.prog}: unrecognized arguments: --bogus\n")
