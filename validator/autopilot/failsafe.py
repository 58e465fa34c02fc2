"""Each autopilot's failsafes: the parameter that chooses the action, the documented values,
the firmware default, the path each action flies, and the value our ``.param`` sets.

When a link, the battery or the position estimate fails (or the fence is breached), the
autopilot leaves the mission and flies a path of its own. Which path is a parameter; the
audit (:mod:`validator.failsafe`) checks every path an action may fly, its fallbacks
included ("SmartRTL or RTL" may fly RTL when SmartRTL has no path). The path kinds:

- ``mission``: the vehicle carries on with the (audited) mission: a failsafe that is off or
  only warns, or ArduCopter's FS_OPTIONS "continue in Auto";
- ``smartrtl``: ArduCopter's SmartRTL retraces the path it has flown (within SRTL_ACCURACY),
  so it is clear wherever the mission is; ``mission_path``: PX4's RTL_TYPE 2, the mission's
  own path to its landing, or reversed;
- ``land``, ``brake``, ``hold``: where the vehicle is (a Land descends vertically; AltHold and
  PX4's Altitude mode hold position only as well as the vehicle drifts);
- ``rtl``: climb (ArduCopter RTL_ALT, PX4 RTL_RETURN_ALT) where it is, then a straight line to
  home or the nearest rally point: the path the audit must prove clear from every point. Home
  is the one in force when the failsafe fires, which a mission's DO_SET_HOME may have moved
  (:mod:`validator.flight.home`).

Sources, read for exactly these firmware versions: ArduCopter 4.5.6 (7ce11b41:
ArduCopter/Parameters.cpp, AP_BattMonitor_Params.cpp, AC_Fence, AP_SmartRTL, AP_Rally,
mode_rtl.cpp) and PX4 v1.15 (commander_params.c, navigator's rtl_params.c, geofence_params.c,
rtl.cpp). A parameter a file does not set is taken at the firmware's default, which the
parameter tables hold (:mod:`validator.autopilot.ardupilot`, :mod:`validator.autopilot.px4`).

The actions we choose (``recommended``) never fly a path the audit has not proven clear:
ArduCopter retraces the flown path with SmartRTL, or lands where it is when SmartRTL has no
path; a critical battery, an EKF failure and dead reckoning land in place. PX4 v1.15 has no
SmartRTL: RC loss holds (the operator, still on the ground-station link, decides), link loss,
low battery and navigation loss land in place, the fence holds, and the remaining-flight-time
failsafe only warns (the battery failsafe lands).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

from validator.autopilot.fence import ARDUPILOT_FENCE, PX4_FENCE
from validator.autopilot.tables import param_table

PathKind = Literal["mission", "smartrtl", "mission_path", "land", "brake", "hold", "rtl"]


@dataclass(frozen=True)
class Action:
    """One documented value of a failsafe parameter: its name and the paths it may fly."""

    name: str
    paths: tuple[PathKind, ...]


@dataclass(frozen=True)
class Failsafe:
    """One failsafe: what fires it, the parameter choosing the action, the value our ``.param``
    writes (None: left at the firmware's default), and each value's paths."""

    trigger: str
    param: str
    recommended: float | None
    actions: Mapping[int, Action]

    def action(self, value: float) -> Action:
        """The action of ``value``; an undocumented value is assumed to fly straight home."""
        return self.actions.get(int(value), Action(f"undocumented value {value:g}", ("rtl",)))


def _actions(**by_value: tuple[str, tuple[PathKind, ...]]) -> dict[int, Action]:
    return {int(k[1:]): Action(name, paths) for k, (name, paths) in by_value.items()}


_OFF: tuple[PathKind, ...] = ("mission",)
_RTL: tuple[PathKind, ...] = ("rtl",)
_SRTL_RTL: tuple[PathKind, ...] = ("smartrtl", "rtl")
_SRTL_LAND: tuple[PathKind, ...] = ("smartrtl", "land")
_LAND: tuple[PathKind, ...] = ("land",)
# DO_LAND_START: jump to the mission's landing sequence, flying straight to it from anywhere
# (our plans have none, so ArduCopter flies RTL instead): audited as a straight return.
_LAND_START = ("Auto DO_LAND_START or RTL", _RTL)

# ArduCopter's RC, GCS, battery and dead-reckoning actions share these values
_COPTER_BATT = _actions(v0=("None", _OFF), v1=("Land", _LAND), v2=("RTL", _RTL),
                        v3=("SmartRTL or RTL", _SRTL_RTL), v4=("SmartRTL or Land", _SRTL_LAND),
                        v5=("Terminate", _LAND), v6=_LAND_START)

ARDUPILOT_FAILSAFES: tuple[Failsafe, ...] = (
    Failsafe("RC loss", "FS_THR_ENABLE", 5.0, _actions(
        v0=("Disabled", _OFF), v1=("Enabled always RTL", _RTL),
        v2=("Continue with Mission in Auto (removed in 4.0+)", _RTL),
        v3=("Enabled always Land", _LAND), v4=("Enabled always SmartRTL or RTL", _SRTL_RTL),
        v5=("Enabled always SmartRTL or Land", _SRTL_LAND), v6=_LAND_START,
        v7=("Enabled always Brake or Land", ("brake", "land")))),
    Failsafe("ground-station link loss", "FS_GCS_ENABLE", 4.0, _actions(
        v0=("Disabled/NoAction", _OFF), v1=("RTL", _RTL),
        v2=("RTL or Continue with Mission in Auto (removed in 4.0+)", _RTL),
        v3=("SmartRTL or RTL", _SRTL_RTL), v4=("SmartRTL or Land", _SRTL_LAND),
        v5=("Land", _LAND), v6=_LAND_START, v7=("Brake or Land", ("brake", "land")))),
    Failsafe("low battery", "BATT_FS_LOW_ACT", 4.0, _COPTER_BATT),
    Failsafe("critical battery", "BATT_FS_CRT_ACT", 1.0, _COPTER_BATT),
    Failsafe("EKF / GPS loss", "FS_EKF_ACTION", 1.0, _actions(
        v1=("Land", _LAND), v2=("AltHold", ("hold",)), v3=("Land even in Stabilize", _LAND))),
    Failsafe("dead reckoning", "FS_DR_ENABLE", 1.0,
             _actions(v0=("Disabled/NoAction", _OFF), v1=("Land", _LAND), v2=("RTL", _RTL),
                      v3=("SmartRTL or RTL", _SRTL_RTL), v4=("SmartRTL or Land", _SRTL_LAND),
                      v6=_LAND_START)),
    Failsafe("fence breach", "FENCE_ACTION", ARDUPILOT_FENCE.recommended["FENCE_ACTION"],
             _actions(v0=("Report Only", _OFF), v1=("RTL or Land", ("rtl", "land")),
                      v2=("Always Land", _LAND), v3=("SmartRTL or RTL or Land", _SRTL_RTL),
                      v4=("Brake or Land", ("brake", "land")),
                      v5=("SmartRTL or Land", _SRTL_LAND))),
)

# FS_OPTIONS (bitmask, default 16): bit 0 continues an Auto mission on RC loss, bit 1 on GCS
# loss; bit 3 lets a landing in progress finish on any failsafe, bit 4 lets a pilot in a manual
# mode keep flying on GCS loss. We set bits 3 and 4: a landing already under way (in place, or
# the mission's own audited return) goes on.
FS_OPTIONS_CONTINUE_AUTO = {"FS_THR_ENABLE": 1, "FS_GCS_ENABLE": 2}
FS_OPTIONS_RECOMMENDED = 24.0
# SmartRTL keeps a point each SRTL_ACCURACY metres and simplifies its path to within half that
# (AP_SmartRTL.h SMARTRTL_SIMPLIFY_EPSILON; loops closer than 0.99 x it are pruned): at the
# default 2 m its return passed 1.06 m nearer a zone than the mission did (SITL, depot).
# 1 m halves that; a straight leg still simplifies to its two ends, so SRTL_POINTS holds.
SRTL_ACCURACY_RECOMMENDED = 1.0

_PX4_MODE = _actions(v0=("None", _OFF), v1=("Warning", _OFF), v2=("Hold mode", ("hold",)),
                     v3=("Return mode", _RTL), v4=("Terminate", _LAND), v5=("Land mode", _LAND))

PX4_FAILSAFES: tuple[Failsafe, ...] = (
    Failsafe("RC loss", "NAV_RCL_ACT", 1.0, _actions(
        v0=("Disabled", _OFF), v1=("Hold mode", ("hold",)), v2=("Return mode", _RTL),
        v3=("Land mode", _LAND), v5=("Terminate", _LAND), v6=("Disarm", _LAND))),
    Failsafe("data-link loss", "NAV_DLL_ACT", 3.0, _actions(
        v0=("Disabled", _OFF), v1=("Hold mode", ("hold",)), v2=("Return mode", _RTL),
        v3=("Land mode", _LAND), v5=("Terminate", _LAND), v6=("Disarm", _LAND))),
    Failsafe("low battery", "COM_LOW_BAT_ACT", 2.0, _actions(
        v0=("Warning", _OFF), v2=("Land mode", _LAND),
        v3=("Return at critical level, land at emergency level", ("rtl", "land")))),
    Failsafe("remaining flight time low", "COM_FLTT_LOW_ACT", 1.0, _actions(
        v0=("None", _OFF), v1=("Warning", _OFF), v3=("Return", _RTL))),
    Failsafe("navigation (position) loss", "COM_POSCTL_NAVL", 1.0, _actions(
        v0=("Altitude/Manual", ("hold",)), v1=("Land/Descend", _LAND))),
    Failsafe("geofence breach", "GF_ACTION", PX4_FENCE.recommended["GF_ACTION"], _PX4_MODE),
    Failsafe("high wind", "COM_WIND_MAX_ACT", None, _PX4_MODE),
    Failsafe("imbalanced propeller", "COM_IMB_PROP_ACT", None, {
        -1: Action("Disabled", _OFF), 0: Action("Warning", _OFF), 1: Action("Return", _RTL),
        2: Action("Land", _LAND)}),
    Failsafe("actuator failure", "COM_ACT_FAIL_ACT", None, _actions(
        v0=("Warning only", _OFF), v1=("Hold mode", ("hold",)), v2=("Land mode", _LAND),
        v3=("Return mode", _RTL), v4=("Terminate", _LAND))),
)
# RC loss ignored in these modes (COM_RCL_EXCEPT bitmask, default 0): bit 0 Mission
COM_RCL_EXCEPT_MISSION = 1
RTL_TYPE_MISSION_PATH = 2  # the mission's own path to its landing, or reversed home
# rtl.cpp: rally points within 10 m of home are ignored; a rally point must be 2 m nearer than
# home to be chosen (MAX_DIST_FROM_HOME_FOR_LAND_APPROACHES, MIN_DIST_THRESHOLD)
PX4_RALLY_MIN_FROM_HOME_M = 10.0
PX4_RALLY_MARGIN_M = 2.0

FAILSAFES: dict[str, tuple[Failsafe, ...]] = {"ardupilot": ARDUPILOT_FAILSAFES,
                                              "px4": PX4_FAILSAFES}


# the parameters of the return path and of the failsafes' options, read with the actions
RETURN_PARAMS = {
    "ardupilot": ("FS_OPTIONS", "SRTL_POINTS", "SRTL_ACCURACY", "RTL_ALT", "RALLY_INCL_HOME",
                  "RALLY_LIMIT_KM"),
    "px4": ("COM_RCL_EXCEPT", "RTL_TYPE", "RTL_RETURN_ALT"),
}


# How each path is said to an operator (a lost link's verdict, :mod:`validator.mavlink.link_loss`)
PATH_SAID: dict[PathKind, str] = {
    "mission": "flies the mission on to its end",
    "smartrtl": "flies SmartRTL back along its flown path",
    "mission_path": "returns along the mission's own path",
    "land": "lands where it is",
    "brake": "brakes and holds",
    "hold": "holds where it is",
    "rtl": "flies straight home (RTL / Return), a path only the failsafe audit (--params) "
           "proves clear",
}

# the ground-station (data-link) loss failsafe: its action parameter and its timeout's
GCS_LOSS_PARAMS = {"ardupilot": ("FS_GCS_ENABLE", "FS_GCS_TIMEOUT"),
                   "px4": ("NAV_DLL_ACT", "COM_DL_LOSS_T")}


def failsafe_of(autopilot: str, param: str) -> Failsafe:
    """The failsafe whose action ``param`` chooses."""
    return next(f for f in FAILSAFES[autopilot] if f.param == param)


def said(action: Action) -> str:
    """What the vehicle does, in words: "it lands where it is", "it ..., else ..."."""
    return "it " + ", else ".join(PATH_SAID[p] for p in action.paths)


def failsafe_defaults(autopilot: str) -> dict[str, float]:
    """The firmware default of every parameter the failsafe audit reads: each action, and the
    return path's (the one table of defaults, :mod:`validator.autopilot.ardupilot` / ``px4``)."""
    table = param_table(autopilot)
    return {n: table[n].default for n in FAILSAFE_PARAMS[autopilot]}


def recommended_failsafes(autopilot: str, srtl_points: float | None = None) -> dict[str, float]:
    """The failsafe values our ``.param`` writes (the fence's own are in
    :mod:`validator.autopilot.fence`); ArduCopter's SRTL_POINTS is ``srtl_points``."""
    fence = {"FENCE_ACTION", "GF_ACTION"}
    out = {f.param: f.recommended for f in FAILSAFES[autopilot]
           if f.recommended is not None and f.param not in fence}
    if autopilot == "ardupilot":
        out["FS_OPTIONS"] = FS_OPTIONS_RECOMMENDED
        out["SRTL_ACCURACY"] = SRTL_ACCURACY_RECOMMENDED
        if srtl_points is not None:
            out["SRTL_POINTS"] = srtl_points
    return out


FAILSAFE_PARAMS: dict[str, tuple[str, ...]] = {
    ap: tuple(dict.fromkeys([f.param for f in FAILSAFES[ap]] + list(RETURN_PARAMS[ap])))
    for ap in FAILSAFES
}
"""Every parameter the failsafe audit reads, by autopilot."""
