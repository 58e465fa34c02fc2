"""Where the SITL binary and its default parameters are found: paths the simulator, which runs
in a working directory of its own, can open."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from validator.errors import InputError
from validator.mavlink.sitl_process import find_binary, find_defaults


@pytest.fixture
def in_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("ARDUPILOT_SITL", raising=False)
    monkeypatch.delenv("ARDUPILOT_SITL_DEFAULTS", raising=False)
    binary = tmp_path / "arducopter"
    binary.write_text("#!/bin/sh\n")
    binary.chmod(0o755)
    (tmp_path / "my.parm").write_text("SIM_WIND_SPD 0\n")
    return tmp_path


def test_a_relative_defaults_file_is_handed_on_absolute(in_tmp: Path) -> None:
    found = find_defaults(in_tmp / "arducopter", "my.parm")
    assert found.is_absolute()
    assert found == in_tmp / "my.parm"


def test_a_relative_binary_is_handed_on_absolute(in_tmp: Path) -> None:
    found = find_binary("./arducopter")
    assert found is not None and found.is_absolute()
    assert os.path.samefile(found, in_tmp / "arducopter")


def test_a_missing_defaults_file_is_named(in_tmp: Path) -> None:
    with pytest.raises(InputError, match="--sitl-defaults nowhere.parm: no such file"):
        find_defaults(in_tmp / "arducopter", "nowhere.parm")
