"""Multicopter flight profiles: how an autopilot turns a resolved :class:`~validator.flight.Flight`
into motion in time.

Three profiles (:func:`make_profile`), parameters in the autopilot's own names and units so a
``.param`` file's values can be passed straight through (``--param WPNAV_ACCEL=500``):

``ideal``
    Straight lines at the commanded speeds, instant speed changes, exact holds: the plan's own
    timing. Legs without a commanded speed fly at ``SPEED`` (m/s, default: the site's V).
``arducopter``
    ArduCopter 4.x S-curve navigation. Every leg is planned from rest to rest as a jerk-limited
    profile (WPNAV_JERK, WPNAV_ACCEL, speed = the DO_CHANGE_SPEED in force or WPNAV_SPEED,
    capped by ANGLE_MAX and the vehicle's top speed), so a leg shorter than about
    v²/A + v·A/J never reaches v. When a waypoint has no hold, the next leg starts while this
    one decelerates, as soon as the blended target stays within WPNAV_RADIUS of the waypoint,
    slower than both legs' speeds and within the corner acceleration (WPNAV_ACCEL_C, 0 = twice
    WPNAV_ACCEL): the two profiles add up, which rounds the corner on the inside of the turn
    and passes collinear waypoints without stopping. The waypoint counts as reached half-way
    through that overlap. Holds are truncated to whole seconds, as ArduCopter stores them.
    Speed is capped by the lean-limited top speed (:func:`top_speed_mps`: ANGLE_MAX or
    PSC_ANGLE_MAX against a drag fitted to the SITL quad, VEHICLE_DRAG, at the air density of
    ALT_AMSL). A takeoff from the ground climbs after the lift-off delay; a landing descends at
    WPNAV_SPEED_DN to LAND_ALT_LOW, then at LAND_SPEED, and ends when the land detector
    fires; every stop at a waypoint is counted STOP_LAG_S after the S-curve ends (all three
    fitted to ArduCopter 4.5.6 SITL flights, ``../shared/data/arducopter-sitl-2``).
``px4``
    PX4 v1.15 mission following, its own rules ported (:mod:`validator.motion.px4`): toward
    each waypoint the fastest speed from which it can still arrive, with PX4's conservative
    2·A/J reaction delay (MPC_ACC_HOR, MPC_JERK_AUTO), smoothed by its jerk-limited velocity
    smoother; corners rounded by an arc inside NAV_ACC_RAD at PX4's corner speed
    (MPC_XY_TRAJ_P); a waypoint with a hold stops the vehicle, and the hold starts when the
    vehicle is within NAV_ACC_RAD (NAV_MC_ALT_RAD vertically). The vehicle follows that
    trajectory through PX4's position and velocity loops against a linear drag
    (VEHICLE_LIN_DRAG, SIH's quad by default) within MPC_TILTMAX_AIR, which also sets its top
    speed. Takeoff climbs after PX4_LIFTOFF_DELAY_S; a landing descends at MPC_Z_V_AUTO_DN,
    slowing to MPC_LAND_SPEED between MPC_LAND_ALT1 and MPC_LAND_ALT2, and ends
    PX4_LAND_DETECT_S after touchdown. Holds keep fractional seconds. Checked on PX4 v1.15.4
    SIH flights of our plans (``tests/data/px4-sih``).

Accelerations and jerks default to the site's ``uav.max_accel`` / ``uav.max_jerk``, speeds to
its ``max_speed``; ``VEHICLE_SPEED_MAX`` (m/s, every profile) is the vehicle's real top speed
(default: the site's V), e.g. 10.4 for ArduPilot's SITL quad.

:func:`fly` evaluates a profile and returns a :class:`FlownPath`: samples of the commanded
position (the vehicle is assumed to track its target; the position controller's small lag is
not modelled) and the time each leg started, reached its destination and completed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from validator.errors import InputError
from validator.flight import Flight, Leg
from validator.motion import px4
from validator.site import Site

ProfileName = Literal["ideal", "arducopter", "px4"]
PROFILES: tuple[ProfileName, ...] = ("ideal", "arducopter", "px4")
GRAVITY_MPS2 = 9.80665
SEG_CRUISE = 7  # S-curves: segments 0-6 accelerate, 7 cruises, 8-14 decelerate, 15 end run
SEG_DECEL_START = 8
CORNER_SEARCH_STEP_S = 0.0025  # ArduCopter checks the corner condition at its 400 Hz loop rate
STOP_TOLERANCE_M = 0.01  # a vehicle creeping to a stop counts as there this close
# Fitted to ArduCopter 4.5.6 SITL (quad, `+` frame; ../shared/data/arducopter-sitl-2): level
# top speed 10.03 m/s at 40 m AMSL and 10.37 m/s at 584 m, both at the 30° lean limit.
SITL_QUAD_DRAG_PER_M = 0.0561
# Arming to the start of the climb: the arming delay, motor spool-up and throttle slew until
# the land detector lets go (TKOFF_SLEW_TIME); measured 3.1 s in every SITL flight (fitted with
# the climb below so that NAV_TAKEOFF completes when it did, 18.2 s after arming from 30 m).
LIFTOFF_DELAY_S = 3.1
# Touchdown to "land complete": ArduCopter's land detector needs a second of low throttle and
# no descent; measured 1.57 s in every SITL flight (disarm follows 0.5 s later).
LAND_DETECT_S = 1.57
# A stop at a waypoint comes later than the S-curve's own end: ArduCopter slows the S-curve's
# clock while the vehicle lags its target (AC_WPNav's track scaler). Measured 0.3-1.2 s per
# horizontal rest-to-rest leg in the SITL flights, median 0.6 s.
STOP_LAG_S = 0.6
# PX4 v1.15 SIH (quad x), measured on flights of our plans: arming to the start of the climb
# (spool-up and the MPC_TKO_RAMP_T takeoff ramp), and touchdown to disarm (land detector, then
# COM_DISARM_LAND).
PX4_LIFTOFF_DELAY_S = 3.0
PX4_LAND_DETECT_S = 2.5
# PX4 counts a stop waypoint reached this long after the straight-line model does: closing in,
# the vehicle also converges on the planned line (PositionSmoothing's L1 crossing point),
# which slows its last metre. Median over the stops of the SIH flights in tests/data/px4-sih.
PX4_ARRIVAL_LAG_S = 0.9


@dataclass(frozen=True)
class ParamSpec:
    """One profile parameter: its unit, factor to SI, and documentation."""

    unit: str
    to_si: float
    doc: str


_COMMON = {
    "VEHICLE_SPEED_MAX": ParamSpec("m/s", 1.0, "the vehicle's real top speed (default: site V)"),
}
PARAM_SPECS: dict[str, dict[str, ParamSpec]] = {
    "ideal": {
        "SPEED": ParamSpec("m/s", 1.0, "speed of legs without DO_CHANGE_SPEED (default: site V)"),
        "SPEED_UP": ParamSpec("m/s", 1.0, "climb speed (default 2.5)"),
        "SPEED_DN": ParamSpec("m/s", 1.0, "descent speed (default 1.5)"),
        **_COMMON,
    },
    "arducopter": {
        "WPNAV_SPEED": ParamSpec("cm/s", 0.01, "horizontal speed without DO_CHANGE_SPEED "
                                 "(default: site V, as our .param files set it)"),
        "WPNAV_ACCEL": ParamSpec("cm/s/s", 0.01, "horizontal acceleration (default: site "
                                 "max_accel)"),
        "WPNAV_JERK": ParamSpec("m/s/s/s", 1.0, "horizontal jerk (default: site max_jerk)"),
        "WPNAV_RADIUS": ParamSpec("cm", 0.01, "waypoint radius; corners are cut inside it "
                                  "(default 200)"),
        "WPNAV_ACCEL_C": ParamSpec("cm/s/s", 0.01, "corner acceleration, 0 = 2 x WPNAV_ACCEL "
                                   "(default 0)"),
        "WPNAV_SPEED_UP": ParamSpec("cm/s", 0.01, "climb speed (default 250)"),
        "WPNAV_SPEED_DN": ParamSpec("cm/s", 0.01, "descent speed (default 150)"),
        "WPNAV_ACCEL_Z": ParamSpec("cm/s/s", 0.01, "vertical acceleration (default 100)"),
        "PSC_JERK_Z": ParamSpec("m/s/s/s", 1.0, "vertical jerk (default 5)"),
        "ANGLE_MAX": ParamSpec("cdeg", 0.01, "lean angle limit; caps WPNAV_ACCEL at "
                               "g·tan(ANGLE_MAX) (default 3000)"),
        "ATC_INPUT_TC": ParamSpec("s", 1.0, "attitude input time constant; jerk ramps over "
                                  "2·ATC_INPUT_TC (default 0.15)"),
        "ATC_ACCEL_R_MAX": ParamSpec("cdeg/s/s", 0.01, "roll acceleration limit; bounds how "
                                     "fast jerk can change (default 110000)"),
        "RTL_LOIT_TIME": ParamSpec("ms", 0.001, "hover over home before landing (default 5000)"),
        "PSC_ANGLE_MAX": ParamSpec("deg", 1.0, "position controller lean limit, 0 = ANGLE_MAX "
                                   "(default 0)"),
        "LAND_SPEED": ParamSpec("cm/s", 0.01, "final descent speed below LAND_ALT_LOW "
                                "(default 50)"),
        "LAND_ALT_LOW": ParamSpec("cm", 0.01, "altitude where a landing slows to LAND_SPEED "
                                  "(default 1000)"),
        "VEHICLE_DRAG": ParamSpec("1/m", 1.0, "drag deceleration over speed squared at sea "
                                  "level; with the lean limit it sets the top speed (default "
                                  f"{SITL_QUAD_DRAG_PER_M}, ArduPilot's SITL quad)"),
        "ALT_AMSL": ParamSpec("m", 1.0, "flight altitude above mean sea level, for the air "
                              "density (default: the site's ground altitude + H)"),
        **_COMMON,
    },
    "px4": {
        "MPC_XY_CRUISE": ParamSpec("m/s", 1.0, "speed without DO_CHANGE_SPEED (default: site V)"),
        "MPC_XY_VEL_MAX": ParamSpec("m/s", 1.0, "horizontal speed limit (default: site V)"),
        "MPC_ACC_HOR": ParamSpec("m/s/s", 1.0, "horizontal acceleration (default: site "
                                 "max_accel)"),
        "MPC_JERK_AUTO": ParamSpec("m/s/s/s", 1.0, "jerk in missions (default: site max_jerk)"),
        "NAV_ACC_RAD": ParamSpec("m", 1.0, "acceptance radius; corners are cut inside it "
                                 "(default 2)"),
        "MPC_Z_V_AUTO_UP": ParamSpec("m/s", 1.0, "climb speed (default 3)"),
        "MPC_Z_V_AUTO_DN": ParamSpec("m/s", 1.0, "descent speed (default 1.5)"),
        "MPC_ACC_UP_MAX": ParamSpec("m/s/s", 1.0, "climb acceleration (default 4)"),
        "MPC_ACC_DOWN_MAX": ParamSpec("m/s/s", 1.0, "descent acceleration (default 3)"),
        "MPC_XY_TRAJ_P": ParamSpec("", 1.0, "share of MPC_ACC_HOR used to turn through a "
                                   "waypoint (default 0.5)"),
        "NAV_MC_ALT_RAD": ParamSpec("m", 1.0, "altitude acceptance radius (default 0.8)"),
        "MPC_LAND_SPEED": ParamSpec("m/s", 1.0, "landing speed below MPC_LAND_ALT2 "
                                    "(default 0.7)"),
        "MPC_LAND_ALT1": ParamSpec("m", 1.0, "height where a landing starts to slow "
                                   "(default 10)"),
        "MPC_LAND_ALT2": ParamSpec("m", 1.0, "height below which it lands at MPC_LAND_SPEED "
                                   "(default 5)"),
        "MPC_XY_P": ParamSpec("1/s", 1.0, "horizontal position gain (default 0.95)"),
        "MPC_XY_VEL_P_ACC": ParamSpec("1/s", 1.0, "horizontal velocity P gain (default 1.8)"),
        "MPC_XY_VEL_I_ACC": ParamSpec("1/s/s", 1.0, "horizontal velocity I gain (default 0.4)"),
        "MPC_XY_ERR_MAX": ParamSpec("m", 1.0, "lag at which the trajectory waits for the "
                                    "vehicle (default 2)"),
        "MPC_TILTMAX_AIR": ParamSpec("deg", 1.0, "tilt limit; with the drag it sets the top "
                                     "speed (default 45)"),
        "VEHICLE_LIN_DRAG": ParamSpec("1/s", 1.0, "drag deceleration over speed (default 1, "
                                      "PX4 SIH's quad: SIH_KDV / SIH_MASS)"),
        **_COMMON,
    },
}


def _defaults(name: ProfileName, site: Site) -> dict[str, float]:
    v = site.max_speed_mps
    common = {"VEHICLE_SPEED_MAX": v}
    if name == "ideal":
        return {"SPEED": v, "SPEED_UP": 2.5, "SPEED_DN": 1.5, **common}
    if name == "arducopter":
        return {
            "WPNAV_SPEED": v * 100.0,
            "WPNAV_ACCEL": site.max_accel_mps2 * 100.0,
            "WPNAV_JERK": site.max_jerk_mps3,
            "WPNAV_RADIUS": 200.0,
            "WPNAV_ACCEL_C": 0.0,
            "WPNAV_SPEED_UP": 250.0,
            "WPNAV_SPEED_DN": 150.0,
            "WPNAV_ACCEL_Z": 100.0,
            "PSC_JERK_Z": 5.0,
            "ANGLE_MAX": 3000.0,
            "ATC_INPUT_TC": 0.15,
            "ATC_ACCEL_R_MAX": 110000.0,
            "RTL_LOIT_TIME": 5000.0,
            "PSC_ANGLE_MAX": 0.0,
            "LAND_SPEED": 50.0,
            "LAND_ALT_LOW": 1000.0,
            "VEHICLE_DRAG": SITL_QUAD_DRAG_PER_M,
            "ALT_AMSL": site.frame.alt0_m + site.altitude_m,
            **common,
        }
    return {
        "MPC_XY_CRUISE": v,
        "MPC_XY_VEL_MAX": v,
        "MPC_ACC_HOR": site.max_accel_mps2,
        "MPC_JERK_AUTO": site.max_jerk_mps3,
        "NAV_ACC_RAD": 2.0,
        "MPC_Z_V_AUTO_UP": 3.0,
        "MPC_Z_V_AUTO_DN": 1.5,
        "MPC_ACC_UP_MAX": 4.0,
        "MPC_ACC_DOWN_MAX": 3.0,
        "MPC_XY_TRAJ_P": 0.5,
        "NAV_MC_ALT_RAD": 0.8,
        "MPC_LAND_SPEED": 0.7,
        "MPC_LAND_ALT1": 10.0,
        "MPC_LAND_ALT2": 5.0,
        "MPC_XY_P": 0.95,
        "MPC_XY_VEL_P_ACC": 1.8,
        "MPC_XY_VEL_I_ACC": 0.4,
        "MPC_XY_ERR_MAX": 2.0,
        "MPC_TILTMAX_AIR": 45.0,
        "VEHICLE_LIN_DRAG": 1.0,
        **common,
    }


@dataclass(frozen=True)
class Profile:
    """A flight profile: its name and every parameter in the autopilot's units."""

    name: ProfileName
    params: Mapping[str, float]

    def si(self, param: str) -> float:
        """The parameter converted to SI units (m, m/s, m/s², m/s³, s, rad for angles)."""
        spec = PARAM_SPECS[self.name][param]
        value = float(self.params[param]) * spec.to_si
        return math.radians(value) if spec.unit.startswith("cdeg") else value


