"""Replay a logged trial in the twin: same fixture, logged initial state, samples at log times."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sphere_env.calibration.channels import STATE_CHANNELS
from sphere_env.calibration.logs import RobotLog
from sphere_env.physics import InitialState, Twin

#: The log channels a replay produces: every state channel but the heading, which the replay does not track.
SIM_CHANNELS = tuple(c for c in STATE_CHANNELS if not c.startswith("heading"))


def initial_rate(t: np.ndarray, x: np.ndarray, window_s: float = 0.1) -> float:
    """Rate [unit/s] at t[0] from a quadratic least-squares fit over the first ``window_s`` seconds.

    The logs do not always carry velocities (steer_free has none); a quadratic over ~5 samples
    is robust to the 50 Hz jitter and captures the release acceleration.
    """
    k = max(int(np.searchsorted(t, t[0] + window_s)) + 1, 3)
    k = min(k, len(t))
    coeff = np.polyfit(t[:k] - t[0], x[:k], deg=min(2, k - 1))
    return float(coeff[-2])


def _rate(log: RobotLog, name: str, rate_name: str) -> float:
    """The logged rate channel at the first sample, else :func:`initial_rate` of the angle."""
    return float(log[rate_name][0]) if log.has(rate_name) else initial_rate(log.t_s, log[name])


def initial_state_from_log(log: RobotLog, theta_offset_rad: float = 0.0, radius_m: float = 0.305) -> InitialState:
    """The twin's initial state at the log's first sample (a window's start), for the log's fixture.

    ``theta_offset_rad``: encoder zero offset, θ_log = θ_model + offset (see friction fit).
    Rates come from the log's velocity channels when present, else from :func:`initial_rate`.

    Channel mapping (log channel → twin; frames and signs as in ``docs/design.md``):

    * ``stand``: θ, θ̇ ← ``theta``, ``theta_dot`` (steer joint). The shell is welded.
    * ``steer_plane``: additionally φ, φ̇ ← ``phi``, ``phi_dot``: the planar joint's rotation about x_W
      is φ itself; the centre rolls without slip, v = (0, −R φ̇, 0). The drive is locked.
    * ``free`` / ``locked_steer`` (floating base, flat ground, heading ψ = 0: the dynamics on flat
      ground do not depend on heading, so the log's yaw is not used): the pitch center's orientation
      is R_W,PC = Rx(φ) Ry(α), the reading under which the twin's φ (the driveshaft's tilt,
      asin(ŷ_PC·ẑ_W)) and ``pendulum_pitch`` (α, the pitch center's rotation about ŷ_PC out of the
      upright) are exactly the logged ``phi`` and ``pendulum_pitch``. Its angular velocity is
      ω_W = φ̇ x̂_W + α̇ ŷ_PC + s ẑ_W, the spin s about the vertical chosen so that the heading rate ψ̇
      (yaw rate of ŷ_PC's horizontal projection, the twin's ``heading_rate``) equals the logged
      ``heading_rate`` when there is one, else s = 0.
      Drive joint: q̇_d ← ``drive_rate`` (the loader has already turned the ``drive_shaft``
      encoder, which counts the other way round, into the twin's q_d convention). The encoder's
      zero is arbitrary and the shell is symmetric about the driveshaft, so q_d starts at 0. The
      centre rolls without slip: v = ω_shell × (R ẑ_W), ω_shell = ω_PC − q̇_d ŷ_PC.
      θ is not used for ``locked_steer`` (the joint is locked at 0).
    """
    kw: dict = {}
    if log.has("theta"):
        kw["theta"] = float(log["theta"][0]) - theta_offset_rad
        kw["theta_dot"] = _rate(log, "theta", "theta_dot")
    fixture = log.fixture
    if log.has("phi"):
        phi, phi_dot = float(log["phi"][0]), _rate(log, "phi", "phi_dot")
        if fixture in ("free", "locked_steer"):
            alpha = float(log["pendulum_pitch"][0]) if log.has("pendulum_pitch") else 0.0
            alpha_dot = _rate(log, "pendulum_pitch", "pendulum_pitch_rate") if log.has("pendulum_pitch") else 0.0
            cf, sf, ca, sa = math.cos(phi), math.sin(phi), math.cos(alpha), math.sin(alpha)
            # R_W,PC = Rx(φ) Ry(α), written as the twin's roll–pitch–yaw (R = Rz Ry Rx).
            R = np.array([[ca, 0.0, sa], [sf * sa, cf, -sf * ca], [-cf * sa, sf, cf * ca]])
            roll, pitch, yaw = math.atan2(R[2, 1], R[2, 2]), math.asin(-R[2, 0]), math.atan2(R[1, 0], R[0, 0])
            y_pc = R[:, 1]
            w_pc = np.array([phi_dot, 0.0, 0.0]) + alpha_dot * y_pc
            if log.has("heading_rate"):
                # A ẑ spin changes neither φ̇ nor α̇ and raises the heading rate one for one.
                y_dot = np.cross(w_pc, y_pc)
                psi_dot_0 = (y_pc[0] * y_dot[1] - y_pc[1] * y_dot[0]) / (y_pc[0] ** 2 + y_pc[1] ** 2)
                w_pc[2] += float(log["heading_rate"][0]) - psi_dot_0
            qd_dot = _rate(log, "drive_angle", "drive_rate") if log.has("drive_angle") or log.has("drive_rate") else 0.0
            if fixture == "locked_steer":
                kw.pop("theta", None), kw.pop("theta_dot", None)
            w_shell = w_pc - qd_dot * y_pc
            kw.update(
                roll=roll,
                pitch=pitch,
                heading=yaw,
                drive_rate=qd_dot,
                angular_velocity_rad_s=tuple(float(x) for x in w_pc),
                velocity_m_s=(radius_m * float(w_shell[1]), -radius_m * float(w_shell[0]), 0.0),
            )
        else:
            kw["roll"] = phi
            if fixture == "steer_plane":
                # Rolling about x_W without slip: v_centre = ω × (R ẑ) = (0, −R φ̇, 0).
                kw["angular_velocity_rad_s"] = (phi_dot, 0.0, 0.0)
                kw["velocity_m_s"] = (0.0, -radius_m * phi_dot, 0.0)
    return InitialState(**kw)


@dataclass
class SimTrace:
    """Simulated channels sampled at the log's times [s]; angles rad, rates rad/s."""

    t_s: np.ndarray
    channels: dict[str, np.ndarray]
    diverged: bool = False

    def __getitem__(self, name: str) -> np.ndarray:
        return self.channels[name]


def simulate_log(
    twin: Twin,
    log: RobotLog,
    theta_offset_rad: float = 0.0,
    motor_torque_nm=(0.0, 0.0),
    pressure_kpa: float | None = None,
    initial: InitialState | None = None,
) -> SimTrace:
    """Reset ``twin`` to the log's initial state and sample it at every log time.

    The twin must already be built with the log's fixture (build once, reuse in fitting loops).
    Simulated θ is reported in the log's frame: θ_model + ``theta_offset_rad``.
    """
    if log.fixture is not None and twin.config.fixture != log.fixture:
        raise ValueError(f"fixture: twin has {twin.config.fixture!r} but log {log.name!r} needs {log.fixture!r}")
    init = initial or initial_state_from_log(log, theta_offset_rad, twin.robot.radius_m)
    s = twin.reset(init, pressure_kpa=pressure_kpa)
    n = len(log.t_s)
    names = SIM_CHANNELS
    out = {k: np.empty(n) for k in names}
    diverged = False

    def put(i: int, st) -> None:
        for k in SIM_CHANNELS:
            out[k][i] = getattr(st, k)

    put(0, s)
    for i in range(1, n):
        if diverged:
            for k in names:
                out[k][i] = out[k][i - 1]
            continue
        try:
            # Advance to the absolute log time (no drift from summed increments); the 1 ns margin
            # keeps a sample that falls on a plant-step boundary on the same side as a live run.
            twin.advance(max(float(log.t_s[i]) - twin.time_s - 1e-9, 0.0), motor_torque_nm)
            put(i, twin.state())
        except RuntimeError:  # a solver failure at absurd parameters: keep a flat, bad trace
            diverged = True
            for k in names:
                out[k][i] = out[k][i - 1]
    out["theta"] = out["theta"] + theta_offset_rad
    return SimTrace(log.t_s.copy(), out, diverged)
