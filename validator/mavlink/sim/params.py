"""The simulated vehicle's parameters: ArduCopter's and its flight profile's, and the vehicle
side of the parameter protocol (PARAM_REQUEST_LIST, PARAM_REQUEST_READ, PARAM_SET)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from validator.autopilot.ardupilot import PARAMS as ARDUPILOT_PARAMS
from validator.errors import InputError
from validator.mavlink.autoflight import vehicle_profile
from validator.mavlink.sim.arducopter import BASE_PARAMS, INT16, REAL32
from validator.mavlink.sim.config import VehicleConfig
from validator.motion.limits import VehicleLimits
from validator.motion.profile import PARAM_SPECS, Profile


class ParamTable:
    """Name -> [value, MAV_PARAM_TYPE] in :attr:`values`, in the order the vehicle numbers
    them; a value is accepted only if the flight profile accepts it."""

    def __init__(self, config: VehicleConfig, limits: VehicleLimits) -> None:
        self.profile_name = config.profile
        self.limits = limits
        profile = vehicle_profile(config.profile, limits,
                                  {**{k: v for k, (v, _) in BASE_PARAMS.items()}, **config.params})
        self.values: dict[str, list[float]] = {k: [v, t] for k, (v, t) in BASE_PARAMS.items()}
        specs = PARAM_SPECS[profile.name]
        for name, value in profile.params.items():
            self.values[name] = [float(value), float(specs[name].mav_type)]
        for name, value in config.params.items():
            if name not in self.values:
                raise InputError(f"--param {name}: the vehicle has no such parameter")
            self.values[name][0] = float(value)
        self.values["SYSID_THISMAV"] = [float(config.system_id), float(INT16)]

    def value(self, name: str) -> float:
        return float(self.values[name][0])

    def si(self, name: str) -> float:
        """An ArduCopter parameter's value in SI units (:mod:`validator.autopilot.ardupilot`)."""
        return self.value(name) * ARDUPILOT_PARAMS[name].to_si

    def profile(self, changes: Mapping[str, float] | None = None) -> Profile:
        """The flight profile at the current values (with ``changes``); raises
        :class:`InputError` for a value out of the profile's range."""
        values = {k: float(v[0]) for k, v in self.values.items()}
        values.update(changes or {})
        return vehicle_profile(self.profile_name, self.limits, values)

    # -- the protocol: ``mav`` sends the answers ---------------------------------------------

    def send(self, mav: Any, name: str) -> None:
        names = list(self.values)
        value, ptype = self.values[name]
        mav.param_value_send(name.encode("ascii"), float(value), int(ptype), len(names),
                             names.index(name))

    def on_list(self, mav: Any, _msg: Any) -> None:
        for name in self.values:
            self.send(mav, name)

    def on_read(self, mav: Any, msg: Any) -> None:
        names = list(self.values)
        name = msg.param_id if msg.param_index < 0 else (
            names[msg.param_index] if msg.param_index < len(names) else None)
        if name in self.values:
            self.send(mav, name)

    def on_set(self, mav: Any, msg: Any) -> None:
        name = msg.param_id
        if name not in self.values or not math.isfinite(msg.param_value):
            return  # ArduPilot ignores unknown parameters: the ground station times out
        ptype = self.values[name][1]
        value = float(msg.param_value)
        if ptype != REAL32:
            value = float(int(round(value)))
        try:
            self.profile({name: value})
        except InputError:
            value = self.values[name][0]  # out of range: keep it; the reply says so
        self.values[name][0] = value
        self.send(mav, name)
