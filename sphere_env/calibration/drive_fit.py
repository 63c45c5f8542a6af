"""Drive-direction fit: the parameters of rolling and turning fitted on one part of a driven segment.

A driven replay (:mod:`sphere_env.calibration.driven`) makes the twin's pendulum move as the real one
did; what is left to the shell and the drive joint is fitted here, on the drive velocity ω_d and the
heading rate ψ̇ (residuals in rad/s, every sample of the fitted windows weighted the same):

* ``drive_friction_scale``: × the drive joint's friction law (Table I's Majd law);
* ``injected_rolling_damping_factor`` (injected shell): C_drive = factor × C_inject(p), the damper on ω_d
  that the paper puts in the drive direction (§IV: factor 1);
* ``dissipation_s_per_m`` (hydroelastic shell): Drake's Hunt–Crossley dissipation of the contact, which
  resists rolling (and, through the same contact, damps the steer direction too);
* ``spin_damping_nms_per_rad`` (both soft shells): the couple −C_spin (ω_shell·n̂) n̂ against spinning
  about the ground normal. A rigid point contact has no torque about the normal, so a tilted driveshaft's
  drive torque spins the twin's shell freely; a real contact patch resists it (drilling friction).

``point`` has only ``drive_friction_scale``. The fit is scipy's ``least_squares`` with coarse
tolerances; intervals come from the Jacobian and parameters the data do not pin down are marked as the
steer fit marks them (:func:`~sphere_env.calibration.shell_fit.jacobian_ci95`,
:func:`~sphere_env.calibration.shell_fit.unidentified`). The fitted values are written as a
calibration's opt-in ``drive_law`` section (the drive friction scale under ``drive_fit``).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares

from sphere_env.calibration.driven import DrivenTrace, Tracking, driven_replay, driven_rmse
from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.shell_fit import FitError, calibration_at, fixture_twin, jacobian_ci95, unidentified
from sphere_env.models.shell import ShellCalibration
from sphere_env.physics import Twin

#: Search range of each drive-direction parameter.
DRIVE_BOUNDS = {
    "drive_friction_scale": (0.0, 10.0),  # the registry's range
    "injected_rolling_damping_factor": (0.0, 10.0),
    "dissipation_s_per_m": (0.0, 20.0),
    "spin_damping_nms_per_rad": (0.0, 100.0),  # the calibration schema's range
}
DRIVE_PARAMS = {
    "point": ("drive_friction_scale",),
    "injected": ("drive_friction_scale", "injected_rolling_damping_factor", "spin_damping_nms_per_rad"),
    "hydroelastic": ("drive_friction_scale", "dissipation_s_per_m", "spin_damping_nms_per_rad"),
}
#: The channels fitted [rad/s].
FIT_CHANNELS = ("omega_d", "heading_rate")
#: Where the search starts for a parameter the base calibration leaves at zero (a bound is no start).
SPIN_START_NMS_PER_RAD = 5.0


def drive_values(base: ShellCalibration, model: str, pressure_kpa: float) -> dict[str, float]:
    """The drive-direction parameters of ``base`` for ``model`` (drive friction scale 1)."""
    out = {
        "drive_friction_scale": 1.0,
        "injected_rolling_damping_factor": base.injected_rolling_damping_factor,
        "spin_damping_nms_per_rad": base.spin_damping_nms_per_rad,
    }
    if model == "hydroelastic":
        from sphere_env.models.rigid_body import RobotParameters

        out["dissipation_s_per_m"] = base.bind(RobotParameters.from_urdf()).hydroelastic(pressure_kpa)[1]
    return {k: v for k, v in out.items() if k in DRIVE_PARAMS[model]}


def calibration_with_drive(base: ShellCalibration, pressure_kpa: float, values: Mapping[str, float]) -> dict[str, Any]:
    """``base`` as a mapping with the drive-direction ``values`` set: ``drive_law`` and, for
    ``dissipation_s_per_m``, the hydroelastic k_d at ``pressure_kpa``
    (:func:`~sphere_env.calibration.shell_fit.calibration_at`)."""
    raw = (
        calibration_at(base, pressure_kpa, dissipation_s_per_m=values["dissipation_s_per_m"])
        if "dissipation_s_per_m" in values
        else copy.deepcopy(dict(base.raw))
    )
    law = dict(raw.get("drive_law") or {})
    for k in ("injected_rolling_damping_factor", "spin_damping_nms_per_rad"):
        if k in values:
            law[k] = float(values[k])
    if law:
        raw["drive_law"] = law
    return raw


class DriveTwin:
    """One ``free`` twin of a shell model whose drive-direction parameters are set before each replay.

    The base calibration's own ``drive_law`` (a shipped calibration carries its drive fit) is dropped:
    a replay without values has the paper's drive direction, the calibration before any drive fit, and
    the values of a replay are the whole drive direction, never a factor on an earlier fit's."""

    def __init__(self, model: str, base: ShellCalibration, pressure_kpa: float | None = None, tracking=Tracking()):
        self.model, self.base, self.tracking = model, base.without_drive_law(), tracking
        self.pressure_kpa = base.nominal_pressure_kpa if pressure_kpa is None else pressure_kpa
        self.twin: Twin = fixture_twin("free", model)
        self.twin.set_calibration(self.base, self.pressure_kpa)

    def install(self, values: Mapping[str, float] | None = None) -> None:
        """Set the drive-direction ``values`` (:data:`DRIVE_PARAMS`; the base calibration's for the others)."""
        values = dict(values or {})
        cal = self.base
        if any(k != "drive_friction_scale" for k in values):
            raw = calibration_with_drive(self.base, self.pressure_kpa, values)
            cal = ShellCalibration.from_dict(raw, source="<drive fit>", check_stand_still=False)
        self.twin.set_calibration(cal, self.pressure_kpa)
        self.twin.apply({"drive_friction_scale": values.get("drive_friction_scale", 1.0)})

    def replay(self, log: RobotLog, values: Mapping[str, float] | None = None) -> DrivenTrace:
        """The driven replay of ``log`` with the drive-direction ``values``."""
        self.install(values)
        return driven_replay(self.twin, log, self.tracking, pressure_kpa=self.pressure_kpa)


