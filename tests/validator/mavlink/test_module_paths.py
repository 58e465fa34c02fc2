"""Names that moved when the MAVLink modules were split (issue 12) stay importable from their
old modules, as the very objects of their new homes, so code written against the old paths
keeps working."""

from __future__ import annotations

import importlib

import pytest

MOVED = {
    "validator.mavlink.link": {
        "validator.mavlink.connection": ["DEFAULT_RETRY_S", "DEFAULT_TIMEOUT_S",
                                         "GCS_COMPONENT_ID", "GCS_SYSTEM_ID", "LinkError",
                                         "VehicleInfo", "command_name", "open_connection"],
        "validator.mavlink.mission_protocol": ["BOOT_PATIENCE_S", "RESENDS_BEFORE_RESTART",
                                               "RESTART_AFTER_S", "TRANSFER_ATTEMPTS"],
        "validator.mavlink.param_protocol": ["ParamValue"],
    },
    "validator.mavlink.driver": {
        "validator.mavlink.modes": ["ARDUCOPTER_MODES", "PX4_MODES", "ModeNumbers", "mode_name",
                                    "modes_for"],
        "validator.mavlink.telemetry": ["Telemetry", "recorded_track", "telemetry_track"],
    },
}


@pytest.mark.parametrize("old", sorted(MOVED))
def test_moved_names_stay_importable_from_the_old_module(old):
    module = importlib.import_module(old)
    for new, names in MOVED[old].items():
        home = importlib.import_module(new)
        for name in names:
            assert getattr(module, name) is getattr(home, name), f"{old}.{name}"
