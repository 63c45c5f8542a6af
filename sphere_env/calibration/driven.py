"""Driven replay: the twin's pendulum made to follow a log's steer angle θ(t) and pitch α(t), the shell free.

The motor torques of the free robot's driving were not logged, so a driving segment cannot be replayed
open-loop. The pendulum's angles were logged: θ (``roll_joint``, the steer joint) and α
(``pitch_joint``, the IMU's pitch of the pendulum against gravity). A stiff tracking controller at the
motors makes the twin's pendulum move as the real one did, within the motors' torque limits, and the
shell's response is what the twin predicts: the drive velocity ω_d, the heading rate ψ̇ and the lean φ.

* steer motor: PID on θ, the steer joint angle;
* drive motor: PID on α. The drive joint (axis −ŷ_PC) turns the pitch center and pendulum against the
  shell; a positive drive torque raises α (the pitch center's rotation about +ŷ_PC).

Both torques are clipped to the motor limits (the registry's ``steer_torque_limit_nm`` and
``drive_torque_limit_nm``, assumed: the real limits are unpublished) and recorded; the integral
stops growing while a motor saturates (anti-windup). The references are the logged angles smoothed
by a Savitzky–Golay filter (scipy), which also gives their rates. The replay starts from the logged
state at the window's start (:func:`~sphere_env.calibration.simulate.initial_state_from_log`) and the
twin is sampled at the log's times (linear interpolation between control steps).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import savgol_filter

from sphere_env.calibration.logs import LogError, RobotLog
from sphere_env.calibration.simulate import initial_state_from_log
from sphere_env.params import PARAMETERS
from sphere_env.physics import Twin

#: The log channels a driven window needs: the tracked angles and the compared responses.
DRIVEN_CHANNELS = ("theta", "pendulum_pitch", "omega_d", "heading_rate", "phi")
#: The responses a driven replay is judged on (rad/s, rad/s, rad); θ and α are the tracked angles.
RESPONSES = ("omega_d", "heading_rate", "phi")
TRACKED = ("theta", "pendulum_pitch")
#: How far inside the steer joint's limits the θ reference is held [rad].
THETA_LIMIT_MARGIN_RAD = 0.005
#: The motors' torque limits [N m] at the joints (assumed, see the module docstring).
TORQUE_LIMITS_NM = (PARAMETERS["steer_torque_limit_nm"].nominal, PARAMETERS["drive_torque_limit_nm"].nominal)


@dataclass(frozen=True)
class Tracking:
    """The tracking controller: one PID per motor on its angle (θ for steer, α for drive), run every
    ``control_period_s``; ``smoothing_s`` is the Savitzky–Golay window of the references."""

    kp_nm_per_rad: float = 400.0
    ki_nm_per_rad_s: float = 2000.0
    kd_nms_per_rad: float = 25.0
    control_period_s: float = 0.005
    smoothing_s: float = 0.11


@dataclass
class DrivenTrace:
    """The twin's channels at the log's times [rad, rad/s], and the motor torques [N m] it needed
    (``torque_nm``, columns steer and drive, at ``control_t_s``): as applied (clipped) and as the
    controller asked (``requested_nm``)."""

    t_s: np.ndarray
    channels: dict[str, np.ndarray]
    control_t_s: np.ndarray
    torque_nm: np.ndarray
    requested_nm: np.ndarray
    limits_nm: tuple[float, float]
    diverged: bool = False
    extra: dict = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.channels[name]

    def torque_summary(self) -> dict[str, dict[str, float]]:
        """Per motor: the limit, the peak and RMS applied torque, the peak the controller asked for and
        the share of control steps at the limit [N m, -]."""
        out = {}
        for j, motor in enumerate(("steer", "drive")):
            tau, req, lim = self.torque_nm[:, j], self.requested_nm[:, j], self.limits_nm[j]
            out[motor] = {
                "limit_nm": float(lim),
                "peak_nm": float(np.max(np.abs(tau))),
                "rms_nm": float(np.sqrt(np.mean(tau**2))),
                "peak_requested_nm": float(np.max(np.abs(req))),
                "saturated_fraction": float(np.mean(np.abs(req) >= lim)),
            }
        return out


def check_driven(log: RobotLog, where: str = "driven window") -> None:
    """Refuse (:class:`LogError`, naming the channels) a log a driven replay cannot use."""
    missing = [c for c in DRIVEN_CHANNELS if not log.has(c)]
    if missing:
        raise LogError(
            f"log {log.path!r}: {where} {log.name!r} lacks channels {missing}; a driven replay needs {list(DRIVEN_CHANNELS)}"
        )
    if log.fixture != "free":
        raise LogError(
            f"log {log.path!r}: {where} {log.name!r} has fixture {log.fixture!r}; a driven replay needs 'free'"
        )


def references(log: RobotLog, smoothing_s: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The tracked angles θ and α smoothed, with their rates: channel -> (angle [rad], rate [rad/s])
    at the log's times (Savitzky–Golay, quadratic, over ``smoothing_s``)."""
    dt = float(np.median(np.diff(log.t_s)))
    n = max(int(round(smoothing_s / dt)) // 2 * 2 + 1, 5)
    n = min(n, len(log.t_s) - (1 - len(log.t_s) % 2))
    return {ch: (savgol_filter(log[ch], n, 2), savgol_filter(log[ch], n, 2, deriv=1, delta=dt)) for ch in TRACKED}


def driven_replay(
    twin: Twin,
    log: RobotLog,
    tracking: Tracking = Tracking(),
    limits_nm: tuple[float, float] = TORQUE_LIMITS_NM,
    pressure_kpa: float | None = None,
) -> DrivenTrace:
    """Replay ``log`` (a ``free`` window of driving) on ``twin`` (built with fixture ``free``): the
    pendulum tracks the logged θ and α, the shell responds (module docstring)."""
    check_driven(log)
    refs = references(log, tracking.smoothing_s)
    # θ beyond the twin's steer joint limits (the URDF's [−1.57, 1.0] rad; the free robot's log holds
    # θ ≈ 1.04 rad while driving) would wind the steer motor up against the limit: clamp the reference
    lo, hi = float(twin.steer.position_lower_limits()[0]), float(twin.steer.position_upper_limits()[0])
    theta_ref = np.clip(refs["theta"][0], lo + THETA_LIMIT_MARGIN_RAD, hi - THETA_LIMIT_MARGIN_RAD)
    clipped = float(np.mean(theta_ref != refs["theta"][0]))
    refs["theta"] = (theta_ref, np.where(theta_ref != refs["theta"][0], 0.0, refs["theta"][1]))
    t_log = log.t_s
    twin.reset(initial_state_from_log(log, 0.0, twin.robot.radius_m), pressure_kpa=pressure_kpa)
    dt = tracking.control_period_s
    n = int(math.ceil(float(t_log[-1]) / dt)) + 1
    kp, ki, kd = tracking.kp_nm_per_rad, tracking.ki_nm_per_rad_s, tracking.kd_nms_per_rad
    lim = np.asarray(limits_nm, float)
    integral = np.zeros(2)
    rec_t, rec_x, rec_tau, rec_req = np.empty(n), np.empty((n, 5)), np.empty((n, 2)), np.empty((n, 2))
    diverged = False
    for i in range(n):
        s = twin.state()
        t = twin.time_s
        rec_t[i] = t
        rec_x[i] = (s.omega_d, s.heading_rate, s.phi, s.theta, s.pendulum_pitch)
        err = np.array([np.interp(t, t_log, refs[ch][0]) - x for ch, x in zip(TRACKED, (s.theta, s.pendulum_pitch))])
        rate_err = np.array(
            [np.interp(t, t_log, refs[ch][1]) - x for ch, x in zip(TRACKED, (s.theta_dot, s.pendulum_pitch_rate))]
        )
        req = kp * err + ki * integral + kd * rate_err
        tau = np.clip(req, -lim, lim)
        integral += np.where(np.abs(req) < lim, err * dt, 0.0)  # anti-windup: no growth at the limit
        rec_tau[i], rec_req[i] = tau, req
        if i == n - 1:
            break
        try:
            twin.advance_unchecked(dt, tau)
        except RuntimeError:  # a solver failure at absurd parameters: hold the last state
            diverged = True
            rec_t, rec_x, rec_tau, rec_req = rec_t[: i + 1], rec_x[: i + 1], rec_tau[: i + 1], rec_req[: i + 1]
            break
    names = (*RESPONSES, *TRACKED)
    channels = {k: np.interp(t_log, rec_t, rec_x[:, j]) for j, k in enumerate(names)}
    extra = {"theta_reference_clamped_fraction": clipped, "steer_limits_rad": [lo, hi]}
    return DrivenTrace(t_log.copy(), channels, rec_t, rec_tau, rec_req, (float(lim[0]), float(lim[1])), diverged, extra)


def driven_rmse(trace: DrivenTrace, log: RobotLog) -> dict[str, float]:
    """RMSE of every response and tracked angle against the log [rad/s or rad], over every sample of
    the window (the convention of ``validate``)."""
    return {ch: float(np.sqrt(np.mean((trace[ch] - log[ch]) ** 2))) for ch in (*RESPONSES, *TRACKED)}
