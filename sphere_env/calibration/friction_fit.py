"""Joint-friction fit: simulate the ``stand`` fixture against stand-swing logs (paper Fig. 7).

The shell is held by the stand, so the pendulum swings on the steer joint under gravity and the
gearbox friction only. For a chosen law the parameters are fitted by bounded nonlinear least
squares (``scipy.optimize.least_squares``, several starts) on θ(t), each trial weighted equally.
An optional constant encoder offset θ_log = θ_model + θ_0 can be fitted with them: the model's
equilibrium is set by the pendulum COM's small y-offset (≈ −0.035 rad), the logs rest near
−0.015 rad, and that 0.02 rad is either a zero offset of the encoder or a COM error — the fit
reports it instead of hiding it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Mapping, Sequence

import numpy as np
from pydantic import Field
from scipy.optimize import least_squares

from sphere_env.analysis.metrics import rmse
from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.simulate import SimTrace, simulate_log
from sphere_env.files import write_text_atomic
from sphere_env.models.friction import FRICTION_LAWS, FrictionModel
from sphere_env.physics import Twin, TwinConfig
from sphere_env.plotting import save_figure
from sphere_env.schemas import Schema, allowed, validate

# Bounds for each law's parameters (units as in sphere_env.models.friction).
BOUNDS: dict[str, dict[str, tuple[float, float]]] = {
    "viscous": {"c": (0.0, 5.0)},
    "coulomb": {"mu_s": (0.0, 3.0), "mu_d": (0.0, 3.0), "c": (0.0, 3.0), "v_tol": (0.005, 0.5)},
    "majd": {"f_w": (0.0, 3.0), "f_c": (0.0, 3.0), "sigma": (0.0, 30.0), "omega_c": (0.02, 3.0), "n": (0.2, 5.0)},
}


class FrictionFitOptions(Schema):
    """The choices of :func:`fit_friction`: the law (one of :data:`BOUNDS`) and the joint."""

    law: Literal[tuple(BOUNDS)] = Field(json_schema_extra=allowed(str(sorted(BOUNDS))))  # type: ignore[valid-type]
    joint: Literal["steer"] = Field(json_schema_extra=allowed("['steer'] (the stand only frees the steer joint)"))


DEFAULT_START: dict[str, dict[str, float]] = {
    "viscous": {"c": 0.3},
    "coulomb": {"mu_s": 0.5, "mu_d": 0.45, "c": 0.1, "v_tol": 0.05},
    "majd": {"f_w": 0.2, "f_c": 0.45, "sigma": 10.0, "omega_c": 0.1, "n": 1.0},
}
DEFAULT_FIXED = {"coulomb": ("v_tol",)}
OFFSET_BOUNDS = (-0.1, 0.1)  # rad


@dataclass
class FrictionFit:
    """Fitted law parameters, encoder offset [rad] and per-trial θ RMSE [rad]."""

    law: str
    joint: str
    params: dict[str, float]
    theta_offset_rad: float
    rmse_per_trial: dict[str, float]
    free: tuple[str, ...]
    ci95: dict[str, tuple[float, float]] = field(default_factory=dict)
    starts: int = 1
    cost: float = float("nan")

    @property
    def model(self) -> FrictionModel:
        return FrictionModel(self.law, self.params)

    @property
    def max_rmse(self) -> float:
        return max(self.rmse_per_trial.values())

    def as_dict(self) -> dict[str, Any]:
        return {
            "law": self.law,
            "joint": self.joint,
            "params": self.params,
            "theta_offset_rad": self.theta_offset_rad,
            "rmse_per_trial_rad": self.rmse_per_trial,
            "free": list(self.free),
            "ci95": {k: list(v) for k, v in self.ci95.items()},
            "starts": self.starts,
        }


def stand_twin(model: FrictionModel, time_step_s: float = 0.005) -> Twin:
    """A ``stand`` twin with ``model`` on the steer joint (built in ~10 ms)."""
    return Twin(
        TwinConfig(
            fixture="stand", shell_model="point", steer_friction=model, drive_friction="none", time_step_s=time_step_s
        )
    )


def simulate_stand(
    logs: Sequence[RobotLog], model: FrictionModel, theta_offset_rad: float = 0.0, time_step_s: float = 0.005
) -> list[SimTrace]:
    """Simulate every stand log with one friction model."""
    twin = stand_twin(model, time_step_s)
    return [simulate_log(twin, log, theta_offset_rad) for log in logs]


def evaluate_friction(
    logs: Sequence[RobotLog], model: FrictionModel, theta_offset_rad: float = 0.0, time_step_s: float = 0.005
) -> dict[str, float]:
    """Per-trial θ RMSE [rad] of ``model`` against stand logs."""
    traces = simulate_stand(logs, model, theta_offset_rad, time_step_s)
    return {log.name: rmse(tr["theta"], log["theta"]) for log, tr in zip(logs, traces)}


def fit_friction(
    logs: Sequence[RobotLog],
    law: str = "majd",
    joint: str = "steer",
    start: Mapping[str, float] | None = None,
    fixed: Sequence[str] | None = None,
    fit_offset: bool = False,
    theta_offset_rad: float = 0.0,
    starts: int = 3,
    seed: int = 0,
    time_step_s: float = 0.005,
    max_nfev: int = 200,
) -> FrictionFit:
    """Fit ``law`` parameters to stand-swing logs; returns the best of ``starts`` starts.

    :param start: first start point (default :data:`DEFAULT_START`); further starts are drawn
        log-uniformly inside :data:`BOUNDS` with ``seed``.
    :param fixed: parameters held at their ``start`` value (e.g. weakly identifiable ones).
    :param fit_offset: also fit a constant encoder offset θ_0 [rad]; else ``theta_offset_rad`` is used.
    """
    validate(FrictionFitOptions, {"law": law, "joint": joint}, "fit_friction")
    for log in logs:
        if not log.has("theta"):
            raise ValueError(f"log {log.path!r}: needs a theta (roll_joint.position) channel for a friction fit")
        if log.fixture not in (None, "stand"):
            raise ValueError(f"log {log.path!r}: fixture {log.fixture!r}; a friction fit needs 'stand' logs")
    names = FRICTION_LAWS[law][1]
    base = dict(DEFAULT_START[law])
    base.update(start or {})
    fixed = tuple(fixed if fixed is not None else DEFAULT_FIXED.get(law, ()))
    free = tuple(k for k in names if k not in fixed)
    lo = [BOUNDS[law][k][0] for k in free] + ([OFFSET_BOUNDS[0]] if fit_offset else [])
    hi = [BOUNDS[law][k][1] for k in free] + ([OFFSET_BOUNDS[1]] if fit_offset else [])
    weights = [1.0 / math.sqrt(len(log.t_s)) for log in logs]

    def unpack(x: np.ndarray) -> tuple[FrictionModel, float]:
        params = dict(base)
        params.update({k: float(v) for k, v in zip(free, x[: len(free)])})
        off = float(x[len(free)]) if fit_offset else theta_offset_rad
        return FrictionModel(law, params), off

    def residuals(x: np.ndarray) -> np.ndarray:
        model, off = unpack(x)
        traces = simulate_stand(logs, model, off, time_step_s)
        return np.concatenate([w * (tr["theta"] - log["theta"]) for w, tr, log in zip(weights, traces, logs)])

    rng = np.random.default_rng(seed)
    x_first = np.array([base[k] for k in free] + ([theta_offset_rad] if fit_offset else []), float)
    x_first = np.clip(x_first, lo, hi)
    starts_x = [x_first]
    for _ in range(max(starts, 1) - 1):
        x = []
        for a, b in zip(lo, hi):
            if a > 0:
                x.append(math.exp(rng.uniform(math.log(a), math.log(b))))
            elif a < 0:
                x.append(rng.uniform(a / 2, b / 2))
            else:
                x.append(math.exp(rng.uniform(math.log(b * 1e-2), math.log(b * 0.5))))
        starts_x.append(np.array(x))
    best = None
    for x0 in starts_x:
        res = least_squares(
            residuals, x0, bounds=(lo, hi), diff_step=1e-3, x_scale="jac", max_nfev=max_nfev, xtol=1e-6, ftol=1e-8
        )
        if best is None or res.cost < best.cost:
            best = res
    model, off = unpack(best.x)
    ci = _ci95(best, list(free) + (["theta_offset_rad"] if fit_offset else []))
    per = evaluate_friction(logs, model, off, time_step_s)
    return FrictionFit(law, joint, dict(model.params), off, per, free, ci, len(starts_x), float(best.cost))


def _ci95(res, names: list[str]) -> dict[str, tuple[float, float]]:
    """Approximate 95% intervals from the Gauss–Newton covariance s² (JᵀJ)⁻¹ (NaN if singular)."""
    J = res.jac
    dof = max(J.shape[0] - J.shape[1], 1)
    s2 = 2.0 * res.cost / dof
    try:
        cov = np.linalg.inv(J.T @ J) * s2
        std = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        std = np.full(len(names), np.nan)
    return {k: (float(v - 1.96 * s), float(v + 1.96 * s)) for k, v, s in zip(names, res.x, std)}


def leave_one_out(logs: Sequence[RobotLog], **fit_kwargs) -> list[dict[str, Any]]:
    """Fit on all trials but one and test on the one left out; one row per held-out trial."""
    rows = []
    for i, held in enumerate(logs):
        train = [log for j, log in enumerate(logs) if j != i]
        fit = fit_friction(train, **fit_kwargs)
        test = evaluate_friction([held], fit.model, fit.theta_offset_rad)[held.name]
        rows.append(
            {
                "held_out": held.name,
                "train_rmse_rad": fit.rmse_per_trial,
                "test_rmse_rad": test,
                "params": fit.params,
                "theta_offset_rad": fit.theta_offset_rad,
            }
        )
    return rows


def write_preset(path: str | Path, name: str, model: FrictionModel, comment: str = "") -> Path:
    """Set preset ``name`` in a presets YAML (the ``assets/friction/presets.yaml`` format).

    The file's other lines and comments are kept; an existing entry of that name (and the comment
    lines right above it that start with ``# [name]``) is replaced, else it is appended. The new
    text is checked by loading it before the file is replaced (nothing half-written).
    """
    from sphere_env.models.friction import load_friction_presets

    path = Path(path)
    params = ", ".join(f"{k}: {float(f'{v:.4g}')}" for k, v in model.params.items())
    entry = f"  {name}:{' ' * max(1, 16 - len(name))}{{law: {model.law}, params: {{{params}}}}}"
    notes = [f"  # [{name}] {line}" for line in comment.splitlines() if line.strip()]
    lines = path.read_text().splitlines() if path.exists() else ["presets:"]
    pat = re.compile(rf"^\s+{re.escape(name)}\s*:")
    out, replaced = [], False
    for line in lines:
        if line.strip().startswith(f"# [{name}]"):
            continue
        if pat.match(line):
            out.extend(notes + [entry])
            replaced = True
        else:
            out.append(line)
    if not replaced:
        out.extend(notes + [entry])
    write_text_atomic(path, "\n".join(out) + "\n", check=load_friction_presets)
    return path


def plot_stand_overlay(
    path: str | Path,
    logs: Sequence[RobotLog],
    models: Mapping[str, tuple[FrictionModel, float]],
    time_step_s: float = 0.005,
) -> Path:
    """Paper Fig. 7: measured θ(t) of every stand trial overlaid with each named model's simulation."""
    from sphere_env.plotting import pyplot

    plt = pyplot()

    n = len(logs)
    fig, axes = plt.subplots(n, 1, figsize=(8, 2.3 * n), sharex=True, squeeze=False)
    sims = {label: simulate_stand(logs, m, off, time_step_s) for label, (m, off) in models.items()}
    for ax, i in zip(axes[:, 0], range(n)):
        log = logs[i]
        ax.plot(log.t_s, log["theta"], "k.", ms=3, label="measured")
        for label, traces in sims.items():
            tr = traces[i]
            ax.plot(tr.t_s, tr["theta"], "-", lw=1.2, label=f"{label} (RMSE {rmse(tr['theta'], log['theta']):.4f} rad)")
        ax.set_ylabel("θ [rad]")
        ax.set_title(log.name, fontsize=9)
        ax.legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("time [s]")
    fig.tight_layout()
    return save_figure(fig, path, dpi=110)
