"""Each autopilot's flight mode numbers (HEARTBEAT.custom_mode) and names: ArduCopter's custom
modes, PX4's main and sub modes packed into one number."""

from __future__ import annotations

from dataclasses import dataclass

from validator.mavlink.connection import Connection
from validator.mavlink.wire import mavlink, mavutil


@dataclass(frozen=True)
class ModeNumbers:
    """HEARTBEAT.custom_mode values of the modes the driver uses, and how to ask for them."""

    hold: int  # a position-holding mode the vehicle can arm and take off in
    auto: int  # mission mode
    px4: bool = False

    def set_mode_params(self, custom_mode: int) -> tuple[float, float, float]:
        """DO_SET_MODE param1..3 for ``custom_mode``."""
        base = float(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
        if self.px4:  # PX4 takes main and sub mode apart
            return base, float((custom_mode >> 16) & 0xFF), float((custom_mode >> 24) & 0xFF)
        return base, float(custom_mode), 0.0


def _px4_mode(main: int, sub: int = 0) -> int:
    return (main << 16) | (sub << 24)


ARDUCOPTER_MODES = ModeNumbers(
    hold=mavutil.mode_mapping_byname(mavlink.MAV_TYPE_QUADROTOR)["GUIDED"],
    auto=mavutil.mode_mapping_byname(mavlink.MAV_TYPE_QUADROTOR)["AUTO"],
)
PX4_MODES = ModeNumbers(
    hold=_px4_mode(mavutil.PX4_CUSTOM_MAIN_MODE_AUTO, mavutil.PX4_CUSTOM_SUB_MODE_AUTO_LOITER),
    auto=_px4_mode(mavutil.PX4_CUSTOM_MAIN_MODE_AUTO, mavutil.PX4_CUSTOM_SUB_MODE_AUTO_MISSION),
    px4=True,
)


def modes_for(link: Connection) -> ModeNumbers:
    """The mode numbers of the connected vehicle's autopilot."""
    return PX4_MODES if link.vehicle.is_px4 else ARDUCOPTER_MODES


def mode_name(link: Connection, custom_mode: int) -> str:
    """The vehicle's name for ``custom_mode`` (ArduCopter's or PX4's), or its number."""
    if link.vehicle.is_px4:
        px4 = {_px4_mode(main, sub): name for name, (_, main, sub) in mavutil.px4_map.items()}
        return str(px4.get(custom_mode, custom_mode))
    names = mavutil.mode_mapping_bynumber(mavlink.MAV_TYPE_QUADROTOR) or {}
    return str(names.get(custom_mode, custom_mode))