@dataclass
class DriveFit:
    """Fitted drive-direction parameters, their 95 % intervals, the unidentified ones (name -> reason)
    and the fit's RMSE on the fitted windows [rad/s, rad]."""

    model: str
    fit_on: list[str]
    params: dict[str, float]
    start: dict[str, float]
    ci95: dict[str, tuple[float, float]] = field(default_factory=dict)
    unidentified: dict[str, str] = field(default_factory=dict)
    rmse: dict[str, dict[str, float]] = field(default_factory=dict)
    nfev: int = 0

    def as_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "fit_on": list(self.fit_on),
            "params": dict(self.params),
            "start": dict(self.start),
            "ci95": {k: list(v) for k, v in self.ci95.items()},
            "unidentified": dict(self.unidentified),
            "rmse_fit": self.rmse,
            "nfev": self.nfev,
        }


def fit_drive(
    logs: Sequence[RobotLog],
    model: str,
    base: ShellCalibration,
    drive_twin: DriveTwin | None = None,
    max_nfev: int = 30,
) -> DriveFit:
    """Fit :data:`DRIVE_PARAMS` of ``model`` to the driven windows ``logs`` (module docstring).

    Refuses (:class:`~sphere_env.calibration.shell_fit.FitError`) an unknown model, no windows, and an
    optimum whose replay diverged. The tolerances are coarse (``xtol``, ``ftol`` 1e-3): a replay of a
    window costs about a second of computing per simulated 10 s."""
    if model not in DRIVE_PARAMS:
        raise FitError(f"fit_drive: model {model!r} unknown; allowed: {list(DRIVE_PARAMS)}")
    if not logs:
        raise FitError("fit_drive: no driven windows to fit on")
    dt = drive_twin or DriveTwin(model, base)
    names = list(DRIVE_PARAMS[model])
    start = drive_values(dt.base, model, dt.pressure_kpa)  # from the paper's drive direction
    if start.get("spin_damping_nms_per_rad") == 0.0:
        start["spin_damping_nms_per_rad"] = SPIN_START_NMS_PER_RAD
    lo = np.array([DRIVE_BOUNDS[n][0] for n in names])
    hi = np.array([DRIVE_BOUNDS[n][1] for n in names])
    x0 = np.clip([start[n] for n in names], lo, hi)
    n_res = sum(len(FIT_CHANNELS) * len(log.t_s) for log in logs)
    w = 1.0 / math.sqrt(n_res)

    def residuals(x) -> np.ndarray:
        values = dict(zip(names, map(float, x)))
        parts = []
        for log in logs:
            tr = dt.replay(log, values)
            parts += [w * (tr[ch] - log[ch]) for ch in FIT_CHANNELS]
        return np.concatenate(parts)

    res = least_squares(
        residuals, x0, bounds=(lo, hi), diff_step=1e-2, x_scale="jac", max_nfev=max_nfev, xtol=1e-3, ftol=1e-3
    )
    values = {k: float(v) for k, v in zip(names, res.x)}
    ci = jacobian_ci95(res, names)
    poor = unidentified(values, ci, {k: DRIVE_BOUNDS[k] for k in names})
    per = {}
    for log in logs:
        tr = dt.replay(log, values)
        if tr.diverged:
            raise FitError(f"drive fit of {model!r} on {log.name!r}: the twin diverged at the optimum")
        per[log.name] = driven_rmse(tr, log)
    return DriveFit(model, [log.name for log in logs], values, dict(start), ci, poor, per, int(res.nfev))


