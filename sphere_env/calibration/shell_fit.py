"""Shell calibration on ``steer_free``-type logs: robot on flat ground, confined to the steer plane.

The pendulum swings freely (steer friction from a preset), the drive joint is locked, and the
shell model alone decides how the body rocks. At the (single, possibly unrecorded) pressure p₀ of
the trials we fit

* ``injected``: ω_n(p₀) [rad/s] and ζ(p₀) [-], i.e. K_inject, C_inject of eqs. 7–8;
* ``hydroelastic``: the modulus [Pa] and the Hunt–Crossley dissipation [s/m].

Both are expressed through a :class:`ShellCalibration`, never by touching the twin's internals:
ω_n and ζ move the intercept/scale of the curves (slopes kept), the modulus becomes a contact-
volume table V(p) = f_n / modulus scaled along the membrane shape, and the dissipation becomes
k_d = d / C_inject(p₀). A fitted calibration is installed in one twin (``twin.set_calibration(cal, p₀)``), so the Drake diagram is built once per model.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np
from scipy.optimize import brentq, least_squares

from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.simulate import rmse, simulate_log
from sphere_env.models.friction import FrictionModel
from sphere_env.models.rigid_body import RobotParameters
from sphere_env.models.shell import ShellCalibration, membrane_contact_volume_m3
from sphere_env.physics.twin import Twin, TwinConfig

AUTHORS_MODULUS_PA = 1.55e5  # the authors' tuned single-pressure modulus (DESIGN.md §3)


def pressure_for_modulus(modulus_pa: float, robot: RobotParameters | None = None,
                         bracket_kpa: tuple[float, float] = (0.2, 200.0)) -> float:
    """The gauge pressure [kPa] at which the membrane estimate gives m_hydro = f_n / V(p) = ``modulus_pa``."""
    r = robot or RobotParameters.from_urdf()
    f = lambda p: r.weight_n / membrane_contact_volume_m3(p, r.weight_n, r.radius_m) - modulus_pa  # noqa: E731
    return float(brentq(f, *bracket_kpa))


def calibration_at(
    base: ShellCalibration,
    pressure_kpa: float,
    omega_n: float | None = None,
    zeta: float | None = None,
    modulus_pa: float | None = None,
    dissipation_s_per_m: float | None = None,
    robot: RobotParameters | None = None,
    table_points: int = 12,
) -> dict[str, Any]:
    """A calibration mapping equal to ``base`` except that, at ``pressure_kpa``:

    ω_n = ``omega_n`` (intercept moved, slope kept), ζ = ``zeta`` (scale moved, rate kept),
    modulus = ``modulus_pa`` (V(p) becomes a table: the base V(p) times one factor so that
    f_n / V(p₀) = modulus), dissipation d = ``dissipation_s_per_m`` (k_d = d / C_inject(p₀)).
    """
    r = robot or RobotParameters.from_urdf()
    raw = copy.deepcopy(dict(base.raw))
    p0 = float(pressure_kpa)
    if omega_n is not None:
        raw["omega_n"] = {"model": "linear", "intercept_rad_s": float(omega_n - base.omega_n_slope * p0),
                          "slope_rad_s_per_kpa": base.omega_n_slope}
    if zeta is not None:
        raw["zeta"] = {"model": "exponential", "scale": float(zeta * math.exp(-base.zeta_rate * p0)),
                       "rate_per_kpa": base.zeta_rate}
    if modulus_pa is not None:
        lo, hi = base.pressure_range_kpa
        grid = np.unique(np.concatenate([np.linspace(lo, hi, table_points), [p0]]))
        v_base = np.array([base.volume_m3(p, r.weight_n, r.radius_m) for p in grid])
        factor = (r.weight_n / modulus_pa) / base.volume_m3(p0, r.weight_n, r.radius_m)
        raw["contact_volume"] = {"model": "table", "pressure_kpa": [float(x) for x in grid],
                                 "volume_m3": [float(v) for v in v_base * factor]}
    if dissipation_s_per_m is not None:
        cal = ShellCalibration.from_dict(raw, source="<fit>")
        _, c_inject = cal.bind(r).injected_gains(p0)
        raw["hydroelastic"] = dict(raw["hydroelastic"], k_d=float(dissipation_s_per_m / c_inject))
    return raw


@dataclass
class ShellFit:
    """Fitted shell parameters at p₀ and per-trial RMSE [rad] of φ and θ on the fit trials."""

    model: str
    pressure_kpa: float
    params: dict[str, float]
    rmse: dict[str, dict[str, float]]
    calibration: dict[str, Any]
    ci95: dict[str, tuple[float, float]] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {"model": self.model, "pressure_kpa": self.pressure_kpa, "params": self.params,
                "rmse_rad": self.rmse, "ci95": {k: list(v) for k, v in self.ci95.items()}}


def steer_plane_twin(model: str, steer_friction: Any, calibration: str | None = None,
                     pressure_kpa: float | None = None, time_step_s: float = 0.005) -> Twin:
    """A ``steer_plane`` twin (drive locked, pendulum free) for one shell model."""
    return Twin(TwinConfig(fixture="steer_plane", shell_model=model, steer_friction=steer_friction,
                           drive_friction="none", calibration=calibration, pressure_kpa=pressure_kpa,
                           time_step_s=time_step_s))


def install_calibration(twin: Twin, raw: Mapping[str, Any], pressure_kpa: float) -> None:
    """Swap ``twin``'s calibration for ``raw`` and apply it at ``pressure_kpa`` (no rebuild)."""
    twin.set_calibration(ShellCalibration.from_dict(dict(raw), source="<fit>"), pressure_kpa)


