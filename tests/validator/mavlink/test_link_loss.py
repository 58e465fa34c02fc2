"""What the verdict of a lost link says the vehicle will do on its own, from its failsafe
parameters (read from the vehicle; here from a table)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from validator.mavlink import link_loss
from validator.mavlink.link_loss import gcs_failsafe, land_mode
from validator.mavlink.modes import ARDUCOPTER_MODES, PX4_MODES


def vehicle_with(monkeypatch, params: dict[str, float], *, px4: bool = False):
    monkeypatch.setattr(link_loss, "_read_quickly", lambda _link, name, _s: params.get(name))
    return SimpleNamespace(vehicle=SimpleNamespace(is_px4=px4))


@pytest.mark.parametrize("params, said", [
    ({"FS_GCS_ENABLE": 0}, "its ground-station link loss failsafe is off: it flies the mission "
                           "on to its end (FS_GCS_ENABLE 0)"),
    ({"FS_GCS_ENABLE": 5, "FS_GCS_TIMEOUT": 5}, "after 5 s without us, it lands where it is "
                                                "(FS_GCS_ENABLE 5: Land)"),
    ({"FS_GCS_ENABLE": 4, "FS_GCS_TIMEOUT": 5, "FS_OPTIONS": 24},
     "after 5 s without us, it flies SmartRTL back along its flown path, else lands where it "
     "is (FS_GCS_ENABLE 4: SmartRTL or Land)"),
    ({"FS_GCS_ENABLE": 1, "FS_GCS_TIMEOUT": 3, "FS_OPTIONS": 2},
     "after 3 s without us, it flies the mission on in AUTO (FS_OPTIONS continues it), else "
     "flies straight home (RTL / Return), a path only the failsafe audit (--params) proves "
     "clear (FS_GCS_ENABLE 1: RTL)"),
    ({"FS_GCS_ENABLE": 9}, "FS_GCS_ENABLE 9: an action this tool does not know "
                           "(FS_GCS_ENABLE 9)"),
    ({}, "the vehicle did not report FS_GCS_ENABLE: what it does without a link is unknown"),
])
def test_arducopters_failsafe_is_said_as_its_parameters_have_it(monkeypatch, params, said):
    assert gcs_failsafe(vehicle_with(monkeypatch, params)) == said


def test_px4s_data_link_failsafe_is_said_too(monkeypatch):
    link = vehicle_with(monkeypatch, {"NAV_DLL_ACT": 3, "COM_DL_LOSS_T": 10}, px4=True)
    assert gcs_failsafe(link) == ("after 10 s without us, it lands where it is "
                                  "(NAV_DLL_ACT 3: Land mode)")


def test_every_documented_gcs_action_is_said_from_the_one_failsafe_table(monkeypatch):
    from validator.autopilot.failsafe import failsafe_of
    for px4, name in ((False, "FS_GCS_ENABLE"), (True, "NAV_DLL_ACT")):
        for value, action in failsafe_of("px4" if px4 else "ardupilot", name).actions.items():
            said = gcs_failsafe(vehicle_with(monkeypatch, {name: value}, px4=px4))
            assert said.endswith(f"({name} {value}: {action.name})") or value == 0, said


def test_land_is_each_autopilots_own_mode_number():
    assert land_mode(ARDUCOPTER_MODES) == 9
    assert land_mode(PX4_MODES) == (4 << 16) | (6 << 24)  # AUTO / LAND