def diagnose(trace: DrivenTrace, log: RobotLog, max_lag_s: float = 1.0) -> dict[str, float]:
    """Measured reasons a response misses: how well the pendulum was tracked (θ, α RMSE [rad]), the
    time shift of the twin's ω_d and ψ̇ that best matches the log (lag [s], + when the twin is late) and
    the RMSE left after it, the gain that scales the twin's ω_d onto the log's (least squares: a rolling
    radius or slip would scale it), and the turning ratio ψ̇ / (−ω_d sin φ) of the log and of the twin
    over the samples that roll (|ω_d| > 0.2 rad/s): 1 when the shell rolls without spinning about the
    ground normal, the kinematics of a tilted shaft; the twin's mean φ error while rolling, and the ψ̇
    RMSE left when the twin's ψ̇ is rescaled to the log's lean (× sin φ_log / sin φ_twin)."""
    out = {f"rmse_tracking_{ch}_rad": _rmse(trace[ch], log[ch]) for ch in ("theta", "pendulum_pitch")}
    dt = float(np.median(np.diff(log.t_s)))
    n, k_max = len(log.t_s), int(max_lag_s / dt)
    for ch in FIT_CHANNELS:
        # shift k > 0: the twin's sample i + k is compared with the log's sample i (the twin is late)
        errs = [
            _rmse(trace[ch][max(k, 0) : n + min(k, 0)], log[ch][max(-k, 0) : n - max(k, 0)])
            for k in range(-k_max, k_max + 1)
        ]
        best = int(np.argmin(errs))
        out[f"{ch}_lag_s"] = float((best - k_max) * dt)
        out[f"{ch}_rmse_after_lag"] = float(errs[best])
    sim, real = trace["omega_d"], log["omega_d"]
    out["omega_d_gain"] = float(np.dot(sim, real) / max(float(np.dot(sim, sim)), 1e-12))
    # the lean: the twin's mean φ error while rolling, and ψ̇ as the twin would turn at the log's lean
    # (ψ̇ ∝ sin φ at a given ω_d on a tilted shaft): what of the ψ̇ error the lean accounts for
    rolling = np.abs(log["omega_d"]) > 0.2
    out["phi_mean_error_rolling_rad"] = float(np.mean(trace["phi"][rolling] - log["phi"][rolling]))
    s_twin = np.sin(trace["phi"])
    ok = np.abs(s_twin) > 0.05
    at_log_lean = np.where(
        ok, trace["heading_rate"] * np.sin(log["phi"]) / np.where(ok, s_twin, 1.0), trace["heading_rate"]
    )
    out["heading_rate_rmse_at_log_lean"] = _rmse(at_log_lean, log["heading_rate"])
    for who, src in (("log", log), ("twin", trace)):
        rolling = np.abs(src["omega_d"]) > 0.2
        expected = -src["omega_d"][rolling] * np.sin(src["phi"][rolling])
        out[f"turning_ratio_{who}"] = float(
            np.dot(expected, src["heading_rate"][rolling]) / max(float(np.dot(expected, expected)), 1e-12)
        )
    return out


def _rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))