def trial_rmse(twin: Twin, logs: Sequence[RobotLog]) -> dict[str, dict[str, float]]:
    """φ and θ RMSE [rad] per log for the twin as currently calibrated."""
    out = {}
    for log in logs:
        tr = simulate_log(twin, log)
        out[log.name] = {"phi": rmse(tr["phi"], log["phi"]), "theta": rmse(tr["theta"], log["theta"])}
    return out


def fit_shell(
    logs: Sequence[RobotLog],
    model: str,
    pressure_kpa: float,
    steer_friction: FrictionModel | str = "majd_steer",
    base: ShellCalibration | None = None,
    start: Mapping[str, float] | None = None,
    fixed_injected: Mapping[str, float] | None = None,
    time_step_s: float = 0.005,
    max_nfev: int = 60,
    twin: Twin | None = None,
) -> ShellFit:
    """Fit the shell ``model`` (``injected`` or ``hydroelastic``) at p₀ = ``pressure_kpa`` to steer-plane logs.

    Residuals are φ and θ errors [rad] of every log, each trial weighted equally.
    ``fixed_injected``: ω_n, ζ at p₀ to keep while fitting the hydroelastic parameters (they set
    C_inject, through which the dissipation is stored as k_d); default the base calibration's.
    """
    if model not in ("injected", "hydroelastic"):
        raise ValueError(f"model: value {model!r}; allowed: ['injected', 'hydroelastic']")
    for log in logs:
        for ch in ("phi", "theta"):
            if not log.has(ch):
                raise ValueError(f"log {log.path!r}: needs a {ch} channel for a shell fit")
    base = base or ShellCalibration.load()
    robot = RobotParameters.from_urdf()
    p0 = base.check_pressure(pressure_kpa)
    twin = twin or steer_plane_twin(model, steer_friction, base.source if base.source.endswith(".yaml") else None,
                                    p0, time_step_s)
    inj = dict(fixed_injected or {"omega_n": float(base.omega_n(p0)), "zeta": float(base.zeta(p0))})
    if model == "injected":
        names = ["omega_n", "zeta"]
        x0 = [float((start or {}).get("omega_n", base.omega_n(p0))), float((start or {}).get("zeta", base.zeta(p0)))]
        lo, hi = [0.5, 0.0], [8.0, 0.95]
    else:
        m0, d0 = base.bind(robot).hydroelastic(p0)
        names = ["log10_modulus_pa", "dissipation_s_per_m"]
        x0 = [math.log10((start or {}).get("modulus_pa", m0)), float((start or {}).get("dissipation_s_per_m", d0))]
        lo, hi = [4.0, 0.0], [7.0, 20.0]
    x0 = list(np.clip(x0, lo, hi))

    def raw_for(x) -> dict[str, Any]:
        if model == "injected":
            return calibration_at(base, p0, omega_n=x[0], zeta=x[1], robot=robot)
        return calibration_at(base, p0, modulus_pa=10 ** x[0], dissipation_s_per_m=x[1], robot=robot, **inj)

    weights = [1.0 / math.sqrt(2 * len(log.t)) for log in logs]

    def residuals(x) -> np.ndarray:
        install_calibration(twin, raw_for(x), p0)
        parts = []
        for w, log in zip(weights, logs):
            tr = simulate_log(twin, log)
            parts += [w * (tr["phi"] - log["phi"]), w * (tr["theta"] - log["theta"])]
        return np.concatenate(parts)

    res = least_squares(residuals, x0, bounds=(lo, hi), diff_step=1e-3, x_scale="jac", max_nfev=max_nfev,
                        xtol=1e-6, ftol=1e-8)
    raw = raw_for(res.x)
    install_calibration(twin, raw, p0)
    per = trial_rmse(twin, logs)
    J = res.jac
    try:
        cov = np.linalg.inv(J.T @ J) * (2 * res.cost / max(J.shape[0] - J.shape[1], 1))
        std = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        std = np.full(len(names), np.nan)
    ci = {k: (float(v - 1.96 * s), float(v + 1.96 * s)) for k, v, s in zip(names, res.x, std)}
    if model == "injected":
        params = {"omega_n": float(res.x[0]), "zeta": float(res.x[1])}
        K, C = ShellCalibration.from_dict(raw).bind(robot).injected_gains(p0)
        params.update(K_inject=K, C_inject=C)
    else:
        params = {"modulus_pa": float(10 ** res.x[0]), "dissipation_s_per_m": float(res.x[1]),
                  "k_d": float(raw["hydroelastic"]["k_d"])}
    return ShellFit(model, p0, params, per, raw, ci)
