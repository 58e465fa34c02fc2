"""How a simulated vehicle starts and runs: home, system id, clock, packet loss, flight model."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from validator.mavlink.sim.arducopter import SITL_TOP_SPEED_MPS
from validator.motion.limits import VehicleLimits
from validator.site import DEFAULT_MAX_ACCEL_MPS2, DEFAULT_MAX_JERK_MPS3


@dataclass(frozen=True)
class VehicleConfig:
    """How the simulated vehicle starts and runs.

    ``home`` is (lat deg, lon deg, alt m AMSL); ``speedup`` simulated seconds per wall second;
    ``loss`` the fraction of packets dropped in each direction (``seed`` makes it repeatable);
    ``telemetry_hz`` the GLOBAL_POSITION_INT rate in simulated time; ``profile`` the flight
    model flown in AUTO (:data:`validator.motion.profile.PROFILES`); ``params`` initial parameter
    values (autopilot units) over ArduCopter's defaults; ``max_speed_mps`` the vehicle's top
    speed (the profile's VEHICLE_SPEED_MAX default); ``signing_key`` a MAVLink 2 signing key.
    """

    home: tuple[float, float, float]
    system_id: int = 1
    speedup: float = 1.0
    loss: float = 0.0
    seed: int = 0
    telemetry_hz: float = 20.0
    profile: str = "arducopter"
    params: Mapping[str, float] = field(default_factory=dict)
    max_speed_mps: float = SITL_TOP_SPEED_MPS
    signing_key: bytes | None = None  # sign, and refuse what is not signed (mavlink.signing)

    @property
    def limits(self) -> VehicleLimits:
        """The vehicle its flight model flies: ``max_speed_mps``, a site's default acceleration
        and jerk limits, at home's altitude."""
        return VehicleLimits(self.max_speed_mps, DEFAULT_MAX_ACCEL_MPS2, DEFAULT_MAX_JERK_MPS3,
                             self.home[2])
