"""Wind: what the air does at a site, and what it leaves of a multicopter's speed over ground.

Conventions are aviation's: a wind's speed in m/s and the direction it blows FROM in degrees
true (0 = from the north, 90 = from the east; "7@300" is 7 m/s from west-north-west), its
turbulence as the standard deviation of the gusts in m/s (ArduPilot SITL's SIM_WIND_TURB).
A site's ``wind:`` may give layers by height above ground; the wind at an altitude is the
highest layer at or below it (the top-level figures are the layer at the ground).

A multicopter's speed is limited relative to the air (its lean against drag), not the ground.
Flying along a unit heading u over the ground at ground speed g in a wind w (m/s, the vector
the air moves along), its air velocity is g·u − w, so the fastest it can hold along u with
air-speed limit V is the positive root of |g·u − w| = V:

    g(u) = u·w + sqrt(V² − |w|² + (u·w)²)

It exists for every heading exactly when |w| < V; at or above, the vehicle can neither hold
position nor fly upwind, and such a wind is refused (:func:`check_flyable`).

In turbulence of standard deviation σ the gusts add to the drag's mean, and a vehicle at its
lean limit has no authority left to hold its speed through them: a plan commands no more
than the airspeed it still holds, sqrt(V² − k·σ²) (:func:`held_air_speed_mps`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import BaseModel, ConfigDict, Field, field_validator

from validator.errors import InputError

MAX_WIND_MPS = 100.0  # far beyond any wind a multicopter flies in: catches unit mistakes
MAX_LAYERS = 32
# k of the airspeed held in gusts, sqrt(V² − k·σ²). Fitted to ArduCopter 4.5.6 SITL: over 110
# legs of 60 m and more commanded at the air-speed cap (ninth and tenth wind campaigns,
# turbulence 0.5-2 m/s) the airspeed flown was 9.4-10.6 m/s against the model's 10.08 (median
# 9.98: the per-axis drag of a crabbing SITL quad gains about what the gusts cost); the
# slowest at σ = 2 m/s, legs into the wind, flew 9.79-9.88 (two flights 3 % late on such
# legs), which k = 1.5 (9.78) keeps.
GUST_KEEP = 1.5


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, strict=True)


class WindLayerModel(_Strict):
    """The wind from ``above_m`` metres above ground upward (to the next layer)."""

    above_m: float = Field(gt=0, le=1e5)
    speed_mps: float = Field(ge=0, le=MAX_WIND_MPS)
    from_deg: float = Field(ge=0, le=360)
    turbulence_mps: float = Field(default=0.0, ge=0, le=MAX_WIND_MPS)


class WindModel(_Strict):
    """A site file's ``wind:`` exactly as written (pydantic schema)."""

    speed_mps: float = Field(ge=0, le=MAX_WIND_MPS, description="mean wind speed, m/s")
    from_deg: float = Field(ge=0, le=360, description="direction it blows from, degrees true")
    turbulence_mps: float = Field(default=0.0, ge=0, le=MAX_WIND_MPS,
                                  description="gusts' standard deviation, m/s")
    layers: list[WindLayerModel] = Field(default_factory=list, max_length=MAX_LAYERS)

    @field_validator("layers")
    @classmethod
    def _one_layer_per_height(cls, layers: list[WindLayerModel]) -> list[WindLayerModel]:
        # two layers from the same height leave the wind there to the order they are written in
        seen: dict[float, int] = {}
        for i, a in enumerate(layers):
            if a.above_m in seen:
                raise ValueError(f"layers[{i}].above_m {a.above_m:g} m is layer "
                                 f"{seen[a.above_m]}'s height too: one layer per height")
            seen[a.above_m] = i
        return layers


@dataclass(frozen=True)
class WindLayer:
    """Wind from ``above_m`` metres above ground upward."""

    above_m: float
    speed_mps: float
    from_deg: float
    turbulence_mps: float = 0.0


