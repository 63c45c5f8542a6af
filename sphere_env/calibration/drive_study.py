"""What ``calibrate drive-fit`` does: the driven segment replayed under every shell model and shipped
calibration, then the drive direction fitted on one part and tested on the other, both ways.

The results (one JSON, ``evaluation/results/validation/drive_fit.json``) hold:

* ``replay``: per calibration (without its own drive fit: :class:`~sphere_env.calibration.drive_fit.DriveTwin`),
  model and driven window, the RMSE of ω_d, ψ̇ [rad/s], φ and the tracked
  θ, α [rad] (the conventions of ``validate``) and the motor torques against the limits;
* ``fits``: per model and direction, the fitted parameters with their intervals and unidentified ones,
  the RMSE on the part the fit never saw, the same before the fit and for point contact (its drive
  friction fitted the same way), their ratios, whether the aims are met, and measured diagnostics
  (:func:`~sphere_env.calibration.drive_fit.diagnose`).
"""

from __future__ import annotations

import time
from typing import Any, Callable, Mapping, Sequence

from sphere_env.analysis.metrics import rmse
from sphere_env.calibration.drive_fit import DriveTwin, diagnose, fit_drive
from sphere_env.calibration.driven import driven_rmse
from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.simulate import simulate_log
from sphere_env.models.shell import ShellCalibration

#: The aims on the part not fitted, for the soft shells [rad/s].
AIMS_RAD_S = {"omega_d": 0.15, "heading_rate": 0.10}
MODELS = ("point", "injected", "hydroelastic")
SOFT_MODELS = ("injected", "hydroelastic")


def drive_study(
    parts: Mapping[str, RobotLog],
    whole: RobotLog | None = None,
    calibrations: Sequence[str] = ("default", "free_robot"),
    bases: Sequence[str] = ("free_robot",),
    max_nfev: int = 20,
    log_to: Callable[[str], Any] | None = None,
    steer_windows: Sequence[RobotLog] = (),
) -> dict[str, Any]:
    """``parts``: the two driven windows by name (forward first); ``whole``: optionally the segment in
    one replay. Replays every model under every calibration in ``calibrations``, then fits each model's
    drive direction from each of ``bases`` on each part and tests it on the other (module docstring).
    ``steer_windows``: free-motion windows (the free robot's release and pushes) replayed with each soft
    fit and without it, so that what the drive fit does to the steer direction is measured."""
    say = log_to or (lambda *_: None)
    t0 = time.time()
    names = list(parts)
    if len(names) != 2:
        raise ValueError(f"drive_study: parts must name two driven windows, got {names}")
    windows = [*parts.values(), *([whole] if whole is not None else [])]
    replay = []
    for cal_name in calibrations:
        cal = ShellCalibration.load(cal_name)
        for model in MODELS:
            dt = DriveTwin(model, cal)
            for log in windows:
                tr = dt.replay(log)
                row = {
                    "calibration": cal_name,
                    "model": model,
                    "window": log.name,
                    "window_s": list(log.window_s or ()),
                    "rmse": driven_rmse(tr, log),
                    "torques": tr.torque_summary(),
                    **tr.extra,
                }
                replay.append(row)
                say(f"replay {cal_name:10s} {model:12s} {log.name:14s} " + _fmt(row["rmse"]))
    fits = []
    for base in bases:
        base_cal = ShellCalibration.load(base)
        for fit_on, test in ((names[0], names[1]), (names[1], names[0])):
            point = None
            for model in MODELS:
                row = _fit_and_test(parts, fit_on, test, model, base_cal, max_nfev, steer_windows)
                row["base_calibration"] = base
                if model == "point":
                    point = row["held_out_rmse"]
                else:
                    held, before = row["held_out_rmse"], row["before_fit_rmse"]
                    row["ratio_to_point"] = {ch: held[ch] / point[ch] for ch in AIMS_RAD_S}
                    row["ratio_to_before_fit"] = {ch: held[ch] / before[ch] for ch in AIMS_RAD_S}
                    row["aims_met"] = {ch: held[ch] <= lim for ch, lim in AIMS_RAD_S.items()}
                fits.append(row)
                say(
                    f"fit {model:12s} from {base} on {fit_on} -> {test}: {row['fit']['params']}; held out "
                    + _fmt(row["held_out_rmse"])
                )
    return {
        "aims_rad_s": dict(AIMS_RAD_S),
        "base_calibrations": list(bases),
        "windows": {log.name: list(log.window_s or ()) for log in windows},
        "max_nfev": max_nfev,
        "replay": replay,
        "fits": fits,
        "runtime_s": time.time() - t0,
    }


def _fit_and_test(
    parts: Mapping[str, RobotLog],
    fit_on: str,
    test: str,
    model: str,
    base: ShellCalibration,
    max_nfev: int,
    steer_windows: Sequence[RobotLog],
) -> dict[str, Any]:
    """One model's drive fit on ``fit_on``, tested on ``test``, before and after, with its diagnosis and,
    for a soft shell, the steer windows' φ and θ RMSE [rad] without and with the fit."""
    dt = DriveTwin(model, base)
    fit = fit_drive([parts[fit_on]], model, base, dt, max_nfev=max_nfev)
    tr = dt.replay(parts[test], fit.params)
    row = {
        "model": model,
        "fit_on": fit_on,
        "test": test,
        "fit": fit.as_dict(),
        "held_out_rmse": driven_rmse(tr, parts[test]),
        "before_fit_rmse": driven_rmse(dt.replay(parts[test]), parts[test]),
        "torques": tr.torque_summary(),
        "diagnosis": diagnose(tr, parts[test]),
    }
    if model != "point" and steer_windows:
        row["steer_windows_rmse"] = {
            w.name: {
                when: {ch: rmse(sim[ch], w[ch]) for ch in ("phi", "theta")}
                for when, sim in (("before", _steer_replay(dt, w, {})), ("after", _steer_replay(dt, w, fit.params)))
            }
            for w in steer_windows
        }
    return row


def _steer_replay(dt: DriveTwin, log: RobotLog, values: Mapping[str, float]):
    """A free-motion window replayed (no torque) on the drive twin with the drive ``values`` set."""
    dt.install(values)
    return simulate_log(dt.twin, log, pressure_kpa=dt.pressure_kpa)


def _fmt(rmse: Mapping[str, float]) -> str:
    return "ω_d {omega_d:.3f} ψ̇ {heading_rate:.3f} rad/s, φ {phi:.3f} θ {theta:.3f} α {pendulum_pitch:.3f} rad".format(
        **rmse
    )
