"""Error measures between a measured and a simulated trace: RMSE and the Point Mean Error.

Pure numpy: used by calibration (fits, validation) and by evaluation (model-vs-model PME).
"""

from __future__ import annotations

import numpy as np


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    """Root-mean-square difference [same unit as inputs]."""
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


def pme_percent(
    omega_e: np.ndarray, omega_s: np.ndarray, mask: np.ndarray | None = None, min_speed: float = 1e-3
) -> float:
    """Point Mean Error (paper eq. 12) [%]: mean of (ω_e − ω_s)/ω_e · 100 over on-ramp samples.

    Positive when the simulation underestimates the experiment. Samples with |ω_e| below
    ``min_speed`` [rad/s] (release instant) are excluded to avoid dividing by ~0.
    """
    e, s = np.asarray(omega_e, float), np.asarray(omega_s, float)
    keep = np.abs(e) > min_speed
    if mask is not None:
        keep &= np.asarray(mask, bool)
    if not keep.any():
        return float("nan")
    return float(np.mean((e[keep] - s[keep]) / e[keep]) * 100.0)
