"""The line-of-sight air-to-ground rate model of the paper (eqs. 11-13).

Channel gain h = β0 / (‖q − w‖² + H²); spectral efficiency log2(1 + h·p/σ²) in bps/Hz.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def dbm_to_w(dbm: float) -> float:
    """A power in dBm as watts."""
    return float(10.0 ** ((dbm - 30.0) / 10.0))


def db_to_linear(db: float) -> float:
    """A gain in dB as a ratio."""
    return float(10.0 ** (db / 10.0))


def spectral_efficiency(
    uav_xy_m: ArrayLike,
    gn_xy_m: ArrayLike,
    altitude_m: float,
    power_w: ArrayLike,
    beta0: float,
    noise_w: float,
) -> NDArray[np.float64]:
    """Instantaneous rate (bps/Hz) from UAV positions (..., 2) to a GN at ``gn_xy_m`` (..., 2)."""
    q = np.asarray(uav_xy_m, dtype=float)
    w = np.asarray(gn_xy_m, dtype=float)
    d2 = np.sum((q - w) ** 2, axis=-1) + altitude_m**2
    snr = beta0 * np.asarray(power_w, dtype=float) / (noise_w * d2)
    return np.asarray(np.log2(1.0 + snr), dtype=float)


def hover_upper_bound(
    num_gns: int, altitude_m: float, p_avg_w: float, beta0: float, noise_w: float
) -> float:
    """(1/K)·log2(1 + β0·P_avg/(σ²H²)): every GN served from straight above at average power."""
    return float(np.log2(1.0 + beta0 * p_avg_w / (noise_w * altitude_m**2)) / num_gns)
