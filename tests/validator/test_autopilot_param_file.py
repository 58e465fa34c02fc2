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


def test_each_value_names_its_file_and_line_the_last_for_a_name_given_twice():
    values = parse_params("# head\nWPNAV_SPEED 500\n\nWPNAV_ACCEL 100\nWPNAV_SPEED 700\n",
                          "m.param")
    assert values.where("WPNAV_ACCEL") == "m.param:4: WPNAV_ACCEL"
    assert values.where("WPNAV_SPEED") == "m.param:5: WPNAV_SPEED"


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