def make_profile(
    name: str, site: Site, overrides: Mapping[str, float] | None = None
) -> Profile:
    """The profile ``name`` with the site's defaults and ``overrides`` (autopilot units).

    Raises :class:`InputError` for an unknown profile or parameter, or a value that is not a
    finite number > 0 (>= 0 for WPNAV_ACCEL_C, RTL_LOIT_TIME, PSC_ANGLE_MAX, VEHICLE_DRAG and
    ALT_AMSL).
    """
    if name not in PROFILES:
        raise InputError(f"--profile: unknown profile {name!r} (choose from {', '.join(PROFILES)})")
    pname: ProfileName = name
    params = _defaults(pname, site)
    for key, value in (overrides or {}).items():
        if key not in params:
            known = ", ".join(sorted(params))
            raise InputError(
                f"--param {key}: unknown parameter for profile {name} (known: {known})"
            )
        v = float(value)
        may_be_zero = key in ("WPNAV_ACCEL_C", "RTL_LOIT_TIME", "PSC_ANGLE_MAX", "VEHICLE_DRAG",
                              "ALT_AMSL")
        if not math.isfinite(v) or v < 0 or (v == 0 and not may_be_zero):
            raise InputError(f"--param {key}: must be a number > 0, got {value}")
        params[key] = v
    return Profile(pname, params)


