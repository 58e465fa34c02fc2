"""Which autopilot parameters switch the geofence on, and which breach actions are safe here.

An uploaded fence does nothing until the autopilot's fence is enabled, and what the vehicle
does on a breach is a parameter too. A breach action is *safe* for a mission among several
no-fly zones when it never flies a straight line across another zone: stopping, landing where
the vehicle is, or retracing the path it flew are; a return straight home is not.

ArduCopter 4.5 (``AC_Fence``): ``FENCE_ENABLE`` 1; ``FENCE_TYPE`` bit 4 (the polygon and
circle fences we upload; bit 2 is a home-centred circle of FENCE_RADIUS, not ours);
``FENCE_ACTION`` 5, *SmartRTL or Land*: the vehicle flies back along the path it has flown (which
the audit proved clear of every zone) and lands at home, or lands where it is when no SmartRTL
path is available. Brake (4) is also safe but leaves the vehicle hovering at the zone's edge
until someone takes over; RTL (1) and *SmartRTL or RTL* (3) can fly straight home across a zone.

PX4 v1.15 (geofence in navigator): the fence is checked whenever fence items are loaded;
``GF_ACTION`` says what a breach does: 2, Hold (loiter where it is), or 5, Land. PX4's Return
(3) flies to home or a rally point first, in a straight line.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass


@dataclass(frozen=True)
class FenceRules:
    """One autopilot's geofence parameters: ``recommended`` switches the fence on with a safe
    breach action; :meth:`problems` says why other values leave it off or unsafe."""

    autopilot: str  # "ardupilot" or "px4"
    recommended: Mapping[str, float]
    enable: str | None  # the parameter that must be 1, or None when loading the fence enables it
    type_param: str | None  # a bitmask that must include type_bits
    type_bits: int
    action: str
    safe_actions: frozenset[int]
    action_names: Mapping[int, str]

    @property
    def param_names(self) -> tuple[str, ...]:
        """The parameters :meth:`problems` reads."""
        return tuple(n for n in (self.enable, self.type_param, self.action) if n is not None)

    def problems(self, params: Mapping[str, float]) -> list[str]:
        """Why ``params`` (the values a vehicle holds or a file sets; a missing name means
        the file leaves it at the vehicle's default) do not give an enabled fence with a safe
        breach action; empty when they do."""
        out: list[str] = []
        if self.enable is not None and params.get(self.enable) != 1:
            out.append(f"{self.enable} is {_shown(params.get(self.enable))}, not 1: the "
                       "uploaded fence is inactive")
        if self.type_param is not None:
            value = params.get(self.type_param)
            if value is None or not int(value) & self.type_bits:
                out.append(f"{self.type_param} is {_shown(value)}: it must include "
                           f"{self.type_bits} (polygon and circle fences)")
        act = params.get(self.action)
        if act is None or int(act) not in self.safe_actions:
            name = self.action_names.get(int(act), "unknown") if act is not None else ""
            safe = ", ".join(f"{a} ({self.action_names[a]})" for a in sorted(self.safe_actions))
            out.append(f"{self.action} is {_shown(act)}{f' ({name})' if name else ''}: "
                       f"a breach must not fly straight across another zone (use {safe})")
        return out


def _shown(value: float | None) -> str:
    return "not set" if value is None else f"{value:g}"


ARDUPILOT_FENCE = FenceRules(
    autopilot="ardupilot",
    recommended={"FENCE_TYPE": 4.0, "FENCE_ACTION": 5.0, "FENCE_ENABLE": 1.0},
    enable="FENCE_ENABLE",
    type_param="FENCE_TYPE",
    type_bits=4,
    action="FENCE_ACTION",
    safe_actions=frozenset({2, 4, 5}),
    action_names={0: "Report Only", 1: "RTL or Land", 2: "Always Land",
                  3: "SmartRTL or RTL or Land", 4: "Brake or Land", 5: "SmartRTL or Land"},
)
PX4_FENCE = FenceRules(
    autopilot="px4",
    recommended={"GF_ACTION": 2.0},
    enable=None,
    type_param=None,
    type_bits=0,
    action="GF_ACTION",
    safe_actions=frozenset({2, 5}),
    action_names={0: "None", 1: "Warning", 2: "Hold", 3: "Return", 4: "Terminate", 5: "Land"},
)
FENCE_RULES = {"ardupilot": ARDUPILOT_FENCE, "px4": PX4_FENCE}
