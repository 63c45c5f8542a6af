"""The PD baseline (:class:`~sphere_env.controllers.PendulumPDController`) as a torch module: the same
equations and gains, with the controller's state (the speed-error integral and the previous ω_d) held
in an explicit tensor instead of attributes, so that an exported graph can carry it from one control
step to the next::

    action, next_state = PendulumPDModule(pd)(observation, state)

``observation`` (batch, n_obs), laid out as the controller reads it (computed in float64);
``state`` (batch, 3) float64, laid out as :data:`PD_STATE`; at the start of every episode (where the
controller is ``reset()``) it is :data:`PD_STATE_RESET` = [0, 0, 1]. ``action`` (batch, 2) float64
in [−1, 1], [steer, drive]: the controller's action before its float32 cast. Feeding ``next_state``
back as the next step's ``state`` gives the controller's actions step after step.
"""

from __future__ import annotations

import torch

from sphere_env.controllers import (
    CMD_HEADING,
    CMD_SPEED,
    DRIVE_ANGLE,
    DRIVE_RATE,
    GX,
    GZ,
    HEADING_RATE,
    OMEGA_D,
    THETA,
    THETA_DOT,
    PendulumPDController,
)

#: The PD state's components in index order: (name, unit, meaning, value at an episode's start).
PD_STATE = (
    (
        "speed_error_integral",
        "rad",
        "∫(ω_ref − ω_d − t_lead ω̇_d) dt since the episode's start, clipped to ±beta_max / k_int",
        0.0,
    ),
    ("omega_d_prev", "rad/s", "ω_d of the previous control step (unused while no_omega_d_prev is 1)", 0.0),
    (
        "no_omega_d_prev",
        "1",
        "1 until the first step of an episode has run (that step takes ω̇_d = 0), then 0",
        1.0,
    ),
)
#: The state at the start of every episode (the controller's ``reset()``): zeros, and the flag set.
PD_STATE_RESET = tuple(value for *_, value in PD_STATE)


def atan2(y: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
    """atan2(y, x) of float64 tensors, to float64 precision, from float32's atan2 and one Newton step:
    θ = θ₀ + tan(θ − θ₀), tan(θ − θ₀) = (y cos θ₀ − x sin θ₀) / (x cos θ₀ + y sin θ₀) (the step's error
    is (θ − θ₀)³/3 ≈ 1e-21). ONNX runtimes implement Atan in float32 only (onnxruntime's CPU kernels);
    this keeps the exported PD in float64 like the Python controller's ``math.atan2``. At x = y = 0
    it is float32's atan2."""
    theta0 = torch.atan2(y.to(torch.float32), x.to(torch.float32)).to(torch.float64)
    c, s = torch.cos(theta0), torch.sin(theta0)
    den = x * c + y * s  # r cos(θ − θ₀) > 0 unless x = y = 0
    return torch.where(den > 0, theta0 + (y * c - x * s) / den, theta0)


class PendulumPDModule(torch.nn.Module):
    """:class:`~sphere_env.controllers.PendulumPDController` ``pd``'s law with its gains, command mode,
    control period and torque limits; ``forward(observation, state) -> (action, next_state)``."""

    def __init__(self, pd: PendulumPDController):
        super().__init__()
        self.dt = float(pd.control_period_s)
        self.k_speed, self.k_int, self.beta_max = float(pd.k_speed), float(pd.k_int), float(pd.beta_max)
        self.integral_limit = float(pd.integral_limit_rad)
        self.kp_pitch, self.kd_pitch, self.t_lead = float(pd.kp_pitch), float(pd.kd_pitch), float(pd.t_lead_s)
        self.k_heading, self.k_yaw, self.k_yaw_rate = float(pd.k_heading), float(pd.k_yaw), float(pd.k_yaw_rate)
        self.theta_max, self.kp_lean, self.kd_lean = float(pd.theta_max), float(pd.kp_lean), float(pd.kd_lean)
        self.heading_mode = pd.command_mode == "heading"
        self.k_eq, self.k_lean = float(pd.k_eq_nm), float(pd.k_lean_nm)
        self.steer_limit, self.drive_limit = float(pd.steer_torque_limit_nm), float(pd.drive_torque_limit_nm)

    def forward(self, observation: torch.Tensor, state: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = observation.to(torch.float64)
        state = state.to(torch.float64)
        integral, omega_prev, first = state[:, 0], state[:, 1], state[:, 2]
        omega = x[:, OMEGA_D]
        # the first step after a reset has no previous ω_d: its acceleration is 0
        accel = torch.where(first > 0.5, torch.zeros_like(omega), (omega - omega_prev) / self.dt)
        err = x[:, CMD_SPEED] - omega - self.t_lead * accel
        integral = torch.clamp(integral + err * self.dt, -self.integral_limit, self.integral_limit)
        beta_ref = torch.clamp(self.k_speed * err + self.k_int * integral, -self.beta_max, self.beta_max)
        # pendulum lift β and its rate (sphere_env.controllers.pendulum_pitch)
        gx, gz, q = x[:, GX], x[:, GZ], x[:, DRIVE_ANGLE]
        c, s = torch.cos(q), torch.sin(q)
        gpx, gpz = c * gx - s * gz, s * gx + c * gz
        beta, beta_dot = atan2(-gpx, -gpz), -(omega + x[:, DRIVE_RATE])
        tau_d = self.k_eq * torch.sin(beta_ref) + self.kp_pitch * (beta_ref - beta) - self.kd_pitch * beta_dot
        if self.heading_mode:
            theta_ref = self.k_heading * x[:, CMD_HEADING] - self.k_yaw * x[:, HEADING_RATE]
        else:
            theta_ref = self.k_yaw_rate * (x[:, CMD_HEADING] - x[:, HEADING_RATE])
        theta_ref = torch.clamp(theta_ref, -self.theta_max, self.theta_max)
        tau_s = (
            self.k_lean * torch.sin(theta_ref)
            + self.kp_lean * (theta_ref - x[:, THETA])
            - self.kd_lean * x[:, THETA_DOT]
        )
        action = torch.stack([tau_s / self.steer_limit, tau_d / self.drive_limit], dim=1).clamp(-1.0, 1.0)
        next_state = torch.stack([integral, omega, torch.zeros_like(omega)], dim=1)
        return action, next_state
