"""The site's numbers in the units the solver sees: all O(1).

Lengths are in units of ``LENGTH_UNIT_M`` (100 m), slot lengths in units of T/N (mean 1), power
in units of P_avg. σ² cancels from the rate: with d̃ = d / 100 m and p̃ = p / P_avg,

    log2(1 + β0 p / (σ² d²)) = log2(1 + ρ p̃ / d̃²),   ρ = β0 P_avg / (σ² (100 m)²).

Polygon zones enter as their convex parts (``parts``) in the same length unit, each part
tagged with its zone (``part_zone``); a leg keeps ``clearance`` (buffer + planning margin) from
every part.

With a fixed ``gamma`` (the paper's γ1 = γ2 = 100), the shifts are moved by the constant that
normalisation takes out of each logarithm, so the quadratic-transform surrogate is exactly the
paper's; by default they are set per rate term at each SCA point instead
(:func:`.trajectory.qt_shifts`).

Wind (the site's forecast at the flight altitude, :mod:`validator.wind`) enters as ``wind``,
the distance the air moves in a unit slot length: the top speed then holds in the air frame,
‖q[n] − q[n−1] − w̃ δ̃[n]‖ ≤ Ṽ δ̃[n], beside the ground-speed limit ‖q[n] − q[n−1]‖ ≤ Ṽ δ̃[n]
(the fastest speed the plan commands over the ground, which Theorem 1's radius is built on).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from validator.site import Site
from validator.wind import ground_speed_mps

LENGTH_UNIT_M = 100.0


@dataclass(frozen=True)
class Scaled:
    """A site in solver units. ``radius`` already includes buffer and planning margin, and so
    does ``clearance``, the distance every leg keeps from each polygon part."""

    num_slots: int  # N
    num_gns: int  # K
    num_nfzs: int  # M
    gn: NDArray[np.float64]  # (K, 2)
    nfz: NDArray[np.float64]  # (M, 2)
    radius: NDArray[np.float64]  # (M,)
    height: float  # H̃
    speed: float  # Ṽ: distance per unit slot length at top speed
    rho: float  # β0 P_avg / (σ² L0²)
    peak: float  # P_peak / P_avg
    gamma1: float | None  # the QT's fixed shifts in these units; None: per term (trajectory)
    gamma2: float | None
    period_s: float
    parts: tuple[NDArray[np.float64], ...] = ()  # convex parts of the polygon zones, (Q, 2) each
    part_zone: tuple[int, ...] = ()  # index into Site.polygon_zones of each part
    clearance: float = 0.0  # buffer + margin
    wind: NDArray[np.float64] | None = None  # (2,) w̃: air's move per unit slot; None: still air

    @property
    def slot_s(self) -> float:
        """Seconds per unit slot length (T/N)."""
        return self.period_s / self.num_slots

    def leg_speed(self, legs: NDArray[np.float64]) -> NDArray[np.float64]:
        """(N,) the fastest each leg ``legs`` (N, 2, displacement) can be flown, in length
        per unit slot: Ṽ, or in wind the lower of Ṽ and the ground speed its heading leaves
        (:func:`validator.wind.ground_speed_mps`; NaN where none)."""
        if self.wind is None:
            return np.full(len(legs), self.speed)
        length = np.linalg.norm(legs, axis=1)
        unit = np.divide(legs, length[:, None], out=np.zeros_like(legs),
                         where=length[:, None] > 0)
        g = ground_speed_mps(self.speed, self.wind, unit)
        return np.asarray(np.where(length > 0, np.minimum(g, self.speed), self.speed),
                          dtype=float)

    def air_excess(self, legs: NDArray[np.float64], delta: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
        """(N,) ‖leg − w̃ δ̃‖ − Ṽ δ̃, above 0 where a leg breaks the air-frame limit; −inf
        in still air, where the ground limit alone holds."""
        if self.wind is None:
            return np.full(len(legs), -np.inf)
        air = legs - delta[:, None] * self.wind[None, :]
        return np.asarray(np.linalg.norm(air, axis=1) - self.speed * delta, dtype=float)


def scale_site(site: Site, margin_m: float, gamma: float | None = None) -> Scaled:
    """Scale ``site``; NFZ radii become radius + buffer + ``margin_m``, and polygon parts are
    kept buffer + ``margin_m`` away from."""
    n = site.slots
    slot_s = site.period_s / n
    # log2(σ² A_SI + β0 p) = log2(Ã + ρ p̃) + log2(σ² L0²); log2(B_SI/σ²) = log2 B̃ − log2(σ² L0²).
    shift = float(np.log2(site.noise_w * LENGTH_UNIT_M**2))
    return Scaled(
        num_slots=n,
        num_gns=site.num_gns,
        num_nfzs=site.num_nfzs,
        gn=site.gn_xy_m / LENGTH_UNIT_M,
        nfz=site.nfz_xy_m.reshape(-1, 2) / LENGTH_UNIT_M,
        radius=(site.planning_radius_m + margin_m) / LENGTH_UNIT_M,
        height=site.altitude_m / LENGTH_UNIT_M,
        speed=site.max_speed_mps * slot_s / LENGTH_UNIT_M,
        rho=site.beta0 * site.p_avg_w / (site.noise_w * LENGTH_UNIT_M**2),
        peak=site.p_peak_w / site.p_avg_w,
        gamma1=None if gamma is None else gamma + shift,
        gamma2=None if gamma is None else gamma - shift,
        period_s=site.period_s,
        parts=tuple(p / LENGTH_UNIT_M for z in site.polygon_zones for p in z.parts),
        part_zone=tuple(i for i, z in enumerate(site.polygon_zones) for _ in z.parts),
        clearance=(site.buffer_m + margin_m) / LENGTH_UNIT_M,
        wind=(None if site.flight_wind is None
              else site.flight_wind.vector_mps * slot_s / LENGTH_UNIT_M),
    )


def distance_sq(sc: Scaled, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """(K, N) squared 3-D distance d̃² from slot positions ``q`` (N, 2) to every GN."""
    diff = q[None, :, :] - sc.gn[:, None, :]
    return np.asarray(np.sum(diff * diff, axis=-1) + sc.height**2, dtype=float)


def slot_rates(
    sc: Scaled, q: NDArray[np.float64], delta: NDArray[np.float64], power: NDArray[np.float64]
) -> NDArray[np.float64]:
    """(K, N) exact rate terms δ̃ log2(1 + ρ p̃ / d̃²) / N, so that rates = Σ_n s ∘ terms."""
    snr = sc.rho * power[None, :] / distance_sq(sc, q)
    return np.asarray(delta[None, :] * np.log2(1.0 + snr) / sc.num_slots, dtype=float)


def min_rate(
    sc: Scaled,
    q: NDArray[np.float64],
    delta: NDArray[np.float64],
    power: NDArray[np.float64],
    s: NDArray[np.float64],
) -> float:
    """Exact objective of (P0) for a (possibly relaxed) schedule ``s`` (K, N), bps/Hz."""
    return float(np.min(np.sum(s * slot_rates(sc, q, delta, power), axis=1)))