@dataclass(frozen=True)
class Wind:
    """A forecast: mean ``speed_mps`` from ``from_deg`` (degrees true), ``turbulence_mps``,
    at the ground and (``layers``, sorted by height) higher up."""

    speed_mps: float
    from_deg: float
    turbulence_mps: float = 0.0
    layers: tuple[WindLayer, ...] = ()

    @classmethod
    def from_model(cls, model: WindModel) -> Wind:
        layers = sorted((WindLayer(a.above_m, a.speed_mps, a.from_deg % 360.0, a.turbulence_mps)
                         for a in model.layers), key=lambda a: a.above_m)
        return cls(model.speed_mps, model.from_deg % 360.0, model.turbulence_mps, tuple(layers))

    def at(self, above_m: float) -> Wind:
        """The wind (one layer) at ``above_m`` metres above ground."""
        chosen = Wind(self.speed_mps, self.from_deg, self.turbulence_mps)
        for a in self.layers:
            if a.above_m <= above_m:
                chosen = Wind(a.speed_mps, a.from_deg, a.turbulence_mps)
        return chosen

    def scaled(self, factor: float) -> Wind:
        """The same wind with every speed (and turbulence) times ``factor``."""
        return Wind(self.speed_mps * factor, self.from_deg, self.turbulence_mps * factor,
                    tuple(WindLayer(a.above_m, a.speed_mps * factor, a.from_deg,
                                    a.turbulence_mps * factor) for a in self.layers))

    @property
    def calm(self) -> bool:
        return self.speed_mps == 0.0 and not any(a.speed_mps for a in self.layers)

    @property
    def vector_mps(self) -> NDArray[np.float64]:
        """(east, north) velocity of the air at the ground layer, m/s: it blows TOWARD
        from_deg + 180°."""
        return wind_vector_mps(self.speed_mps, self.from_deg)

    def label(self) -> str:
        """``7 m/s from 300°`` (and its turbulence); a layered wind names each layer and the
        height (m above ground) it starts at: ``2 m/s from 270° at the ground, 6 m/s from
        270°, turbulence 1 m/s from 20 m``."""
        ground = _layer_label(self.speed_mps, self.from_deg, self.turbulence_mps)
        if not self.layers:
            return ground
        return ", ".join([f"{ground} at the ground"] + [
            f"{_layer_label(a.speed_mps, a.from_deg, a.turbulence_mps)} from {a.above_m:g} m"
            for a in self.layers])

    def to_dict(self) -> dict[str, object]:
        """The ``wind:`` mapping :class:`WindModel` reads back."""
        out: dict[str, object] = {"speed_mps": self.speed_mps, "from_deg": self.from_deg,
                                  "turbulence_mps": self.turbulence_mps}
        if self.layers:
            out["layers"] = [{"above_m": a.above_m, "speed_mps": a.speed_mps,
                              "from_deg": a.from_deg, "turbulence_mps": a.turbulence_mps}
                             for a in self.layers]
        return out


def _layer_label(speed_mps: float, from_deg: float, turbulence_mps: float) -> str:
    turb = f", turbulence {turbulence_mps:g} m/s" if turbulence_mps else ""
    return f"{speed_mps:g} m/s from {from_deg:g}°{turb}"


def wind_vector_mps(speed_mps: float, from_deg: float) -> NDArray[np.float64]:
    """(east, north) velocity (m/s) of a wind of ``speed_mps`` blowing from ``from_deg``."""
    b = math.radians(from_deg)
    return np.array([-speed_mps * math.sin(b), -speed_mps * math.cos(b)], dtype=float)


_ARG = re.compile(r"^\s*([0-9.eE+-]+)\s*@\s*([0-9.eE+-]+)\s*(?:,\s*([0-9.eE+-]+)\s*)?$")


