"""Per-episode metrics of a controller rollout, and the Point Mean Error (paper eq. 12).

Pure numpy. An episode is summarized from its trace (one sample per control step, SI units):

==========================  =======  ==============================================================
``tracking_rmse_rad_s``     rad/s    RMS of ω_d − ω_ref over the on-ramp samples (the evaluation
                                     replaces it by the task's own judged RMS when the env reports
                                     ``info["tracking_rmse_rad_s"]``: RampDescent-v2 leaves out the
                                     settling time after the start and the command change)
``mean_omega_d_rad_s``      rad/s    mean ω_d over the on-ramp samples
``lateral_drift_m``         m        max |y| off the fall line through the start
``energy_j``                J        motor work drawn, ∫ (|τ_s θ̇| + |τ_d q̇_d|) dt (no regeneration)
``peak_torque_nm``          N m      max |τ| over both motors
``time_on_ramp_s``          s        time until the run-out was reached (episode time if never)
==========================  =======  ==============================================================

The PME itself is :func:`sphere_env.analysis.metrics.pme_percent` (one implementation in the
package); :func:`pme_between` applies it to two time series on (possibly) different time grids.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

#: Columns naming an episode's cell, then its metrics, in a row of the episodes CSV (``condition``:
#: ``nominal``, or the fault or calibration the cell ran under, :mod:`sphere_env.evaluation.conditions`).
KEY_COLUMNS = ("controller", "env_id", "shell_model", "friction", "pressure_kpa", "seed", "condition")
METRIC_COLUMNS = (
    "return",
    "length",
    "is_success",
    "reached_runout",
    "terminated",
    "truncated",
    "tracking_rmse_rad_s",
    "mean_omega_d_rad_s",
    "lateral_drift_m",
    "energy_j",
    "peak_torque_nm",
    "time_on_ramp_s",
    "omega_ref_rad_s",
    "omega_ref_after_rad_s",
)
#: Trace channels recorded per control step by :mod:`sphere_env.evaluation.cells`.
TRACE_CHANNELS = (
    "t_s",
    "omega_d",
    "omega_ref",
    "x_m",
    "y_m",
    "z_m",
    "tau_steer_nm",
    "tau_drive_nm",
    "theta_dot",
    "drive_rate",
    "on_ramp",
    "reward",
)


def episode_metrics(trace: Mapping[str, np.ndarray], dt_s: float) -> dict[str, float]:
    """Metrics of one episode from its trace (see the module table)."""
    on = np.asarray(trace["on_ramp"], bool)
    wd = np.asarray(trace["omega_d"], float)
    ref = np.asarray(trace["omega_ref"], float)
    sel = on if on.any() else np.ones_like(on)
    err = wd[sel] - ref[sel]
    power = np.abs(np.asarray(trace["tau_steer_nm"]) * np.asarray(trace["theta_dot"])) + np.abs(
        np.asarray(trace["tau_drive_nm"]) * np.asarray(trace["drive_rate"])
    )
    tau = np.concatenate([np.abs(trace["tau_steer_nm"]), np.abs(trace["tau_drive_nm"])])
    n = len(wd)
    return {
        "tracking_rmse_rad_s": float(np.sqrt(np.mean(err**2))) if len(err) else math.nan,
        "mean_omega_d_rad_s": float(np.mean(wd[sel])) if n else math.nan,
        "lateral_drift_m": float(np.max(np.abs(trace["y_m"]))) if n else math.nan,
        "energy_j": float(np.sum(power) * dt_s),
        "peak_torque_nm": float(np.max(tau)) if len(tau) else 0.0,
        "time_on_ramp_s": float(np.count_nonzero(on) * dt_s),
    }


#: Reference samples slower than this are left out of the PME [rad/s]: at release ω_e ≈ 0 and the
#: relative error (ω_e − ω_s)/ω_e is meaningless (a 0.05 rad/s contact jitter reads as −1000 %).
PME_MIN_SPEED_RAD_S = 0.5


def pme_between(
    t_e: np.ndarray,
    omega_e: np.ndarray,
    on_ramp_e: np.ndarray,
    t_s: np.ndarray,
    omega_s: np.ndarray,
    min_speed_rad_s: float = PME_MIN_SPEED_RAD_S,
) -> float:
    """PME [%] of a simulation (``t_s``, ``omega_s``) against a reference ("experiment": another
    model or a real log; ``t_e``, ``omega_e``, its on-ramp mask ``on_ramp_e``).

    The simulation is linearly interpolated onto the reference times; only reference samples on the
    ramp, inside the simulated time span and with |ω_e| > ``min_speed_rad_s`` count. Positive when
    the simulation underestimates.
    """
    from sphere_env.analysis.metrics import pme_percent

    t_e, w_e = np.asarray(t_e, float), np.asarray(omega_e, float)
    t_s, w_s = np.asarray(t_s, float), np.asarray(omega_s, float)
    mask = np.asarray(on_ramp_e, bool) & (t_e >= t_s[0] - 1e-9) & (t_e <= t_s[-1] + 1e-9)
    return pme_percent(w_e, np.interp(t_e, t_s, w_s), mask, min_speed=min_speed_rad_s)