def flight_params(name: str, site: Site, params: Mapping[str, float]) -> dict[str, float]:
    """Those of ``params`` (a vehicle's parameter file) that profile ``name`` flies with; the
    rest (the geofence, say) do not move the vehicle."""
    known = make_profile(name, site).params
    return {k: float(v) for k, v in params.items() if k in known}


def parse_param_overrides(pairs: list[str] | None) -> dict[str, float]:
    """``["NAME=VALUE", ...]`` from the command line as a dict; InputError naming the bad one."""
    out: dict[str, float] = {}
    for pair in pairs or []:
        name, sep, value = pair.partition("=")
        name = name.strip().upper()
        if not sep or not name:
            raise InputError(f"--param {pair}: expected NAME=VALUE")
        try:
            out[name] = float(value)
        except ValueError:
            raise InputError(f"--param {name}: {value!r} is not a number") from None
    return out


# --------------------------------------------------------------------------------------------
# the vehicle's own limits


def air_density_ratio(alt_amsl_m: float) -> float:
    """Air density at ``alt_amsl_m`` metres above mean sea level over sea level's (ISA
    troposphere: (1 − 2.25577e-5·h)^4.2559)."""
    return float((1.0 - 2.25577e-5 * alt_amsl_m) ** 4.2559)


def lean_angle_max_deg(angle_max_cdeg: float, psc_angle_max_deg: float = 0.0) -> float:
    """The lean limit (degrees) ArduCopter's position controller flies with: PSC_ANGLE_MAX
    (degrees) when set, else ANGLE_MAX (centidegrees)."""
    return psc_angle_max_deg if psc_angle_max_deg > 0 else angle_max_cdeg / 100.0


def top_speed_mps(
    angle_max_deg: float,
    drag_per_m: float = SITL_QUAD_DRAG_PER_M,
    density_ratio: float = 1.0,
) -> float:
    """Fastest level speed (m/s) of a multicopter leaning at most ``angle_max_deg`` degrees.

    Holding altitude at lean θ leaves g·tan θ (m/s²) of horizontal thrust, which the air's drag
    ``drag_per_m``·σ·v² (m/s², σ = ``density_ratio``, the air density over sea level's, see
    :func:`air_density_ratio`) balances at v = sqrt(g·tan θ / (k·σ)). The default k (1/m) is
    fitted to ArduPilot's SITL quad: 10.07 m/s at 30° near sea level. No drag: infinite.
    """
    if not 0.0 < angle_max_deg < 90.0:
        raise InputError(f"lean angle limit: must be between 0 and 90 degrees, got "
                         f"{angle_max_deg}")
    drag = drag_per_m * density_ratio
    if drag <= 0:
        return math.inf
    return math.sqrt(GRAVITY_MPS2 * math.tan(math.radians(angle_max_deg)) / drag)


def arducopter_lean_max_deg(profile: Profile) -> float:
    """The lean limit (degrees) of an ``arducopter`` profile."""
    return lean_angle_max_deg(float(profile.params["ANGLE_MAX"]),
                              float(profile.params["PSC_ANGLE_MAX"]))


def arducopter_accel_mps2(profile: Profile) -> float:
    """The horizontal acceleration (m/s²) an ``arducopter`` profile's legs use: WPNAV_ACCEL,
    capped by what its lean limit allows (g·tan θ)."""
    lean = math.radians(arducopter_lean_max_deg(profile))
    return min(profile.si("WPNAV_ACCEL"), GRAVITY_MPS2 * math.tan(lean))


def arducopter_top_speed_mps(profile: Profile) -> float:
    """The fastest an ``arducopter`` profile's vehicle flies (m/s), whatever WPNAV_SPEED says:
    its lean-limited top speed (:func:`top_speed_mps` at the profile's air density), capped by
    VEHICLE_SPEED_MAX."""
    v = top_speed_mps(arducopter_lean_max_deg(profile), profile.si("VEHICLE_DRAG"),
                      air_density_ratio(profile.si("ALT_AMSL")))
    return min(v, profile.si("VEHICLE_SPEED_MAX"))


# --------------------------------------------------------------------------------------------
# 1-D jerk-limited profiles


