"""Free-decay fits: a damped sinusoid with confidence intervals and the logarithmic decrement.

A transient y(t) = A e^{−ζ ω_n t} cos(ω_n √(1−ζ²) t + ϕ) + c is fitted by least squares
(``scipy.optimize.curve_fit``); confidence intervals come from the parameter covariance and
Student's t. The logarithmic decrement of successive peaks is an independent cross-check.
Pure numpy/scipy: used by calibration (paper Fig. 10), the physics tests and evaluation.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from scipy import stats
from scipy.optimize import curve_fit
from scipy.signal import find_peaks

#: A signal whose peak-to-peak swing is below this fraction of its magnitude is constant to
#: rounding: nothing to fit.
MIN_SWING_REL = 1e-9


def damped_sinusoid(t, amplitude, zeta, omega_n, phase, offset):
    """y(t) = A e^{−ζ ω_n t} cos(ω_n √(1−ζ²) t + ϕ) + c  (t in s, ω_n in rad/s)."""
    wd = omega_n * np.sqrt(np.clip(1.0 - zeta * zeta, 1e-12, None))
    return amplitude * np.exp(-zeta * omega_n * t) * np.cos(wd * t + phase) + offset


@dataclass(frozen=True)
class DecayFit:
    """Damped-sinusoid fit: ω_n [rad/s], ζ [-], with (low, high) confidence intervals.

    ``logdec_zeta``/``logdec_omega_d`` are the log-decrement cross-check (NaN if < 2 peaks).
    """

    omega_n: float
    zeta: float
    omega_n_ci: tuple[float, float]
    zeta_ci: tuple[float, float]
    amplitude: float
    phase: float
    offset: float
    rmse: float
    logdec_zeta: float
    logdec_omega_d: float
    n_samples: int
    confidence: float

    def as_dict(self) -> dict[str, Any]:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}


def log_decrement(t: np.ndarray, y: np.ndarray, offset: float) -> tuple[float, float]:
    """ζ and ω_d [rad/s] from successive peaks of |y − offset| (half-period log decrement).

    Uses both maxima and minima: δ_half = ln(|x_k| / |x_{k+1}|) over half periods, so
    δ = 2 δ_half per period and ζ = δ / √(4π² + δ²).
    """
    x = np.asarray(y, float) - offset
    idx, _ = find_peaks(np.abs(x), prominence=0.05 * float(np.max(np.abs(x)) or 1.0))
    # Peaks below 10 % of the largest are dominated by noise and the offset estimate.
    idx = [i for i in idx if abs(x[i]) > 0.1 * float(np.max(np.abs(x)))]
    if len(idx) < 2:
        return float("nan"), float("nan")
    amps = np.abs(x[idx])
    ts = np.asarray(t)[idx]
    ratios = amps[:-1] / amps[1:]
    good = ratios > 1.0
    if not good.any():
        return float("nan"), float("nan")
    delta = 2.0 * float(np.mean(np.log(ratios[good])))
    zeta = delta / math.sqrt(4 * math.pi**2 + delta**2)
    omega_d = math.pi / float(np.mean(np.diff(ts)))
    return zeta, omega_d


def fit_free_decay(
    t: np.ndarray,
    y: np.ndarray,
    transient_s: float = 0.0,
    omega_guess: float | None = None,
    confidence: float = 0.95,
) -> DecayFit:
    """Fit a damped sinusoid to ``y(t)`` after dropping the first ``transient_s`` seconds.

    :param t: time [s]; :param y: signal (φ or θ) [rad].
    :param omega_guess: initial ω_n [rad/s]; default from the peak spacing.
    :param confidence: two-sided confidence level of the reported intervals.
    """
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    if t.shape != y.shape or t.ndim != 1:
        raise ValueError(f"fit_free_decay: t and y must be 1-D of one length, got {t.shape} and {y.shape}")
    if not (np.isfinite(t).all() and np.isfinite(y).all()):
        raise ValueError("fit_free_decay: t and y must be finite (no NaN or inf)")
    keep = t >= t[0] + transient_s
    t, y = t[keep] - t[keep][0], y[keep]
    if len(t) < 8:
        raise ValueError(f"fit_free_decay: {len(t)} samples after the transient; need >= 8")
    if not np.all(np.diff(t) > 0):
        raise ValueError("fit_free_decay: t must increase strictly")
    swing = float(np.ptp(y))
    if swing <= MIN_SWING_REL * max(float(np.max(np.abs(y))), 1e-300) or swing == 0.0:
        raise ValueError(
            f"fit_free_decay: the signal is constant (peak to peak {swing:.3g}); there is no "
            "oscillation to fit ω_n and ζ to"
        )
    offset0 = float(np.mean(y[-max(len(y) // 6, 1) :]))
    z_ld, wd_ld = log_decrement(t, y, offset0)
    if omega_guess is None:
        omega_guess = wd_ld if math.isfinite(wd_ld) else 2.0 * math.pi / max(t[-1], 1e-3)
    zeta_guess = z_ld if math.isfinite(z_ld) and 0 < z_ld < 0.9 else 0.1
    best = None
    for ph in (0.0, math.pi / 2, -math.pi / 2, math.pi):
        a0 = (y[0] - offset0) / (math.cos(ph) if abs(math.cos(ph)) > 0.2 else 1.0)
        p0 = [a0, zeta_guess, omega_guess, ph, offset0]
        bounds = ([-np.inf, 0.0, 1e-3, -2 * math.pi, -np.inf], [np.inf, 0.95, np.inf, 2 * math.pi, np.inf])
        try:
            popt, pcov = curve_fit(damped_sinusoid, t, y, p0=p0, bounds=bounds, maxfev=20000)
        except RuntimeError:
            continue
        r = float(np.sqrt(np.mean((damped_sinusoid(t, *popt) - y) ** 2)))
        if best is None or r < best[2]:
            best = (popt, pcov, r)
    if best is None:
        raise ValueError("fit_free_decay: damped-sinusoid least squares did not converge")
    popt, pcov, r = best
    z_ld, wd_ld = log_decrement(t, y, float(popt[4]))  # cross-check with the fitted offset
    dof = max(len(t) - len(popt), 1)
    tq = float(stats.t.ppf(0.5 + confidence / 2, dof))
    std = np.sqrt(np.clip(np.diag(pcov), 0, None))
    if not (np.isfinite(std[1:3]).all() and np.all(std[1:3] > 0)):
        # A zero-width or infinite interval: the data do not determine ω_n and ζ (e.g. no
        # oscillation, or fewer samples per period than parameters); the "fit" is the start guess.
        raise ValueError(
            f"fit_free_decay: the data do not determine ω_n and ζ (standard errors "
            f"{std[2]:.3g} rad/s and {std[1]:.3g}); is there a decaying oscillation in the window?"
        )
    return DecayFit(
        omega_n=float(popt[2]),
        zeta=float(popt[1]),
        omega_n_ci=(float(popt[2] - tq * std[2]), float(popt[2] + tq * std[2])),
        zeta_ci=(float(popt[1] - tq * std[1]), float(popt[1] + tq * std[1])),
        amplitude=float(popt[0]),
        phase=float(popt[3]),
        offset=float(popt[4]),
        rmse=r,
        logdec_zeta=z_ld,
        logdec_omega_d=wd_ld,
        n_samples=len(t),
        confidence=confidence,
    )
