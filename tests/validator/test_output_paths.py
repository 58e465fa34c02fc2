"""check_output_paths: what the base layer refuses as an output, links included."""

import os

import pytest

from validator.errors import InputError
from validator.output_paths import check_output_paths


def test_new_files_beside_existing_regular_ones_pass(tmp_path):
    (tmp_path / "old.plan").write_text("x")
    check_output_paths([tmp_path / "old.plan", tmp_path / "new.json"], {"the site": None})


def test_empty_path_is_refused():
    with pytest.raises(InputError, match="output path is empty"):
        check_output_paths([""])


def test_a_missing_folder_is_refused(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        check_output_paths([tmp_path / "nowhere" / "m.plan"])


def test_a_hard_link_to_an_input_is_refused(tmp_path):
    site = tmp_path / "site.yaml"
    site.write_text("name: s\n")
    os.link(site, tmp_path / "alias.yaml")
    with pytest.raises(InputError, match=r"alias\.yaml: is an input of this command \(the site"):
        check_output_paths([tmp_path / "alias.yaml"], {"the site file": site})


def test_a_symlink_to_another_output_is_refused(tmp_path):
    (tmp_path / "a.json").write_text("{}")
    (tmp_path / "b.json").symlink_to(tmp_path / "a.json")
    with pytest.raises(InputError, match="named for two outputs"):
        check_output_paths([tmp_path / "a.json", tmp_path / "b.json"])


def test_a_symlink_to_a_fifo_is_refused(tmp_path):
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "out.plan").symlink_to(tmp_path / "fifo")
    with pytest.raises(InputError, match="not a regular file"):
        check_output_paths([tmp_path / "out.plan"])
