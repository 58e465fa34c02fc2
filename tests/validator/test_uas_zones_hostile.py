"""Hostile UAS-zone files: every mutation of our own ED-269 and ED-318 files is read, or refused
with one line naming the file (and through the command: exit 2, one line, no output file)."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from mission_planner.cli import plan_mission_main
from tests.validator.test_hostile_readers import HYPO, _mutate
from validator.errors import InputError
from validator.site import load_site
from validator.uas_zones.applicability import AirspaceOptions, parse_at

DATA = Path(__file__).parents[1] / "data" / "airspace"
DOCS = {"zones.json": json.loads((DATA / "zones-ed269.json").read_text()),
        "zones.geojson": json.loads((DATA / "zones-ed318.geojson").read_text())}
SITE = yaml.safe_load((DATA / "site.yaml").read_text())
AT = AirspaceOptions(parse_at("2026-12-02T22:30:00+01:00"), 900.0)


def _write(folder: Path, name: str, doc: Any) -> Path:
    (folder / name).write_text(json.dumps(doc, allow_nan=True))
    (folder / "site.yaml").write_text(yaml.safe_dump({**SITE, "airspace": name}))
    return folder / "site.yaml"


@HYPO
@given(st.data(), st.sampled_from(sorted(DOCS)))
def test_zone_file_mutations_read_or_refuse_in_one_line(
        tmp_path_factory: pytest.TempPathFactory, data: st.DataObject, name: str) -> None:
    folder = tmp_path_factory.mktemp("uas")
    site_file = _write(folder, name, _mutate(DOCS[name], data.draw))
    try:
        site = load_site(site_file, AT)
    except InputError as err:
        assert "\n" not in str(err) and str(err).startswith(str(folder)), str(err)
        return
    for zone in site.polygon_zones:
        assert np.all(np.isfinite(zone.vertices_xy_m)) and zone.area_m2 > 0
    assert np.all(np.isfinite(site.nfz_xy_m)) and np.all(site.nfz_radius_m > 0)
    assert json.dumps([d.as_dict() for d in site.airspace.table])  # the report's table


@HYPO
@given(st.data(), st.sampled_from(sorted(DOCS)))
def test_plan_mission_on_a_mutant_exits_2_with_one_line(
        tmp_path_factory: pytest.TempPathFactory, data: st.DataObject, name: str) -> None:
    folder = tmp_path_factory.mktemp("uas-cli")
    site_file = _write(folder, name, _mutate(DOCS[name], data.draw))
    # a negative buffer is refused right after the site is read, so a mutant that reads is
    # refused too, without planning
    argv = [str(site_file), "-o", str(folder / "m.plan"), "--at", "2026-12-02T22:30+01:00",
            "--buffer-m", "-1", "--quiet"]
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        status = plan_mission_main(argv)
    lines = err.getvalue().strip().splitlines()
    assert status == 2 and len(lines) == 1 and lines[0].startswith("plan-mission: "), lines
    assert not (folder / "m.plan").exists()