def parse_wind_arg(text: str, flag: str = "--wind") -> Wind:
    """``SPEED@FROM`` or ``SPEED@FROM,TURBULENCE`` (m/s, degrees true, m/s) from a command
    line, e.g. ``7@300`` or ``6@135,1.5``; ``0`` or ``calm`` for still air."""
    if text.strip().lower() in ("0", "calm"):
        return Wind(0.0, 0.0)
    m = _ARG.match(text)
    if m is None:
        raise InputError(f"{flag} {text}: expected SPEED@FROM (m/s and degrees the wind blows "
                         "from, e.g. 7@300) or SPEED@FROM,TURBULENCE")
    try:
        speed, frm = float(m.group(1)), float(m.group(2))
        turb = float(m.group(3)) if m.group(3) is not None else 0.0
    except ValueError:
        raise InputError(f"{flag} {text}: not a number") from None
    if not (math.isfinite(speed) and 0 <= speed <= MAX_WIND_MPS):
        raise InputError(f"{flag} {text}: speed must be 0 to {MAX_WIND_MPS:g} m/s")
    if not (math.isfinite(frm) and 0 <= frm <= 360):
        raise InputError(f"{flag} {text}: direction must be 0 to 360 degrees (from)")
    if not (math.isfinite(turb) and 0 <= turb <= MAX_WIND_MPS):
        raise InputError(f"{flag} {text}: turbulence must be 0 to {MAX_WIND_MPS:g} m/s")
    return Wind(speed, frm % 360.0, turb)


def ground_speed_mps(air_speed_mps: float, wind_mps: ArrayLike,
                     unit: ArrayLike) -> NDArray[np.float64]:
    """The fastest ground speed (m/s) along each horizontal unit heading ``unit`` (n, 2) with
    air-speed limit ``air_speed_mps`` in the wind vector ``wind_mps`` (east, north): the
    positive root g of |g·u − w| = V (module docstring); NaN where there is none."""
    u = np.atleast_2d(np.asarray(unit, dtype=float))
    w = np.asarray(wind_mps, dtype=float)
    uw = u @ w
    disc = air_speed_mps**2 - float(w @ w) + uw * uw
    with np.errstate(invalid="ignore"):
        g = uw + np.sqrt(disc)
    return np.asarray(np.where((disc >= 0) & (g > 0), g, np.nan), dtype=float)


def lean_limit_ground_speed_mps(air_speed_mps: float, wind_mps: ArrayLike, unit: ArrayLike,
                                linear_share: float) -> NDArray[np.float64]:
    """The ground speed (m/s) along each horizontal unit course ``unit`` (n, 2) of a multicopter
    leaning at its limit in the wind ``wind_mps`` (east, north), heading along its course
    (ArduCopter yaws to the next waypoint), whose drag has a linear part the same every way
    and a quadratic part per body axis; NaN where it cannot progress.

    With air velocity a along the course and c across it, the drag per unit of the lean
    limit's horizontal thrust is s·(a, c)/V + (1 − s)·(a·|a|, c·|c|)/V², s = ``linear_share``
    (the rotors' momentum drag; the rest is the body's), V = ``air_speed_mps``, the airspeed
    it balances at straight into still air. At the limit the crosswind takes
    D_c = s·c/V + (1 − s)·c²/V² of it and leaves D_a = sqrt(1 − D_c²) along the course, so
    a = V·(sqrt(s² + 4·(1 − s)·D_a) − s) / (2·(1 − s)) (V·D_a at s = 1) and g = u·w + a.
    Crabbing across a wind, such a vehicle holds more air speed than one whose drag is the
    same every way (s = 1, where g is :func:`ground_speed_mps`'s): its body drag falls off
    per axis."""
    if not 0.0 <= linear_share <= 1.0:
        raise ValueError(f"linear_share must be 0 to 1, got {linear_share}")
    u = np.atleast_2d(np.asarray(unit, dtype=float))
    w = np.asarray(wind_mps, dtype=float)
    s, v = float(linear_share), float(air_speed_mps)
    c = np.abs(u[:, 0] * w[1] - u[:, 1] * w[0]) / v
    d_c = s * c + (1.0 - s) * c * c
    d_a = np.sqrt(np.clip(1.0 - d_c * d_c, 0.0, None))
    if s >= 1.0:
        a = d_a
    else:
        a = (np.sqrt(s * s + 4.0 * (1.0 - s) * d_a) - s) / (2.0 * (1.0 - s))
    g = u @ w + v * a
    return np.asarray(np.where((d_c < 1.0) & (g > 0), g, np.nan), dtype=float)