@dataclass(frozen=True)
class Profiles1D:
    """Piecewise-polynomial motion along ``n`` straight legs (1-D, metres along each leg).

    ``dur_s``, ``jerk0`` and ``snap`` are (n, S): per segment its duration (s), the jerk at its
    start (m/s³) and its constant snap (m/s⁴). ``v0_mps`` (n,) is the speed at the start (0 for
    rest-to-rest). Boundary states (position, speed, acceleration) are precomputed. Before time
    0 and after the last segment the leg is at rest (position 0, resp. ``length_m``).
    """

    length_m: NDArray[np.float64]
    v0_mps: NDArray[np.float64]
    dur_s: NDArray[np.float64]
    jerk0: NDArray[np.float64]
    snap: NDArray[np.float64]

    def __post_init__(self) -> None:
        n, segs = self.dur_s.shape
        t, p, v, a = (np.zeros((n, segs + 1)) for _ in range(4))
        v[:, 0] = self.v0_mps
        for k in range(segs):
            d, j, s = self.dur_s[:, k], self.jerk0[:, k], self.snap[:, k]
            t[:, k + 1] = t[:, k] + d
            p[:, k + 1] = p[:, k] + v[:, k] * d + a[:, k] * d**2 / 2 + j * d**3 / 6 + s * d**4 / 24
            v[:, k + 1] = v[:, k] + a[:, k] * d + j * d**2 / 2 + s * d**3 / 6
            a[:, k + 1] = a[:, k] + j * d + s * d**2 / 2
        object.__setattr__(self, "_bounds", (t, p, v, a))

    @property
    def total_s(self) -> NDArray[np.float64]:
        """Duration of each leg's motion (s)."""
        return np.asarray(self._bounds[0][:, -1])  # type: ignore[attr-defined]

    def boundary_time_s(self, k: int) -> NDArray[np.float64]:
        """Time (s) at which segment ``k`` starts (k = S: the end)."""
        return np.asarray(self._bounds[0][:, k])  # type: ignore[attr-defined]

    def peak_speed_mps(self) -> NDArray[np.float64]:
        return np.asarray(np.max(self._bounds[2], axis=1))  # type: ignore[attr-defined]

    def state(
        self, leg: NDArray[np.int64], tau_s: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Position (m), speed (m/s), acceleration (m/s²) of legs ``leg`` at local times
        ``tau_s``."""
        t, p, v, a = self._bounds  # type: ignore[attr-defined]
        leg = np.asarray(leg, dtype=np.int64)
        tau = np.asarray(tau_s, dtype=float)
        bt = t[leg]
        segs = self.dur_s.shape[1]
        k = np.clip(np.sum(tau[:, None] >= bt[:, 1:], axis=1), 0, segs - 1)
        d = np.clip(tau - bt[np.arange(leg.size), k], 0.0, None)
        p0, v0, a0 = p[leg, k], v[leg, k], a[leg, k]
        j0, s = self.jerk0[leg, k], self.snap[leg, k]
        pos = p0 + v0 * d + a0 * d**2 / 2 + j0 * d**3 / 6 + s * d**4 / 24
        vel = v0 + a0 * d + j0 * d**2 / 2 + s * d**3 / 6
        acc = a0 + j0 * d + s * d**2 / 2
        done = tau >= bt[:, -1]
        before = tau <= 0.0
        pos = np.where(done, self.length_m[leg], np.where(before, 0.0, pos))
        vel = np.where(done | (before & (self.v0_mps[leg] == 0)), 0.0, vel)
        acc = np.where(done | before, 0.0, acc)
        return pos, vel, acc


def _accel_phase(
    v: NDArray[np.float64], A: NDArray[np.float64], J: NDArray[np.float64], tj: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Jerk (m/s³), jerk-hold t2, accel-hold t4 and duration (s) of a rest-to-``v`` phase.

    The jerk ramps over ``tj`` to ±J, holds t2, ramps back; the acceleration holds its peak t4.
    Peak acceleration J·(tj + t2) ≤ A; speed gained = peak·(2·tj + t2 + t4).
    """
    jm = np.minimum(J, np.divide(A, tj, out=np.full_like(A, np.inf), where=tj > 0))
    t2_full = np.maximum(A / jm - tj, 0.0)
    v_full = A * (2.0 * tj + t2_full)  # least speed gain that reaches A
    with np.errstate(invalid="ignore", divide="ignore"):
        # below v_full: v = J·(tj + t2)·(2·tj + t2), solved for t2 >= 0
        t2_part = (-3.0 * tj + np.sqrt(tj * tj + 4.0 * v / jm)) / 2.0
    small = t2_part < 0  # too small even for full-height jerk ramps: lower the jerk
    jm_small = np.divide(v, 2.0 * tj * tj, out=np.zeros_like(v), where=tj > 0)
    full = v >= v_full
    t2 = np.where(full, t2_full, np.where(small, 0.0, t2_part))
    jm = np.where(~full & small, jm_small, jm)
    peak = jm * (tj + t2)
    t4 = np.where(full, np.divide(v, A, out=np.zeros_like(v), where=A > 0) - 2.0 * tj - t2, 0.0)
    t4 = np.maximum(t4, 0.0)
    dur = 4.0 * tj + 2.0 * t2 + t4
    ok = v > 0
    return (np.where(ok, jm, 0.0), np.where(ok, t2, 0.0), np.where(ok, t4, 0.0),
            np.where(ok & (peak > 0), dur, 0.0))


def scurve_peak_speed(
    length_m: NDArray[np.float64] | float,
    speed_mps: NDArray[np.float64] | float,
    accel_mps2: NDArray[np.float64] | float,
    jerk_mps3: NDArray[np.float64] | float,
    jerk_ramp_s: NDArray[np.float64] | float = 0.0,
) -> NDArray[np.float64]:
    """Top speed (m/s) of a rest-to-rest move over ``length_m`` with these limits.

    With instant jerk changes (``jerk_ramp_s`` = 0) accelerating from rest to v takes
    v/A + A/J seconds and v²/(2A) + vA/(2J) metres when v ≥ A²/J, else 2·sqrt(v/J) s and
    v·sqrt(v/J) m; so a move of length L reaches min(V, the v whose rest-to-v-to-rest distance
    is L). With jerk ramps the same holds with the phase lengthened by ``jerk_ramp_s``.
    """
    L = np.atleast_1d(np.asarray(length_m, dtype=float))
    shape = L.shape
    V, A, J, tj = (np.broadcast_to(np.asarray(x, dtype=float), shape).astype(float)
                   for x in (speed_mps, accel_mps2, jerk_mps3, jerk_ramp_s))

    def distance(v: NDArray[np.float64]) -> NDArray[np.float64]:
        return v * _accel_phase(v, A, J, tj)[3]  # rest -> v -> rest: v times one phase

    reach = distance(V) <= L
    lo, hi = np.zeros(shape), V.copy()
    for _ in range(60):  # bisection: distance(v) is increasing in v
        mid = (lo + hi) / 2.0
        longer = distance(mid) > L
        hi = np.where(longer, mid, hi)
        lo = np.where(longer, lo, mid)
    return np.asarray(np.where(reach, V, lo), dtype=float)


def scurve_rest_to_rest(
    length_m: NDArray[np.float64],
    speed_mps: NDArray[np.float64],
    accel_mps2: NDArray[np.float64],
    jerk_mps3: NDArray[np.float64],
    jerk_ramp_s: NDArray[np.float64] | float = 0.0,
) -> Profiles1D:
    """Jerk-limited profiles from rest over ``length_m`` back to rest.

    Acceleration phase: jerk ramps up over ``jerk_ramp_s`` (constant snap), holds, ramps down,
    acceleration holds, the mirror image brings it back to 0; then cruise; then the
    deceleration phase mirrors the acceleration phase. With ``jerk_ramp_s`` = 0 this is the
    classic seven-segment profile (jerk +J, accel A, jerk −J, cruise, ...) and a long move
    lasts L/V + V/A + A/J; jerk ramps add ``jerk_ramp_s`` to that.
    """
    return scurve_to_touchdown(length_m, speed_mps, accel_mps2, jerk_mps3, jerk_ramp_s, 0.0, 0.0)


def scurve_to_touchdown(
    length_m: NDArray[np.float64],
    speed_mps: NDArray[np.float64],
    accel_mps2: NDArray[np.float64],
    jerk_mps3: NDArray[np.float64],
    jerk_ramp_s: NDArray[np.float64] | float,
    end_speed_mps: NDArray[np.float64] | float,
    end_run_m: NDArray[np.float64] | float,
) -> Profiles1D:
    """Jerk-limited moves from rest that end with ``end_run_m`` metres at ``end_speed_mps``.

    ArduCopter's landing: the descent runs at ``speed_mps`` (at least the end speed), slows
    jerk-limited to the end speed as it reaches the end run (LAND_ALT_LOW) and touches down at
    that speed. With no end speed (0) this is :func:`scurve_rest_to_rest`. Same segments as
    that (accelerate, cruise, decelerate) plus the end run.
    """
    L = np.maximum(np.asarray(length_m, dtype=float), 0.0)
    shape = L.shape
    V, A, J, tj, ve, run = (np.broadcast_to(np.asarray(x, dtype=float), shape).astype(float)
                            for x in (speed_mps, accel_mps2, jerk_mps3, jerk_ramp_s,
                                      end_speed_mps, end_run_m))
    ramp_to_ve = ve * _accel_phase(ve, A, J, tj)[3] / 2.0
    ve = np.where(L >= ramp_to_ve, ve, 0.0)  # too short to reach the end speed: stop instead
    run = np.where(ve > 0, np.clip(run, 0.0, L - ramp_to_ve), 0.0)
    V = np.maximum(V, ve)

    def distance(v: NDArray[np.float64]) -> NDArray[np.float64]:
        up = _accel_phase(v, A, J, tj)[3]
        down = _accel_phase(v - ve, A, J, tj)[3]
        return v * up / 2.0 + (v + ve) * down / 2.0 + run

    lo, hi = ve.copy(), V.copy()
    for _ in range(60):  # bisection: distance(v) is increasing in v
        mid = (lo + hi) / 2.0
        longer = distance(mid) > L
        hi = np.where(longer, mid, hi)
        lo = np.where(longer, lo, mid)
    v = np.where(L <= 0, 0.0, np.where(distance(V) <= L, V, lo))
    jm, t2, t4, up = _accel_phase(v, A, J, tj)
    jd, t2d, t4d, down = _accel_phase(v - ve, A, J, tj)
    cruise = L - v * up / 2.0 - (v + ve) * down / 2.0 - run
    tc = np.divide(np.maximum(cruise, 0.0), v, out=np.zeros_like(v), where=v > 0)
    t_run = np.divide(run, ve, out=np.zeros_like(ve), where=ve > 0)
    tu = np.where(up > 0, tj, 0.0)  # no move, no jerk ramps: a zero-length leg takes no time
    td = np.where(down > 0, tj, 0.0)
    snap = np.divide(jm, tu, out=np.zeros_like(jm), where=tu > 0)
    snap_d = np.divide(jd, td, out=np.zeros_like(jd), where=td > 0)
    z = np.zeros_like(L)
    up_segs = [(tu, z, snap), (t2, jm, z), (tu, jm, -snap)]
    down_segs = [(tu, z, -snap), (t2, -jm, z), (tu, -jm, snap)]
    brake = [(td, z, -snap_d), (t2d, -jd, z), (td, -jd, snap_d), (t4d, z, z),
             (td, z, snap_d), (t2d, jd, z), (td, jd, -snap_d)]
    segs = up_segs + [(t4, z, z)] + down_segs + [(tc, z, z)] + brake + [(t_run, z, z)]
    dur, jerk0, snaps = (np.stack([seg[i] for seg in segs], axis=1) for i in range(3))
    return Profiles1D(L, np.zeros_like(L), dur, jerk0, snaps)


def constant_speed(length_m: NDArray[np.float64], speed_mps: NDArray[np.float64]) -> Profiles1D:
    """Moves at a constant speed (instant start and stop): the ideal profile."""
    L = np.maximum(np.asarray(length_m, dtype=float), 0.0)
    v = np.asarray(speed_mps, dtype=float)
    dur = np.where(L > 0, L / v, 0.0)[:, None]
    return Profiles1D(L, np.where(L > 0, v, 0.0), dur, np.zeros_like(dur), np.zeros_like(dur))


# --------------------------------------------------------------------------------------------
# legs in 3-D


@dataclass(frozen=True)
class LegGeometry:
    """Legs as 3-D vectors (x east, y north, z up; metres): start points and displacements."""

    start: NDArray[np.float64]  # (n, 3)
    delta: NDArray[np.float64]  # (n, 3)

    @property
    def length_m(self) -> NDArray[np.float64]:
        return np.asarray(np.linalg.norm(self.delta, axis=1), dtype=float)

    @property
    def unit(self) -> NDArray[np.float64]:
        L = self.length_m
        return np.divide(self.delta, L[:, None], out=np.zeros_like(self.delta),
                         where=L[:, None] > 0)


def leg_geometry(legs: tuple[Leg, ...]) -> LegGeometry:
    start = np.array([[*leg.start_xy_m, leg.start_alt_m] for leg in legs], dtype=float)
    end = np.array([[*leg.end_xy_m, leg.end_alt_m] for leg in legs], dtype=float)
    return LegGeometry(start.reshape(-1, 3), (end - start).reshape(-1, 3))


def kinematic_limit(
    unit: NDArray[np.float64], horiz: NDArray[np.float64], up: NDArray[np.float64] | float,
    down: NDArray[np.float64] | float,
) -> NDArray[np.float64]:
    """Largest magnitude along ``unit`` (n, 3) whose horizontal part ≤ ``horiz`` and vertical
    part ≤ ``up`` (climbing) or ``down`` (descending)."""
    h = np.hypot(unit[:, 0], unit[:, 1])
    z = unit[:, 2]
    vert = np.where(z > 0, up, down) * np.ones_like(z)
    with np.errstate(divide="ignore"):
        lim_h = np.where(h > 1e-9, horiz / np.maximum(h, 1e-12), np.inf)
        lim_z = np.where(np.abs(z) > 1e-9, vert / np.maximum(np.abs(z), 1e-12), np.inf)
    out = np.minimum(lim_h, lim_z)
    return np.asarray(np.where(np.isfinite(out), out, horiz), dtype=np.float64)


# --------------------------------------------------------------------------------------------
# flown path


@dataclass(frozen=True)
class FlownPath:
    """A modelled flight sampled in time.

    ``t_s`` (n,) from the start of the mission; ``xyz_m`` (n, 3) east, north, up above home;
    ``vel_mps`` (n, 3); ``leg`` (n,) the active leg (index into ``Flight.legs``; the leg whose
    item is the autopilot's current mission item). Per leg: ``start_s`` the leg's motion
    begins, ``reached_s`` its destination is reached (hold starts), ``done_s`` the item
    completes (hold over, the next item becomes current).
    """

    t_s: NDArray[np.float64]
    xyz_m: NDArray[np.float64]
    vel_mps: NDArray[np.float64]
    leg: NDArray[np.int64]
    start_s: NDArray[np.float64]
    reached_s: NDArray[np.float64]
    done_s: NDArray[np.float64]


def _superpose(
    geom: LegGeometry, prof: Profiles1D, start_s: NDArray[np.float64], t: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Target position and velocity at times ``t``: the sum of every leg's own profile."""
    n = len(start_s)
    total = prof.total_s
    end_s = start_s + total
    order = np.argsort(end_s, kind="stable")
    cum = np.vstack([np.zeros((1, 3)), np.cumsum(geom.delta[order], axis=0)])
    ended = np.searchsorted(end_s[order], t, side="right")
    pos = geom.start[0] + cum[ended] if n else np.zeros((t.size, 3))
    vel = np.zeros((t.size, 3))
    lo = np.searchsorted(t, start_s, side="right")
    hi = np.searchsorted(t, end_s, side="left")
    counts = np.maximum(hi - lo, 0)
    if counts.sum():
        leg_idx = np.repeat(np.arange(n), counts)
        offsets = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        sample = np.repeat(lo, counts) + offsets
        p, v, _ = prof.state(leg_idx, t[sample] - start_s[leg_idx])
        u = geom.unit[leg_idx]
        np.add.at(pos, sample, u * p[:, None])
        np.add.at(vel, sample, u * v[:, None])
    return pos, vel


def _active_leg(done_s: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.int64]:
    """Leg whose item is current: leg i is current from done_s[i-1] until done_s[i]."""
    n = len(done_s)
    return np.minimum(np.searchsorted(done_s, t, side="right"), max(n - 1, 0)).astype(np.int64)


def _time_grid(end_s: float, dt_s: float) -> NDArray[np.float64]:
    n = int(math.floor(end_s / dt_s + 1e-9)) + 1
    t = np.arange(n, dtype=np.float64) * dt_s
    return t if t[-1] >= end_s - 1e-9 else np.append(t, np.float64(end_s))


def _ideal_timing(
    flight: Flight, profile: Profile
) -> tuple[LegGeometry, Profiles1D, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    legs = flight.legs
    geom = leg_geometry(legs)
    cmd = np.array([leg.speed_mps or profile.si("SPEED") for leg in legs], dtype=float)
    horiz = np.minimum(cmd, profile.si("VEHICLE_SPEED_MAX"))
    speed = kinematic_limit(geom.unit, horiz, profile.si("SPEED_UP"), profile.si("SPEED_DN"))
    prof = constant_speed(geom.length_m, speed)
    hold = np.array([leg.hold_s for leg in legs], dtype=float)
    span = prof.total_s + hold
    start = np.concatenate([[0.0], np.cumsum(span)[:-1]])
    reached = start + prof.total_s
    done = reached + hold
    return geom, prof, start, reached, done


def ideal_leg_times(
    flight: Flight, profile: Profile
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Per leg: start, arrival and completion times (s) at the commanded speeds and holds.

    ``profile`` must be the ``ideal`` one (it supplies the default and vertical speeds).
    """
    _, _, start, reached, done = _ideal_timing(flight, profile)
    return start, reached, done


def _fly_ideal(flight: Flight, profile: Profile, dt_s: float) -> FlownPath:
    geom, prof, start, reached, done = _ideal_timing(flight, profile)
    t = _time_grid(float(done[-1]), dt_s)
    pos, vel = _superpose(geom, prof, start, t)
    return FlownPath(t, pos, vel, _active_leg(done, t), start, reached, done)


def _ardu_limits(
    flight: Flight, profile: Profile, geom: LegGeometry
) -> tuple[Profiles1D, NDArray[np.float64]]:
    """Every leg's S-curve (rest to rest; a landing ends at LAND_SPEED below LAND_ALT_LOW), and
    each leg's speed limit along its track (m/s)."""
    legs = flight.legs
    a_xy = arducopter_accel_mps2(profile)
    v_cap = arducopter_top_speed_mps(profile)
    wpnav = profile.si("WPNAV_SPEED")
    cmd = np.array(
        [wpnav if leg.kind == "rtl" or leg.speed_mps is None else leg.speed_mps for leg in legs],
        dtype=float,
    )
    unit = geom.unit
    speed = kinematic_limit(unit, np.minimum(cmd, v_cap), profile.si("WPNAV_SPEED_UP"),
                            profile.si("WPNAV_SPEED_DN"))
    a_z = profile.si("WPNAV_ACCEL_Z")
    accel = kinematic_limit(unit, np.full(len(legs), a_xy), a_z, a_z)
    vertical = np.hypot(unit[:, 0], unit[:, 1]) < 1e-9
    jerk = np.where(vertical, profile.si("PSC_JERK_Z"), profile.si("WPNAV_JERK"))
    # ArduCopter lands at WPNAV_SPEED_DN (never slower than LAND_SPEED) down to LAND_ALT_LOW,
    # then at LAND_SPEED until the ground stops it
    landing = np.array([leg.kind == "land" for leg in legs]) & vertical
    land_speed = profile.si("LAND_SPEED")
    speed = np.where(landing, np.maximum(speed, land_speed), speed)
    prof = scurve_to_touchdown(geom.length_m, speed, accel, jerk, jerk_ramp_s(profile, jerk),
                               np.where(landing, land_speed, 0.0),
                               np.where(landing, profile.si("LAND_ALT_LOW"), 0.0))
    return prof, speed


def jerk_ramp_s(profile: Profile, jerk_mps3: NDArray[np.float64]) -> NDArray[np.float64]:
    """Time (s) ArduCopter takes to ramp the jerk from 0 to its limit.

    A multicopter accelerates by leaning, so jerk cannot change instantly: ArduCopter limits
    snap to half of min(J·π/(2·ATC_INPUT_TC), ATC_ACCEL_R_MAX·g), i.e. a ramp of
    max(2·ATC_INPUT_TC, J·π/(ATC_ACCEL_R_MAX·g)) seconds.
    """
    tc = max(profile.si("ATC_INPUT_TC"), 0.1)
    by_rate = jerk_mps3 * math.pi / (profile.si("ATC_ACCEL_R_MAX") * GRAVITY_MPS2)
    return np.asarray(np.maximum(2.0 * tc, by_rate), dtype=float)


def corner_overlaps_s(
    geom: LegGeometry,
    prof: Profiles1D,
    corners: NDArray[np.int64],
    speed_max_mps: NDArray[np.float64],
    radius_m: float,
    corner_accel_mps2: float,
) -> NDArray[np.float64]:
    """How long (s) leg ``i+1`` overlaps the end of leg ``i``, for each ``i`` in ``corners``.

    ArduCopter's corner rule: the next leg may start once leg ``i`` decelerates and has no more
    time left than the next leg's acceleration phase; it starts at the first moment the blended
    target at mid-overlap lies within ``radius_m`` of the waypoint, is slower than both legs'
    speed limits ``speed_max_mps`` (per leg) and has a horizontal acceleration below
    ``corner_accel_mps2``. 0 when that moment never comes (the leg ends, then the next starts).
    Searched on a coarse grid, then refined to :data:`CORNER_SEARCH_STEP_S`.
    """
    i = np.asarray(corners, dtype=np.int64)
    out = np.zeros(i.size)
    if i.size == 0:
        return out
    T = prof.total_s[i]
    tau_max = np.minimum(T - prof.boundary_time_s(SEG_DECEL_START)[i],
                         prof.boundary_time_s(SEG_CRUISE)[i + 1])
    L = geom.length_m
    live = (tau_max > 0) & (L[i] > 0) & (L[i + 1] > 0)
    u1, u2 = geom.unit[i], geom.unit[i + 1]
    vmax = np.minimum(speed_max_mps[i], speed_max_mps[i + 1])

    def passes(tau: NDArray[np.float64]) -> NDArray[np.bool_]:
        """tau (c, K): does the corner rule hold with that much time left on leg i?"""
        c, k = tau.shape
        leg = np.repeat(i, k)
        half = (tau / 2.0).ravel()
        p1, v1, a1 = (x.reshape(c, k, 1) for x in prof.state(leg, np.repeat(T, k) - half))
        p2, v2, a2 = (x.reshape(c, k, 1) for x in prof.state(leg + 1, half))
        a, b = u1[:, None, :], u2[:, None, :]
        pos = -(L[i][:, None, None] - p1) * a + p2 * b
        vel = v1 * a + v2 * b
        acc = a1 * a + a2 * b
        return np.asarray(
            (np.linalg.norm(pos, axis=2) < radius_m)
            & (np.linalg.norm(vel, axis=2) < vmax[:, None])
            & (np.hypot(acc[..., 0], acc[..., 1]) < corner_accel_mps2)
        )

    coarse_n = 128
    frac = 1.0 - np.arange(coarse_n) / coarse_n  # from tau_max down, scanning forward in time
    tau = tau_max[:, None] * frac[None, :]
    ok = passes(tau) & live[:, None]
    first = np.argmax(ok, axis=1)
    found = ok[np.arange(i.size), first]
    # refine between the last failing coarse point and the first passing one
    hi = np.where(first > 0, tau[np.arange(i.size), np.maximum(first - 1, 0)], tau_max)
    lo = tau[np.arange(i.size), first]
    fine_n = int(np.ceil(np.max(np.where(found, hi - lo, 0.0), initial=0.0)
                         / CORNER_SEARCH_STEP_S)) + 1
    fine = hi[:, None] - (hi - lo)[:, None] * np.linspace(0.0, 1.0, max(fine_n, 2))[None, :]
    fine[:, 0] = np.where(first > 0, fine[:, 1], fine[:, 0])  # hi itself failed (or is tau_max)
    ok_f = passes(fine) & found[:, None]
    first_f = np.argmax(ok_f, axis=1)
    got = ok_f[np.arange(i.size), first_f]
    out = np.where(got, fine[np.arange(i.size), first_f], np.where(found, lo, 0.0))
    return np.asarray(out, dtype=float)


def _fly_arducopter(flight: Flight, profile: Profile, dt_s: float) -> FlownPath:
    legs = flight.legs
    geom = leg_geometry(legs)
    prof, speed = _ardu_limits(flight, profile, geom)
    total = prof.total_s
    radius = profile.si("WPNAV_RADIUS")
    corner_acc = profile.si("WPNAV_ACCEL_C") or 2.0 * profile.si("WPNAV_ACCEL")
    # ArduCopter stores hold times as whole seconds (uint16 param1)
    hold = np.array([math.floor(leg.hold_s + 1e-9) for leg in legs], dtype=float)
    hold += np.array([profile.si("RTL_LOIT_TIME") if leg.kind == "rtl" else 0.0 for leg in legs])
    n = len(legs)
    start = np.zeros(n)
    reached = np.zeros(n)
    done = np.zeros(n)
    blend = np.array([leg.pass_through for leg in legs[:-1]] + [False])
    corners = np.flatnonzero(blend)
    overlap = np.zeros(n)
    overlap[corners] = corner_overlaps_s(geom, prof, corners, speed, radius, corner_acc)
    # on the ground the climb waits for spool-up and lift-off; a landing ends when the land
    # detector has seen the touchdown
    liftoff = np.array([LIFTOFF_DELAY_S if leg.kind == "takeoff" and leg.start_alt_m <= 0
                        else 0.0 for leg in legs])
    hold += np.array([LAND_DETECT_S if leg.kind == "land" else 0.0 for leg in legs])
    stop_lag = np.where((geom.length_m > 0) & (np.hypot(geom.unit[:, 0], geom.unit[:, 1]) > 0.5),
                        STOP_LAG_S, 0.0)
    start[0] = liftoff[0]
    for i in range(n):
        end = start[i] + total[i]
        if blend[i]:
            tau = overlap[i]
            start[i + 1] = end - tau
            reached[i] = done[i] = end - tau / 2.0
        else:
            reached[i] = end + stop_lag[i]
            done[i] = reached[i] + hold[i]
            if i + 1 < n:
                start[i + 1] = done[i] + liftoff[i + 1]
    t = _time_grid(float(done[-1]), dt_s)
    pos, vel = _superpose(geom, prof, start, t)
    return FlownPath(t, pos, vel, _active_leg(done, t), start, reached, done)


# --------------------------------------------------------------------------------------------
# PX4: a rounded path and PX4's own speed rules along it (validator.motion.px4)


def _px4_runs(flight: Flight) -> list[list[int]]:
    """Legs grouped into runs the vehicle flies without stopping."""
    runs: list[list[int]] = [[]]
    for k, leg in enumerate(flight.legs):
        runs[-1].append(k)
        if not leg.pass_through:
            runs.append([])
    return [r for r in runs if r]


@dataclass(frozen=True)
class _Px4RunPath:
    """One run's path: arc-length samples ``s_m`` and ``points_m`` (3-D), the speed cap on
    the corners' arcs (``cap_mps``, inf on straights), each waypoint's arc length (mid-corner;
    the run's end last) and the speed PX4 flies through it (0 at the end)."""

    s_m: NDArray[np.float64]
    points_m: NDArray[np.float64]
    cap_mps: NDArray[np.float64]
    waypoint_s_m: NDArray[np.float64]
    through_mps: NDArray[np.float64]


def _px4_run_path(
    start_m: NDArray[np.float64], ends_m: NDArray[np.float64], cruise_mps: NDArray[np.float64],
    profile: Profile, ds_m: float = 0.05,
) -> _Px4RunPath:
    """The path of a run from ``start_m`` through the legs' end points ``ends_m`` (k, 3):
    corners rounded by an arc tangent to both legs at NAV_ACC_RAD (or half a leg) from the
    waypoint, flown at :func:`~validator.motion.px4.corner_speed_mps` at most."""
    acc_rad = profile.si("NAV_ACC_RAD")
    accel, jerk = profile.si("MPC_ACC_HOR"), profile.si("MPC_JERK_AUTO")
    pts = np.vstack([start_m[None, :], ends_m])
    delta = np.diff(pts, axis=0)
    length = np.linalg.norm(delta, axis=1)
    unit = np.divide(delta, length[:, None], out=np.zeros_like(delta), where=length[:, None] > 0)
    k = len(ends_m)
    d_out = np.zeros(k)
    radius = np.full(k, np.inf)
    through = np.zeros(k)
    for j in range(k - 1):
        if length[j] <= 0 or length[j + 1] <= 0:
            continue
        theta = math.acos(float(np.clip(np.dot(unit[j], unit[j + 1]), -1.0, 1.0)))
        exit_mps = px4.max_speed_from_distance(float(length[j + 1]), 0.0, accel, jerk)
        through[j] = min(px4.corner_speed_mps(theta, accel, acc_rad, profile.si("MPC_XY_TRAJ_P")),
                         exit_mps, cruise_mps[j], cruise_mps[j + 1])
        if theta < 1e-3:
            continue  # straight on: no corner
        if theta > math.pi - 1e-3:
            radius[j] = 0.0  # reversal: stop at the waypoint
            through[j] = 0.0
            continue
        d_out[j] = min(acc_rad, length[j] / 2.0, length[j + 1] / 2.0)
        radius[j] = d_out[j] / math.tan(theta / 2.0)
    s_parts, p_parts, c_parts = [], [], []
    wp_s = np.zeros(k)
    s0 = 0.0
    for j in range(k):
        d_in = d_out[j - 1] if j > 0 else 0.0
        straight = max(length[j] - d_in - d_out[j], 0.0)
        m = max(int(math.ceil(straight / ds_m)), 1)
        f = np.linspace(0.0, straight, m + 1)
        begin = pts[j] + unit[j] * d_in
        s_parts.append(s0 + f)
        p_parts.append(begin + np.outer(f, unit[j]))
        c_parts.append(np.full(f.size, np.inf))
        s0 += straight
        wp_s[j] = s0
        if j + 1 < k and d_out[j] > 0 and radius[j] > 0:
            r = radius[j]
            theta = 2.0 * math.atan2(d_out[j], r)
            u1, u2 = unit[j], unit[j + 1]
            normal = u2 - np.dot(u1, u2) * u1
            normal /= np.linalg.norm(normal)
            centre = begin + u1 * straight + normal * r
            m = max(int(math.ceil(r * theta / ds_m)), 2)
            phi = np.linspace(0.0, theta, m + 1)[1:-1]
            s_parts.append(s0 + phi * r)
            p_parts.append(centre - np.outer(np.cos(phi), normal) * r
                           + np.outer(np.sin(phi), u1) * r)
            c_parts.append(np.full(phi.size, through[j]))
            wp_s[j] = s0 + r * theta / 2.0
            s0 += r * theta
    s = np.concatenate(s_parts)
    xyz = np.concatenate(p_parts)
    cap = np.concatenate(c_parts)
    keep = np.concatenate([[True], np.diff(s) > 1e-9])  # drop repeated joints
    return _Px4RunPath(s[keep], xyz[keep], cap[keep], wp_s, through)


def _fly_px4(flight: Flight, profile: Profile, dt_s: float) -> FlownPath:
    legs = flight.legs
    n = len(legs)
    geom = leg_geometry(legs)
    vcap = min(profile.si("MPC_XY_VEL_MAX"), profile.si("VEHICLE_SPEED_MAX"))
    cruise = np.minimum([leg.speed_mps or profile.si("MPC_XY_CRUISE") for leg in legs], vcap)
    jerk = profile.si("MPC_JERK_AUTO")
    start, reached, done = np.zeros(n), np.zeros(n), np.zeros(n)
    t_parts, p_parts = [], []
    clock = 0.0
    here = geom.start[0].copy()
    for run in _px4_runs(flight):
        ends = geom.start[run] + geom.delta[run]
        first = legs[run[0]]
        # a climb or descent in place (the vehicle may still be closing in on its last
        # waypoint horizontally, as PX4 does while it lands)
        vertical = len(run) == 1 and (legs[run[0]].kind in ("takeoff", "land")
                                      or float(np.hypot(*geom.delta[run[0], :2])) < 1e-6)
        if first.kind == "takeoff" and first.start_alt_m <= 0:
            clock += PX4_LIFTOFF_DELAY_S
        if vertical:
            climb = ends[-1, 2] >= here[2]
            path = _px4_run_path(here, ends, np.full(len(run), np.inf), profile)
            accel = profile.si("MPC_ACC_UP_MAX" if climb else "MPC_ACC_DOWN_MAX")
            limit = profile.si("MPC_Z_V_AUTO_UP" if climb else "MPC_Z_V_AUTO_DN")
            landing = legs[run[-1]].kind == "land"
            schedule = _px4_land_schedule(profile, float(here[2])) if landing else None
            flown = px4.fly_run(path.waypoint_s_m, [0.0], [limit], accel, jerk,
                                0.0 if landing else profile.si("NAV_MC_ALT_RAD"),
                                PX4_LAND_DETECT_S if landing else legs[run[-1]].hold_s,
                                speed_profile=schedule)
        else:
            path = _px4_run_path(here, ends, cruise[run], profile)
            flown = px4.fly_run(path.waypoint_s_m, path.through_mps, cruise[run],
                                profile.si("MPC_ACC_HOR"), jerk, profile.si("NAV_ACC_RAD"),
                                legs[run[-1]].hold_s, cap_s_m=path.s_m, cap_mps=path.cap_mps,
                                tracking=_px4_tracking(profile), arrival_lag_s=PX4_ARRIVAL_LAG_S)
        t_run = flown.t_s + clock
        xyz = np.stack([np.interp(flown.s_m, path.s_m, path.points_m[:, c]) for c in range(3)],
                       axis=1)
        t_parts.append(t_run)
        p_parts.append(xyz)
        for j, k in enumerate(run):
            start[k] = clock if j == 0 else reached[run[j - 1]]
            reached[k] = done[k] = clock + flown.reached_s[j]
        done[run[-1]] = clock + flown.end_s
        clock = done[run[-1]]
        here = xyz[-1]
    t_abs = np.concatenate(t_parts)
    xyz_all = np.concatenate(p_parts)
    t = _time_grid(float(done[-1]), dt_s)
    pos = np.stack([np.interp(t, t_abs, xyz_all[:, c]) for c in range(3)], axis=1)
    vel = np.gradient(pos, t, axis=0) if t.size > 1 else np.zeros_like(pos)
    return FlownPath(t, pos, vel, _active_leg(done, t), start, reached, done)


def px4_top_speed_mps(profile: Profile) -> float:
    """The fastest a ``px4`` profile's vehicle flies (m/s): where its drag (VEHICLE_LIN_DRAG)
    uses up the tilt limit (g·tan MPC_TILTMAX_AIR), capped by MPC_XY_VEL_MAX and
    VEHICLE_SPEED_MAX."""
    drag = profile.si("VEHICLE_LIN_DRAG")
    tilt = math.radians(profile.si("MPC_TILTMAX_AIR"))
    top = GRAVITY_MPS2 * math.tan(tilt) / drag if drag > 0 else math.inf
    return min(top, profile.si("MPC_XY_VEL_MAX"), profile.si("VEHICLE_SPEED_MAX"))


def px4_rest_to_rest(profile: Profile, lengths_m: NDArray[np.float64],
                     speed_mps: float) -> px4.SampledLegs:
    """Straight horizontal legs flown alone from rest to a hold by a ``px4`` profile at
    ``speed_mps`` (capped by :func:`px4_top_speed_mps`); see
    :func:`validator.motion.px4.rest_to_rest`."""
    return px4.rest_to_rest(lengths_m, min(speed_mps, px4_top_speed_mps(profile)),
                            profile.si("MPC_ACC_HOR"), profile.si("MPC_JERK_AUTO"),
                            profile.si("NAV_ACC_RAD"), _px4_tracking(profile),
                            PX4_ARRIVAL_LAG_S)


def _px4_tracking(profile: Profile) -> px4.Tracking:
    return px4.Tracking(profile.si("MPC_XY_P"), profile.si("MPC_XY_VEL_P_ACC"),
                        profile.si("MPC_XY_VEL_I_ACC"), profile.si("MPC_TILTMAX_AIR"),
                        profile.si("VEHICLE_LIN_DRAG"), profile.si("MPC_XY_ERR_MAX"))


def _px4_land_schedule(profile: Profile, alt_m: float) -> tuple[NDArray[np.float64],
                                                                  NDArray[np.float64]]:
    """PX4's landing descent speed against the height still to go (m): MPC_Z_V_AUTO_DN down
    to MPC_LAND_ALT1, blending to MPC_LAND_SPEED at MPC_LAND_ALT2 and below."""
    alt1, alt2 = profile.si("MPC_LAND_ALT1"), profile.si("MPC_LAND_ALT2")
    fast, slow = profile.si("MPC_Z_V_AUTO_DN"), profile.si("MPC_LAND_SPEED")
    h = np.array([0.0, alt2, max(alt1, alt2 + 1e-3), max(alt_m, alt1) + 1.0])
    return h, np.array([slow, slow, fast, fast])


def fly(flight: Flight, profile: Profile, *, dt_s: float = 0.05) -> FlownPath:
    """Fly ``flight`` with ``profile``, sampled every ``dt_s`` seconds (and at the very end)."""
    if not flight.legs:
        raise InputError("plan: nothing to replay (no navigation items)")
    if not dt_s > 0:
        raise InputError(f"--dt: must be > 0, got {dt_s}")
    if profile.name == "ideal":
        return _fly_ideal(flight, profile, dt_s)
    if profile.name == "arducopter":
        return _fly_arducopter(flight, profile, dt_s)
    return _fly_px4(flight, profile, dt_s)
