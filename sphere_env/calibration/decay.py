"""The pressure regressions ω_n(p), ζ(p) of paper Fig. 10 and the calibration file they make.

The per-trial damped-sinusoid fit lives in :mod:`sphere_env.analysis.decay`.
Across pressures, ω_n(p) = a + b p (linear) and ζ(p) = s e^{r p} (exponential) are fitted with
CIs and written as a calibration YAML that :meth:`ShellCalibration.load` reads directly.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import yaml
from scipy import stats
from scipy.optimize import curve_fit

from sphere_env.analysis.decay import DecayFit
from sphere_env.files import write_text_atomic
from sphere_env.models.shell import ShellCalibration
from sphere_env.plotting import save_figure

__all__ = [
    "PressureFit",
    "calibration_dict",
    "fit_pressure_curves",
    "plot_pressure_curves",
    "write_yaml",
]


@dataclass(frozen=True)
class PressureFit:
    """ω_n(p) = intercept + slope p  and  ζ(p) = scale e^{rate p}, with CIs (p in kPa)."""

    omega_n_intercept: float
    omega_n_slope: float
    zeta_scale: float
    zeta_rate: float
    ci: dict[str, tuple[float, float]]
    pressures_kpa: tuple[float, ...]
    confidence: float

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["ci"] = {k: list(v) for k, v in self.ci.items()}
        d["pressures_kpa"] = list(self.pressures_kpa)
        return d


def fit_pressure_curves(
    pressures_kpa: Sequence[float], omega_n: Sequence[float], zeta: Sequence[float], confidence: float = 0.95
) -> PressureFit:
    """Linear ω_n(p) and exponential ζ(p) regressions (paper Fig. 10) with CIs.

    Needs at least 3 distinct pressures (2 parameters each plus one degree of freedom for a CI).
    """
    p = np.asarray(pressures_kpa, float)
    w, z = np.asarray(omega_n, float), np.asarray(zeta, float)
    if len(np.unique(p)) < 3:
        raise ValueError(f"fit_pressure_curves: need >= 3 distinct pressures, got {sorted(set(p.tolist()))} kPa")
    if np.any(z <= 0):
        raise ValueError("fit_pressure_curves: every ζ must be > 0 for an exponential fit")
    dof = max(len(p) - 2, 1)
    tq = float(stats.t.ppf(0.5 + confidence / 2, dof))
    lin = lambda x, a, b: a + b * x  # noqa: E731
    (a, b), cov_w = curve_fit(lin, p, w)
    # Exponential: start from the log-linear solution, then refine in linear space.
    r0, ls0 = np.polyfit(p, np.log(z), 1)
    expo = lambda x, s, r: s * np.exp(r * x)  # noqa: E731
    (s, r), cov_z = curve_fit(expo, p, z, p0=[math.exp(ls0), r0], maxfev=20000)
    sw, sz = np.sqrt(np.clip(np.diag(cov_w), 0, None)), np.sqrt(np.clip(np.diag(cov_z), 0, None))
    ci = {
        "omega_n_intercept": (a - tq * sw[0], a + tq * sw[0]),
        "omega_n_slope": (b - tq * sw[1], b + tq * sw[1]),
        "zeta_scale": (s - tq * sz[0], s + tq * sz[0]),
        "zeta_rate": (r - tq * sz[1], r + tq * sz[1]),
    }
    ci = {k: (float(v[0]), float(v[1])) for k, v in ci.items()}
    return PressureFit(float(a), float(b), float(s), float(r), ci, tuple(map(float, p)), confidence)


def calibration_dict(
    fit: PressureFit,
    base: ShellCalibration | None = None,
    pressure_range_kpa: tuple[float, float] | None = None,
    nominal_pressure_kpa: float | None = None,
    provenance: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """A calibration mapping in the :meth:`ShellCalibration.from_dict` format.

    ω_n and ζ come from ``fit``; V(p) and the hydroelastic settings are kept from ``base``
    (default: the shipped calibration). The pressure range defaults to the fitted pressures.
    """
    base = base or ShellCalibration.load()
    lo, hi = pressure_range_kpa or (min(fit.pressures_kpa), max(fit.pressures_kpa))
    raw = dict(base.raw)
    out: dict[str, Any] = {
        "name": raw.get("name", "fitted"),
        "pressure_range_kpa": [float(lo), float(hi)],
        "nominal_pressure_kpa": float(nominal_pressure_kpa if nominal_pressure_kpa is not None else 0.5 * (lo + hi)),
        "omega_n": {
            "model": "linear",
            "intercept_rad_s": fit.omega_n_intercept,
            "slope_rad_s_per_kpa": fit.omega_n_slope,
        },
        "zeta": {"model": "exponential", "scale": fit.zeta_scale, "rate_per_kpa": fit.zeta_rate},
        "contact_volume": raw["contact_volume"],
        "hydroelastic": raw["hydroelastic"],
        "provenance": provenance or {"omega_n, zeta": f"fitted by free decay at {list(fit.pressures_kpa)} kPa"},
        "fit_ci": {k: list(v) for k, v in fit.ci.items()},
    }
    ShellCalibration.from_dict(out, source="<fitted>")  # refuse to return something the twin cannot load
    return out


def write_yaml(path: str | Path, data: dict[str, Any], header: str = "") -> Path:
    """Write YAML atomically (temp file then rename), so a failure leaves nothing half-written."""
    text = (header if not header or header.endswith("\n") else header + "\n") + yaml.safe_dump(
        _plain(data), sort_keys=False, default_flow_style=None, width=110
    )
    return write_text_atomic(path, text)


def _plain(x: Any) -> Any:
    """numpy scalars/tuples -> plain Python for yaml.safe_dump."""
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return float(f"{float(x):.6g}")
    if isinstance(x, np.integer):
        return int(x)
    return x


def plot_pressure_curves(
    path: str | Path,
    pressures_kpa: Sequence[float],
    fits: Sequence[DecayFit],
    curve: PressureFit,
    omega_point_rad_s: float,
) -> Path:
    """Paper Fig. 10: ζ and ω_n per trial with CIs, the regressions, and the point-contact line."""
    from sphere_env.plotting import pyplot

    plt = pyplot()

    p = np.asarray(pressures_kpa, float)
    grid = np.linspace(p.min(), p.max(), 100)
    fig, (az, aw) = plt.subplots(2, 1, figsize=(6, 6), sharex=True)
    z = np.array([f.zeta for f in fits])
    zerr = np.array([[f.zeta - f.zeta_ci[0], f.zeta_ci[1] - f.zeta] for f in fits]).T
    w = np.array([f.omega_n for f in fits])
    werr = np.array([[f.omega_n - f.omega_n_ci[0], f.omega_n_ci[1] - f.omega_n] for f in fits]).T
    az.errorbar(p, z, yerr=zerr, fmt="o", label="free-decay fits")
    az.plot(
        grid,
        curve.zeta_scale * np.exp(curve.zeta_rate * grid),
        "-",
        label=f"ζ = {curve.zeta_scale:.3g} e^({curve.zeta_rate:.3g} p)",
    )
    az.set_ylabel("damping ratio ζ [-]")
    az.legend()
    aw.errorbar(p, w, yerr=werr, fmt="o", label="free-decay fits")
    aw.plot(
        grid,
        curve.omega_n_intercept + curve.omega_n_slope * grid,
        "-",
        label=f"ω_n = {curve.omega_n_intercept:.3g} + {curve.omega_n_slope:.3g} p",
    )
    aw.axhline(omega_point_rad_s, ls="--", color="k", label=f"point contact √(K_eq/M_eq) = {omega_point_rad_s:.3f}")
    aw.set_xlabel("gauge pressure p [kPa]")
    aw.set_ylabel("natural frequency ω_n [rad/s]")
    aw.legend()
    fig.tight_layout()
    return save_figure(fig, path, dpi=110)
