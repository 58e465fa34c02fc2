"""The validator's front door (:mod:`validator.api`) and the choice of a vehicle
(:mod:`validator.mavlink.vehicles`): typed results, the same verdicts as the command."""

from __future__ import annotations

import os
import stat

import pytest
import yaml

import validator
from tests.validator.builders import make_site, waypoint_plan
from validator import api
from validator.errors import InputError
from validator.mavlink.vehicles import (
    DEFAULT_BINARY_SPEEDUP,
    DEFAULT_PX4_SPEEDUP,
    DEFAULT_SITL_SPEEDUP,
    choose_vehicle,
)
from validator.plan_format import Autopilot, write_plan
from validator.site import site_to_dict
from validator.track_file import write_track
from validator.validation import validate_mission

NFZ = ((100.0, 0.0, 20.0),)


@pytest.fixture(autouse=True)
def no_autopilot_binary(monkeypatch):
    """The built-in vehicle, even where an autopilot SITL is installed."""
    monkeypatch.delenv("ARDUPILOT_SITL", raising=False)
    monkeypatch.delenv("PX4_SITL", raising=False)


@pytest.fixture()
def files(tmp_path):
    site = make_site(nfz=NFZ)
    site_path = tmp_path / "site.yaml"
    site_path.write_text(yaml.safe_dump(site_to_dict(site)))
    plan_path = tmp_path / "mission.plan"
    write_plan(waypoint_plan(site, [(40.0, 30.0), (160.0, 30.0), (160.0, -40.0)], v=8.0),
               plan_path)
    return site_path, plan_path


def test_the_package_exports_the_front_door():
    assert sorted(validator.__all__) == sorted(api.__all__)
    for name in validator.__all__:
        assert getattr(validator, name) is getattr(api, name)
    with pytest.raises(AttributeError):
        validator.no_such_name  # noqa: B018


def test_audit_and_replay_agree_with_the_command(files):
    site_path, plan_path = files
    site, plan = api.load_site(site_path), api.read_plan(plan_path)
    audit = api.audit_plan(plan, site)
    replayed = api.replay_plan(plan, site)
    command = validate_mission(plan_path, site_path, replay_flight=True)
    assert audit.violations == [] and audit.nfz[0].clearance_m > 0
    assert audit.nfz[0].clearance_m == pytest.approx(command.audit.nfz[0].clearance_m)
    assert replayed.profile.name == "arducopter"
    assert command.replay is not None
    assert replayed.report.nfz[0].clearance_m == pytest.approx(command.replay.nfz[0].clearance_m)


def test_a_leg_through_the_zone_is_a_violation(files, tmp_path):
    site_path, _ = files
    site = api.load_site(site_path)
    bad = waypoint_plan(make_site(nfz=NFZ), [(40.0, 5.0), (160.0, 5.0)], v=8.0)
    assert api.audit_plan(bad, site).violations
    assert api.replay_plan(bad, site).report.violations


def test_replay_step_is_checked(files):
    site_path, plan_path = files
    with pytest.raises(InputError, match="dt_s"):
        api.replay_plan(api.read_plan(plan_path), api.load_site(site_path), dt_s=0.5)


def test_buffer_override(files):
    site_path, _ = files
    assert api.load_site(site_path, buffer_m=7.5).buffer_m == 7.5


def test_the_days_forecast_overrides_the_sites_wind(files):
    site_path, _ = files
    site = api.load_site(site_path, wind="6@135,1.5")
    assert site.wind == api.Wind(6.0, 135.0, 1.5)
    assert api.load_site(site_path, wind=api.Wind(4.0, 270.0)).wind == api.Wind(4.0, 270.0)
    assert api.load_site(site_path, wind="0").wind is None
    assert api.load_site(site_path).wind is None
    with pytest.raises(InputError, match="^wind 7@abc: expected SPEED@FROM"):
        api.load_site(site_path, wind="7@abc")


def test_a_replay_flies_in_the_sites_wind(files):
    site_path, plan_path = files
    plan = api.read_plan(plan_path)
    calm = api.replay_plan(plan, api.load_site(site_path))
    windy = api.replay_plan(plan, api.load_site(site_path, wind="6@90"))
    assert windy.report.duration_s > calm.report.duration_s


def test_fly_on_the_builtin_vehicle_and_score_the_recorded_track_again(files, tmp_path):
    site_path, plan_path = files
    site, plan = api.load_site(site_path), api.read_plan(plan_path)
    flown = api.fly_plan(plan, site, api.choose_vehicle(plan, speedup_x=50.0))
    assert flown.kind == "builtin" and flown.report.violations == []
    assert flown.telemetry.end_reason == "landed"
    track = tmp_path / "flown.csv"
    write_track(track, flown.recorded)
    again = api.score_recorded(plan, site, track)
    assert again.nfz[0].clearance_m == pytest.approx(flown.report.nfz[0].clearance_m, abs=0.01)


def test_a_fault_needs_an_autopilot_and_one_its_simulator_makes(files):
    site_path, plan_path = files
    site, plan = api.load_site(site_path), api.read_plan(plan_path)
    with pytest.raises(InputError, match="^fault: needs an autopilot SITL"):
        api.fly_plan(plan, site, api.choose_vehicle(plan), fault="rc-loss")
    # refused before any link is opened: nothing listens at this URL
    with pytest.raises(InputError, match="^fault solar-flare: not simulated on ArduCopter"):
        api.fly_plan(plan, site, api.choose_vehicle(plan, url="tcp:127.0.0.1:9"),
                     fault="solar-flare")  # type: ignore[arg-type]


def test_the_vehicle_is_chosen_as_the_command_chooses(files, tmp_path, monkeypatch):
    _, plan_path = files
    plan = api.read_plan(plan_path)
    assert choose_vehicle(plan).kind == "builtin"
    assert choose_vehicle(plan).speedup_x == DEFAULT_SITL_SPEEDUP
    external = choose_vehicle(plan, url="tcp:127.0.0.1:5760", sysid=3)
    assert (external.kind, external.url, external.sysid) == ("external", "tcp:127.0.0.1:5760", 3)
    assert not external.starts_here
    with pytest.raises(InputError, match="signing-key"):
        choose_vehicle(plan, signing_key=b"k" * 32)
    fake = tmp_path / "arducopter"
    fake.write_text("#!/bin/sh\n")
    fake.chmod(fake.stat().st_mode | stat.S_IXUSR)
    monkeypatch.setenv("ARDUPILOT_SITL", str(fake))
    chosen = choose_vehicle(plan)
    assert (chosen.kind, chosen.binary, chosen.speedup_x) == (
        "sitl-binary", fake, DEFAULT_BINARY_SPEEDUP)
    px4 = tmp_path / "px4"
    px4.write_text("#!/bin/sh\n")
    px4.chmod(px4.stat().st_mode | stat.S_IXUSR)
    plan.firmware_type = int(Autopilot.PX4)
    monkeypatch.setenv("PX4_SITL", str(px4))
    assert choose_vehicle(plan).speedup_x == DEFAULT_PX4_SPEEDUP
    not_exec = tmp_path / "not-exec"
    not_exec.write_text("")
    os.chmod(not_exec, 0o644)
    with pytest.raises(InputError, match="not an executable"):
        choose_vehicle(plan, binary=not_exec)
