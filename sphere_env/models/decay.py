"""Free-decay analysis: fit a damped sinusoid to a transient (paper Fig. 10 processing)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import curve_fit


def damped_sinusoid(t, amplitude, zeta, omega_n, phase, offset):
    """y(t) = A e^{−ζ ω_n t} cos(ω_n √(1−ζ²) t + ϕ) + c."""
    omega_damped = omega_n * np.sqrt(np.clip(1.0 - zeta * zeta, 1e-12, None))
    return amplitude * np.exp(-zeta * omega_n * t) * np.cos(omega_damped * t + phase) + offset


@dataclass(frozen=True)
class DecayFit:
    """Fitted natural frequency ω_n [rad/s], damping ratio ζ [-], and their 1σ standard errors."""

    omega_n: float
    zeta: float
    omega_n_std: float
    zeta_std: float
    amplitude: float
    offset: float
    rmse: float


def fit_free_decay(t: np.ndarray, y: np.ndarray, omega_guess: float | None = None) -> DecayFit:
    """Least-squares damped-sinusoid fit of ``y(t)``.

    The initial frequency guess comes from the zero crossings around the final value unless
    ``omega_guess`` [rad/s] is given.
    """
    t = np.asarray(t, float) - float(t[0])
    y = np.asarray(y, float)
    offset0 = float(np.mean(y[-max(len(y) // 5, 1):]))
    if omega_guess is None:
        s = np.sign(y - offset0)
        crossings = t[1:][np.diff(s) != 0]
        omega_guess = np.pi / np.mean(np.diff(crossings)) if len(crossings) >= 3 else 2.0
    a0 = y[0] - offset0
    p0 = [a0, 0.1, omega_guess, 0.0, offset0]
    bounds = ([-np.inf, 0.0, 0.0, -np.pi, -np.inf], [np.inf, 0.99, np.inf, np.pi, np.inf])
    popt, pcov = curve_fit(damped_sinusoid, t, y, p0=p0, bounds=bounds, maxfev=20000)
    std = np.sqrt(np.clip(np.diag(pcov), 0, None))
    rmse = float(np.sqrt(np.mean((damped_sinusoid(t, *popt) - y) ** 2)))
    return DecayFit(float(popt[2]), float(popt[1]), float(std[2]), float(std[1]), float(popt[0]), float(popt[4]), rmse)
