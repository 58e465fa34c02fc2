"""Paths written inside a user's file: resolved from its folder, never leading out of it."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from validator.errors import InputError
from validator.input_files import parse_json, parse_yaml, resolve_referenced_path


@pytest.fixture()
def site(tmp_path: Path) -> Path:
    (tmp_path / "sites" / "zones").mkdir(parents=True)
    path = tmp_path / "sites" / "site.yaml"
    path.write_text("name: x\n")
    return path


@pytest.mark.parametrize("ref, expected", [
    ("airspace.geojson", "airspace.geojson"),
    ("zones/a.geojson", "zones/a.geojson"),
    ("zones/../b.geojson", "b.geojson"),
    ("./zones/./c.geojson", "zones/c.geojson"),
    ("~/d.geojson", "~/d.geojson"),  # not the home folder
])
def test_relative_paths_are_taken_from_the_files_folder(site: Path, ref: str,
                                                         expected: str) -> None:
    got = resolve_referenced_path(site, ref, field="airspace")
    assert got == (site.parent / expected).resolve()


def test_the_folder_is_the_files_not_the_working_directorys(site: Path,
                                                            monkeypatch: pytest.MonkeyPatch
                                                            ) -> None:
    monkeypatch.chdir(site.parent / "zones")
    got = resolve_referenced_path(Path("..") / "site.yaml", "zones/a.geojson", field="airspace")
    assert got == site.parent / "zones" / "a.geojson"


@pytest.mark.parametrize("ref", ["../secret.geojson", "zones/../../secret.geojson",
                                 "zones/../../sites/../secret.geojson", ".."])
def test_a_path_out_of_the_folder_is_refused_and_reported(site: Path, ref: str) -> None:
    with pytest.raises(InputError) as err:
        resolve_referenced_path(site, ref, field="airspace")
    outside = (site.parent / ref).resolve()
    assert str(err.value) == (f"{site}: airspace: {ref!r} resolves to {outside}, outside "
                              f"{site.parent.resolve()} (the folder of the file that names it)")


def test_a_symbolic_link_out_of_the_folder_is_refused(site: Path, tmp_path: Path) -> None:
    (tmp_path / "secret.geojson").write_text("{}")
    os.symlink(tmp_path / "secret.geojson", site.parent / "zones" / "link.geojson")
    os.symlink(tmp_path, site.parent / "up")
    for ref in ("zones/link.geojson", "up/secret.geojson"):
        with pytest.raises(InputError, match="outside"):
            resolve_referenced_path(site, ref, field="airspace")


def test_an_absolute_path_only_when_the_user_allows_it(site: Path, tmp_path: Path) -> None:
    target = tmp_path / "elsewhere.geojson"
    with pytest.raises(InputError, match=r"airspace: '/.*' is an absolute path; name the file "
                                         r"relative to "):
        resolve_referenced_path(site, str(target), field="airspace")
    assert resolve_referenced_path(site, str(target), field="airspace",
                                   allow_absolute=True) == target.resolve()
    # allowing absolute paths does not let a relative one out
    with pytest.raises(InputError, match="outside"):
        resolve_referenced_path(site, "../elsewhere.geojson", field="airspace",
                                allow_absolute=True)


@pytest.mark.parametrize("ref, message", [
    ("", "expected a file path"),
    (None, "expected a file path"),
    (3, "expected a file path"),
    ("a\0b", "NUL character"),
])
def test_a_value_that_is_no_path_is_refused(site: Path, ref: object, message: str) -> None:
    with pytest.raises(InputError, match=f"^{site}: airspace: .*{message}"):
        resolve_referenced_path(site, ref, field="airspace")


def test_a_symbolic_link_loop_is_an_input_error(site: Path) -> None:
    os.symlink("loop", site.parent / "loop")
    with pytest.raises(InputError, match="airspace"):
        resolve_referenced_path(site, "loop/x.geojson", field="airspace")


@pytest.mark.parametrize("text, message", [
    ("name: a\nsafety: {buffer_m: 3.0}\nname: b\n", "s.yaml: line 3: key 'name' given twice"),
    ("safety: {buffer_m: 3.0, buffer_m: 5.0}\n", "s.yaml: line 1: key 'buffer_m' given twice"),
])
def test_a_yaml_key_given_twice_is_refused(text: str, message: str) -> None:
    # the parser kept the last one silently: a second name or buffer overrode the first
    with pytest.raises(InputError, match=message):
        parse_yaml(text, "s.yaml")


def test_a_yaml_merge_may_still_override_what_it_brings() -> None:
    text = "base: &b {x: 1, y: 2}\nother:\n  <<: *b\n  x: 3\n"
    assert parse_yaml(text, "s.yaml") == {"base": {"x": 1, "y": 2}, "other": {"x": 3, "y": 2}}


def test_a_json_key_given_twice_is_refused() -> None:
    with pytest.raises(InputError, match="p.plan: key 'items' given twice in one object"):
        parse_json('{"mission": {"items": [], "items": [1]}}', "p.plan")
