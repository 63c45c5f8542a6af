"""The inflation pressure of a log, estimated from its free motion with a fixed calibration.

The seed paper's claim is that the inflation pressure explains how the shell behaves. If so, one
calibration with one pressure per log reproduces every log: a log whose pressure was not recorded
gets the pressure at which the calibration fits it best, and what is left is the calibration's
error on that log. Windows cut from one file share one pressure (the robot was not re-inflated
within a recording).

The estimate is a profile over the calibration's pressure range: the pooled cost of every window
(the mean square φ and θ error over all samples, as :func:`sphere_env.calibration.shell_fit.fit_shell`
uses) on a grid of pressures, then a bounded scalar search (scipy) around the best grid point. The
grid is reported too: a flat profile means the log cannot tell pressures apart, and the estimate is
marked unidentified. An optimum on a bound of the range says the log wants a pressure the
calibration does not cover.

:func:`pressure_study` (``python -m sphere_env.calibration pressure-study``) asks the question of
the shared logs: each shipped calibration with only the pressure estimated per recording, and the
steer_free trials fitted on one and validated on the other with one number of the other estimated:
its pressure, or instead its rest angle φ_0; and :func:`setup_transfer`, each calibration's law
shape on the other setup's recordings with its stiffness, damping and rest angle refitted.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from sphere_env.analysis.metrics import rmse
from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.shell_fit import FitError, TwinPool
from sphere_env.calibration.simulate import simulate_log
from sphere_env.models.shell import ShellCalibration
from sphere_env.resources import asset_path

#: Pressures on the profile grid, spread evenly over the calibration's range.
GRID_POINTS = 9
#: The profile's flatness test: an estimate is unidentified when the worst grid pressure's RMSE is
#: within this factor of the best (the log cannot tell the range's ends apart).
FLAT_RATIO = 1.1
#: The pressures whose pooled RMSE is within this factor of the best form the reported range.
NEAR_BEST_RATIO = 1.1


@dataclass
class PressureFit:
    """The pressure [kPa] at which ``calibration`` best reproduces ``logs`` (one shell model)."""

    model: str
    logs: list[str]
    pressure_kpa: float
    rmse_rad: dict[str, dict[str, float]]  # window -> {"phi", "theta"} at the estimate
    pooled_rmse_rad: float  # sqrt of the pooled mean square φ and θ error
    profile: list[tuple[float, float]]  # (pressure kPa, pooled RMSE rad) on the grid
    near_best_kpa: tuple[float, float]  # the estimate and the grid pressures within NEAR_BEST_RATIO of its RMSE
    at_bound: bool
    unidentified: bool
    notes: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "logs": self.logs,
            "pressure_kpa": self.pressure_kpa,
            "rmse_rad": self.rmse_rad,
            "pooled_rmse_rad": self.pooled_rmse_rad,
            "profile": [list(x) for x in self.profile],
            "near_best_kpa": list(self.near_best_kpa),
            "at_bound": self.at_bound,
            "unidentified": self.unidentified,
            "notes": self.notes,
        }


def fit_pressure(
    logs: Sequence[RobotLog],
    model: str,
    calibration: ShellCalibration,
    steer_friction: Any = "majd_steer",
    drive_friction: Any = "majd_drive",
    time_step_s: float = 0.005,
    grid_points: int = GRID_POINTS,
    xatol_kpa: float = 0.05,
) -> PressureFit:
    """One pressure for all ``logs`` (windows of one recording) with ``calibration`` fixed.

    Refuses (:class:`FitError`) logs without φ and θ, a fixture other than ``steer_plane`` or
    ``free``, and a model other than ``injected`` or ``hydroelastic`` (point contact has no
    pressure). A simulation that diverges at a pressure costs that pressure a 1 rad error.
    """
    if model not in ("injected", "hydroelastic"):
        raise FitError(f"model: {model!r} has no pressure to estimate; allowed: 'injected', 'hydroelastic'")
    if not logs:
        raise FitError("fit_pressure: no windows to fit on")
    for log in logs:
        if log.fixture not in ("steer_plane", "free"):
            raise FitError(
                f"log {log.path!r}: trial {log.name!r} has fixture {log.fixture!r}; "
                "a pressure estimate needs 'steer_plane' or 'free' windows"
            )
        for ch in ("phi", "theta"):
            if not log.has(ch):
                raise FitError(f"log {log.path!r}: trial {log.name!r} needs a {ch} channel for a pressure estimate")
    lo, hi = calibration.pressure_range_kpa
    pool = TwinPool(model, steer_friction, time_step_s, drive_friction)
    n = sum(2 * len(log.t_s) for log in logs)

    def errors(p: float) -> tuple[float, dict[str, dict[str, float]]]:
        pool.install(calibration, float(p))
        sq, per = 0.0, {}
        for log in logs:
            tr = simulate_log(pool.get(log.fixture), log)
            if tr.diverged:
                return 1.0, {}
            d_phi, d_theta = tr["phi"] - log["phi"], tr["theta"] - log["theta"]
            sq += float(np.sum(d_phi**2) + np.sum(d_theta**2))
            per[log.name] = {"phi": rmse(tr["phi"], log["phi"]), "theta": rmse(tr["theta"], log["theta"])}
        return math.sqrt(sq / n), per

    grid = np.linspace(lo, hi, grid_points)
    profile = [(float(p), errors(p)[0]) for p in grid]
    i = int(np.argmin([c for _, c in profile]))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    res = minimize_scalar(lambda p: errors(p)[0], bounds=(a, b), method="bounded", options={"xatol": xatol_kpa})
    p_best, c_best = (float(res.x), float(res.fun)) if res.fun <= profile[i][1] else profile[i]
    c_best, per = errors(p_best)
    near = [p_best] + [p for p, c in profile if c <= NEAR_BEST_RATIO * c_best]
    costs = [c for _, c in profile]
    at_bound = min(p_best - lo, hi - p_best) <= 2 * xatol_kpa
    flat = max(costs) <= FLAT_RATIO * min(costs)
    notes = []
    if flat:
        notes.append(
            f"the pooled RMSE varies by less than {FLAT_RATIO - 1:.0%} over {lo:g}-{hi:g} kPa: "
            "the log does not pin the pressure down"
        )
    if at_bound:
        notes.append(f"the estimate sits on the calibrated range's bound ({lo:g}-{hi:g} kPa)")
    return PressureFit(
        model=model,
        logs=[log.name for log in logs],
        pressure_kpa=p_best,
        rmse_rad=per,
        pooled_rmse_rad=c_best,
        profile=profile,
        near_best_kpa=(min(near), max(near)),
        at_bound=at_bound,
        unidentified=flat,
        notes=notes,
    )


def by_recording(logs: Sequence[RobotLog]) -> list[list[RobotLog]]:
    """``logs`` grouped by the file they were cut from (one pressure each), in first-seen order."""
    groups: dict[str, list[RobotLog]] = {}
    for log in logs:
        groups.setdefault(str(log.path), []).append(log)
    return list(groups.values())


#: The study's calibrations (shipped files), manifest groups and shell models.
CALIBRATIONS = ("default", "free_robot")
GROUPS = ("steer_free", "free_robot")
MODELS = ("injected", "hydroelastic")
#: The aims of the fidelity issue, per group: (φ, θ) RMSE limits [rad]; None = no limit on θ.
AIMS_RAD = {"steer_free": (0.05, None), "free_robot": (0.06, 0.08)}


def pressure_study(man: Any, log_to: Any = print) -> dict[str, Any]:
    """Each of :data:`CALIBRATIONS` with one pressure estimated per recording of each of :data:`GROUPS`
    of the manifest ``man``, for both soft models, and :func:`steer_free_cross`: the record that
    ``pressure-study`` writes."""
    rows = []
    for cal_name in CALIBRATIONS:
        cal = ShellCalibration.load(asset_path("calibration", f"{cal_name}.yaml"))
        for group in GROUPS:
            logs = [s.load(required=("phi", "theta")) for s in man.group(group)]
            for model in MODELS:
                for rec in by_recording(logs):
                    t0 = time.perf_counter()
                    fit = fit_pressure(rec, model, cal)
                    phi_aim, theta_aim = AIMS_RAD[group]
                    within = all(
                        r["phi"] <= phi_aim and (theta_aim is None or r["theta"] <= theta_aim)
                        for r in fit.rmse_rad.values()
                    )
                    rows.append({"calibration": cal_name, "group": group, **fit.as_dict(), "within_aims": within})
                    log_to(
                        f"{cal_name} {model} {'+'.join(fit.logs)}: {fit.pressure_kpa:.2f} kPa, "
                        + ", ".join(f"{k} {v['phi']:.3f}/{v['theta']:.3f}" for k, v in fit.rmse_rad.items())
                        + f" ({'within' if within else 'outside'} the aims; {time.perf_counter() - t0:.0f} s)",
                    )
    return {
        "aims_rad": {g: list(a) for g, a in AIMS_RAD.items()},
        "rows": rows,
        "steer_free_cross": steer_free_cross(man, log_to),
        "setup_transfer": setup_transfer(man, log_to),
    }


#: The parameters :func:`setup_transfer` refits per recording, per shell model: the stiffness and
#: damping (for the hydroelastic model the steer couple's factors) and the rest angle φ_0.
TRANSFER_PARAMS = {
    "injected": ("omega_n", "zeta", "rest_angle_rad"),
    "hydroelastic": ("couple_stiffness_factor", "couple_damping_factor", "rest_angle_rad"),
}


def setup_transfer(man: Any, log_to: Any = print) -> list[dict[str, Any]]:
    """Each shipped calibration's law shape on the other setup's recordings, with the stiffness,
    damping and rest angle refitted per recording (:data:`TRANSFER_PARAMS`) and the amplitude terms
    held: more freedom than a pressure per log gives, since a pressure moves only ω_n and ζ, along
    the calibration's curves. Where even this misses the aims, no pressure can close the gap and the
    law's shape is what differs; where it meets them, the stiffness and damping it wants show how
    far the pressure would have to move them."""
    from sphere_env.calibration.shell_fit import fit_shell

    out = []
    for cal_name, group in (("free_robot", "steer_free"), ("default", "free_robot")):
        cal = ShellCalibration.load(asset_path("calibration", f"{cal_name}.yaml"))
        p0 = cal.nominal_pressure_kpa
        logs = [s.load(required=("phi", "theta")) for s in man.group(group)]
        phi_aim, theta_aim = AIMS_RAD[group]
        for model in MODELS:
            names = TRANSFER_PARAMS[model]
            for rec in by_recording(logs):
                t0 = time.perf_counter()
                fit = fit_shell(rec, model, p0, base=cal, params=names, max_nfev=40, require_convergence=False)
                rmse_rad = {k: {c: float(v[c]) for c in ("phi", "theta")} for k, v in fit.rmse.items()}
                within = all(
                    r["phi"] <= phi_aim and (theta_aim is None or r["theta"] <= theta_aim) for r in rmse_rad.values()
                )
                law = cal.steer_law
                shipped = {
                    "omega_n": float(cal.omega_n(p0)),
                    "zeta": float(cal.zeta(p0)),
                    "rest_angle_rad": float(law.rest_angle_rad),
                    "couple_stiffness_factor": float(cal.couple_stiffness_factor),
                    "couple_damping_factor": float(cal.couple_damping_factor),
                }
                out.append(
                    {
                        "calibration": cal_name,
                        "form": law.form,
                        "model": model,
                        "group": group,
                        "logs": [log.name for log in rec],
                        "fitted": {k: float(fit.params[k]) for k in names},
                        "shipped_at_nominal": {k: shipped[k] for k in names},
                        "rmse_rad": rmse_rad,
                        "within_aims": within,
                    }
                )
                log_to(
                    f"transfer {cal_name} ({law.form}) {model} {'+'.join(log.name for log in rec)}: "
                    + ", ".join(f"{k} {fit.params[k]:.3f} (shipped {shipped[k]:.3f})" for k in names)
                    + "; "
                    + ", ".join(f"{k} {v['phi']:.3f}/{v['theta']:.3f}" for k, v in rmse_rad.items())
                    + f" ({'within' if within else 'outside'} the aims; {time.perf_counter() - t0:.0f} s)"
                )
    return out


def steer_free_cross(man: Any, log_to: Any = print) -> list[dict[str, Any]]:
    """The steer_free trials both ways with one number per trial: the law fitted on one trial at the
    assumed pressure (as the validation report's cross-validation does), then, with that law held
    fixed, the other trial's pressure estimated (``pressure_kpa``, ``rmse_rad``) and, instead, its
    rest angle φ_0 (``rest_angle``: the shell's equilibrium roll angle, which a soft shell set down
    on another spot of its surface may change), and the other trial's error with each."""
    from sphere_env.calibration.crossval import fit_calibration
    from sphere_env.calibration.shell_fit import fit_shell

    base = ShellCalibration.load(asset_path("calibration", "default.yaml"))
    p0 = base.nominal_pressure_kpa
    logs = [s.load(required=("phi", "theta")) for s in man.group("steer_free")]
    out = []
    for model in MODELS:
        for train in logs:
            t0 = time.perf_counter()
            _, raw = fit_calibration([train], model, p0, base, "majd_steer")
            cal = ShellCalibration.from_dict(raw, source=f"<fitted on {train.name}>")
            for test in (log for log in logs if log is not train):
                fit = fit_pressure([test], model, cal)
                rest = fit_shell(
                    [test], model, p0, base=cal, params=["rest_angle_rad"], max_nfev=30, require_convergence=False
                )
                rest_rmse = {k: float(v) for k, v in rest.rmse[test.name].items()}
                out.append(
                    {
                        "fit_on": train.name,
                        "fit_at_kpa": p0,
                        **fit.as_dict(),
                        "rest_angle": {
                            "fitted_on_rad": float(cal.steer_law.rest_angle_rad),
                            "estimated_rad": float(rest.params["rest_angle_rad"]),
                            "rmse_rad": rest_rmse,
                        },
                    }
                )
                r = fit.rmse_rad[test.name]
                log_to(
                    f"cross {model} {train.name} -> {test.name}: {fit.pressure_kpa:.2f} kPa, "
                    f"{r['phi']:.3f}/{r['theta']:.3f}; rest angle {rest.params['rest_angle_rad']:.3f} rad, "
                    f"{rest_rmse['phi']:.3f}/{rest_rmse['theta']:.3f} ({time.perf_counter() - t0:.0f} s)",
                )
    return out
