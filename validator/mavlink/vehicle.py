"""The simulated vehicle's former address: it now lives in :mod:`validator.mavlink.sim`, one
idea a module; these names stay importable from here for code written against it."""

from validator.mavlink.sim.arducopter import (
    ARMABLE_MODES,
    BASE_PARAMS,
    FORCE_DISARM_MAGIC,
    INT8,
    INT16,
    REAL32,
    SITL_TOP_SPEED_MPS,
    CopterMode,
)
from validator.mavlink.sim.commands import kind_is_int
from validator.mavlink.sim.config import VehicleConfig
from validator.mavlink.sim.mission_server import (
    MAVLINK_PACKET_TYPES_FOR_MAVSDK,
    MAVSDK_PACKET_TYPES_TO_GCS,
)
from validator.mavlink.sim.radio import LossyWriter
from validator.mavlink.sim.vehicle import MISSION_CURRENT_PERIOD_S, SitlVehicle

__all__ = [
    "ARMABLE_MODES",
    "BASE_PARAMS",
    "FORCE_DISARM_MAGIC",
    "INT8",
    "INT16",
    "MAVLINK_PACKET_TYPES_FOR_MAVSDK",
    "MAVSDK_PACKET_TYPES_TO_GCS",
    "MISSION_CURRENT_PERIOD_S",
    "REAL32",
    "SITL_TOP_SPEED_MPS",
    "CopterMode",
    "LossyWriter",
    "SitlVehicle",
    "VehicleConfig",
    "kind_is_int",
]