def held_air_speed_mps(top_mps: float, turbulence_mps: float) -> float:
    """The airspeed (m/s) a vehicle whose top airspeed is ``top_mps`` still holds in gusts of
    standard deviation ``turbulence_mps``: sqrt(V² − k·σ²), k = :data:`GUST_KEEP` (module
    docstring); 0 when the gusts leave nothing."""
    return math.sqrt(max(top_mps * top_mps - GUST_KEEP * turbulence_mps * turbulence_mps, 0.0))


def heading_deg(unit: ArrayLike) -> NDArray[np.float64]:
    """Course over ground (degrees true, 0 north, 90 east) of (east, north) vectors."""
    u = np.atleast_2d(np.asarray(unit, dtype=float))
    return np.asarray(np.degrees(np.arctan2(u[:, 0], u[:, 1])) % 360.0, dtype=float)


def check_flyable(air_speed_mps: float, wind: Wind, where: str,
                  unit: ArrayLike | None = None, names: list[str] | None = None,
                  gusts: bool = False) -> None:
    """Refuse (:class:`InputError`, one line) a wind the vehicle cannot fly against: at or
    above its air-speed limit ``air_speed_mps`` it can neither hold a position nor fly upwind.
    With headings ``unit`` (n, 2) and their ``names`` the first leg it cannot fly is named.
    ``gusts``: the limit is the airspeed held through the wind's turbulence
    (:func:`held_air_speed_mps`), and the message says so."""
    w = wind.vector_mps
    if wind.speed_mps < air_speed_mps:
        return
    leg = ""
    if unit is not None:
        g = ground_speed_mps(air_speed_mps, w, unit)
        bad = np.flatnonzero(~np.isfinite(g))
        if bad.size:
            i = int(bad[0])
            name = names[i] if names else f"leg {i}"
            leg = f"{name} (course {float(heading_deg(unit)[i]):.0f}°) cannot be flown: "
    limit = (f"the airspeed the vehicle holds through its gusts, {air_speed_mps:.2f} m/s" if gusts
             else f"the vehicle's top airspeed {air_speed_mps:.2f} m/s")
    raise InputError(f"{where}: {leg}{wind.label()} is at or above {limit}; it can "
                     "neither hold position nor fly upwind")


def course_speeds_mps(air_speed_mps: float, wind: Wind, heading: ArrayLike,
                      names: list[str] | None = None, *, gusts: bool = False,
                      along: Callable[[float, ArrayLike, ArrayLike], NDArray[np.float64]]
                      = ground_speed_mps) -> NDArray[np.float64]:
    """(n,) the ground speed (m/s) a vehicle of top airspeed ``air_speed_mps`` makes in
    ``wind`` along each leg's horizontal ``heading`` (n, 2 or more; any length; the first two
    are east, north): ``along(air_speed_mps, wind vector, unit course)``, by default
    :func:`ground_speed_mps` (the cone), and ``air_speed_mps`` on a leg with no horizontal
    heading (a climb). A wind at or above ``air_speed_mps`` is refused by
    :func:`check_flyable`, naming the first leg of ``names`` it cannot fly (``gusts`` as
    there): the one course rule of every flight model."""
    h = np.atleast_2d(np.asarray(heading, dtype=float))[:, :2]
    norm = np.hypot(h[:, 0], h[:, 1])
    flat = norm > 1e-9
    u = np.divide(h, norm[:, None], out=np.zeros_like(h), where=flat[:, None])
    named = [n for n, f in zip(names or [], flat, strict=False) if f] or None
    check_flyable(air_speed_mps, wind, "wind", u[flat], named, gusts=gusts)
    return np.asarray(np.where(flat, along(air_speed_mps, wind.vector_mps, u), air_speed_mps),
                      dtype=float)
