"""How much closer to a zone a multicopter flies in wind than its modelled track: the buffer's
share the forecast eats.

The replay (:mod:`validator.motion`) flies the commanded legs and their blended corners
exactly; a real vehicle in gusts strays from them. From ArduCopter 4.5.6 SITL flights of our
plans in SITL wind (``tests/data/arducopter-sitl-wind/``: ``flights.json`` with the site's
buffer, ``flights-wind-buffer.json`` with the wind buffer; flown by
``benchmarks/sitl_wind_flights.py``) each flight gives the deviation d = (replayed least
clearance) − (flown least clearance) of its closest zone, and :func:`fit_deviation_model`
fits d at the quantile :data:`DEVIATION_QUANTILE` as a + b·turbulence + c·wind (least
squares, then a raised until that share of the flights lies at or below the line).
:data:`DEVIATION_MODEL` holds the fit that ``tests/validator/test_wind_track.py`` pins
against the data.

Why 0.99 and not 0.95: the deviations are not spread around the line but mostly near 0 with
a few corners 0.32-0.39 m (realistic.yaml at 6 m/s from 135°, twice; harbour at 8 m/s from
0°, twice). A 95th percentile line falls between them, and the flight above it (2.98 m
against a 3 m buffer) missed the target "no flown point inside the buffer". At 0.99 the line
lies above all 52 recorded flights (the largest residual; it costs 4.7 cm of buffer at
8 m/s, turbulence 2 m/s, over the 95th percentile of the same data).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from validator.wind import Wind

DEVIATION_QUANTILE = 0.99


@dataclass(frozen=True)
class DeviationModel:
    """d_q = ``intercept_m`` + ``per_turbulence`` · turbulence + ``per_wind`` · wind speed
    (m, m/s), at ``quantile``, from ``flights`` flights in winds up to ``wind_max_mps`` and
    turbulence up to ``turbulence_max_mps`` (beyond, the line is extrapolated)."""

    intercept_m: float
    per_turbulence: float
    per_wind: float
    quantile: float
    flights: int
    wind_max_mps: float
    turbulence_max_mps: float

    def extrapolated(self, wind: Wind | None) -> bool:
        """Whether ``wind`` (at the flight altitude) is stronger or gustier than any flight
        the model is fitted to."""
        return wind is not None and (wind.speed_mps > self.wind_max_mps
                                     or wind.turbulence_mps > self.turbulence_max_mps)

    def deviation_m(self, wind: Wind | None) -> float:
        """The extra closeness (m) of a flight in ``wind`` (at the flight altitude) at the
        model's quantile; never below 0."""
        if wind is None or wind.calm:
            speed = turb = 0.0
        else:
            speed, turb = wind.speed_mps, wind.turbulence_mps
        return max(0.0, self.intercept_m + self.per_turbulence * turb + self.per_wind * speed)


def fit_deviation_model(wind_mps: Sequence[float], turbulence_mps: Sequence[float],
                        deviation_m: Sequence[float],
                        quantile: float = DEVIATION_QUANTILE) -> DeviationModel:
    """The model through flights' (wind, turbulence, deviation): least squares for the
    slopes (clipped at 0: more wind never helps), then the intercept raised so that
    ``quantile`` of the flights lie at or below it."""
    w = np.asarray(wind_mps, dtype=float)
    t = np.asarray(turbulence_mps, dtype=float)
    d = np.asarray(deviation_m, dtype=float)
    a = np.column_stack([np.ones_like(w), t, w])
    coef, *_ = np.linalg.lstsq(a, d, rcond=None)
    slopes = np.maximum(coef[1:], 0.0)
    residual = d - a[:, 1:] @ slopes
    intercept = float(np.quantile(residual, quantile, method="higher"))
    return DeviationModel(intercept, float(slopes[0]), float(slopes[1]), quantile, int(d.size),
                          float(np.max(w)), float(np.max(t)))


# Fitted to the flights of plans made for their wind, in both files (see the module docstring;
# the still-air plans flown in wind are in the data too, but no plan-mission plan flies that
# way).
DEVIATION_MODEL = DeviationModel(intercept_m=0.27731003056387954,
                                 per_turbulence=0.02089585553137111,
                                 per_wind=0.013103103711118195,
                                 quantile=DEVIATION_QUANTILE, flights=52,
                                 wind_max_mps=8.0, turbulence_max_mps=2.0)


def wind_buffer_m(buffer_m: float, wind: Wind | None) -> float:
    """The safety buffer (m) that keeps a plan's flown track ``buffer_m`` from the zones in
    ``wind`` at the model's quantile: ``buffer_m`` plus :data:`DEVIATION_MODEL`'s deviation,
    rounded up to the centimetre (the waypoint radius and fence margin follow from it)."""
    return math.ceil((buffer_m + DEVIATION_MODEL.deviation_m(wind)) * 100.0 - 1e-9) / 100.0


def buffer_share(buffer_m: float, wind: Wind | None) -> dict[str, float]:
    """What the forecast eats of a ``buffer_m`` buffer: the modelled deviation (m) at the
    quantile and its share of the buffer (for the reports)."""
    d = DEVIATION_MODEL.deviation_m(wind)
    return {"track_deviation_m": d, "deviation_quantile": DEVIATION_MODEL.quantile,
            "buffer_m": buffer_m, "share_of_buffer": d / buffer_m if buffer_m > 0 else math.inf,
            "extrapolated": DEVIATION_MODEL.extrapolated(wind)}


def extrapolation_warning(wind: Wind | None, px4: bool = False) -> str | None:
    """One line when ``wind`` (at the flight altitude) is beyond the flights the deviation
    model is fitted to, so the buffer's share of it is a guess; else None. ``px4``: the plan
    is PX4's, whose SIH has no wind to fly it in, so only a wider buffer is offered."""
    if not DEVIATION_MODEL.extrapolated(wind):
        return None
    assert wind is not None
    m = DEVIATION_MODEL
    check = ("PX4's SIH has no wind to check it in: keep a wider buffer (--buffer-m)" if px4
             else "check the plan in that wind (validate-mission --sitl-binary --wind) or keep "
                  "a wider buffer (--buffer-m)")
    return (f"the wind buffer's track deviation is fitted to SITL flights in winds up to "
            f"{m.wind_max_mps:g} m/s with turbulence up to {m.turbulence_max_mps:g} m/s; in "
            f"{wind.label()} its {m.deviation_m(wind):.2f} m is extrapolated: {check}")
