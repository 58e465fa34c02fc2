"""Parameter files: both formats read back as written, and any bytes give values or one clean
error naming the file and line."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from validator.autopilot.param_file import format_params, parse_params, read_params
from validator.errors import InputError

VALUES = {"WPNAV_SPEED": 1000.0, "WPNAV_ACCEL": 250.5, "FENCE_ENABLE": 1.0}


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
def test_written_files_read_back(autopilot):
    assert parse_params(format_params(VALUES, autopilot, ["a comment"])) == VALUES


def test_a_binary_file_is_one_clean_error(tmp_path: Path):
    path = tmp_path / "x.param"
    path.write_bytes(b"\xff\xfe\x00WPNAV")
    with pytest.raises(InputError, match="x.param"):
        read_params(path)


@settings(max_examples=80, deadline=None)
@given(st.binary(max_size=200))
def test_any_bytes_give_values_or_a_clean_error(tmp_path_factory, data: bytes):
    path = tmp_path_factory.mktemp("p") / "m.param"
    path.write_bytes(format_params(VALUES, "ardupilot").encode() + data)
    try:
        values = read_params(path)
    except InputError as err:
        assert "\n" not in str(err) and str(path) in str(err)
    else:
        assert all(isinstance(v, float) for v in values.values())
