"""Observation assembly: plain functions of a :class:`~sphere_env.physics.twin.TwinState`.

Only quantities the real robot measures (its log channels, ``docs/design.md``, plus an IMU-like gravity
direction) enter the measured part; the task command and optional privileged pressure follow.
No Drake Context is touched here.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

TWO_PI = 2.0 * math.pi

#: Measured components: (name, unit, meaning, log channel). Order = observation index.
MEASURED_COMPONENTS: tuple[tuple[str, str, str], ...] = (
    ("theta", "rad", "steer joint angle θ (roll_joint)"),
    ("theta_dot", "rad/s", "steer joint rate θ̇ (roll_joint.velocity)"),
    ("drive_angle", "rad", "drive joint angle (pendulum pitch vs shell, pitch_joint), wrapped to [-π, π)"),
    ("drive_rate", "rad/s", "drive joint rate (pitch_joint.velocity)"),
    ("phi", "rad", "pipe angle φ against the ground (pipe_roll)"),
    ("phi_dot", "rad/s", "pipe angle rate φ̇"),
    ("omega_d", "rad/s", "drive velocity ω_d, + rolling forward (drive_shaft.velocity)"),
    ("yaw_rate", "rad/s", "heading rate ψ̇ (shell_yaw rate / IMU gyro)"),
    ("gravity_x", "-", "unit gravity direction in the pipe frame, x (IMU)"),
    ("gravity_y", "-", "unit gravity direction in the pipe frame, y (IMU)"),
    ("gravity_z", "-", "unit gravity direction in the pipe frame, z (IMU)"),
)
N_MEASURED = len(MEASURED_COMPONENTS)

#: Default 1-σ measurement noise per measured component, in the component's unit. Scaled by the
#: env's ``observation_noise_scale`` (0 = noise off). Assumed encoder/IMU-grade values.
DEFAULT_NOISE_STD = np.array([0.005, 0.05, 0.005, 0.05, 0.01, 0.05, 0.05, 0.05, 0.01, 0.01, 0.01])


def wrap_angle(angle_rad: float) -> float:
    """Wrap an angle to [-π, π) [rad]."""
    return (angle_rad + math.pi) % TWO_PI - math.pi


def measured_values(state: Any) -> list[float]:
    """The measured components of a TwinState as plain floats (order of MEASURED_COMPONENTS)."""
    g = state.gravity_in_pipe
    return [
        state.theta,
        state.theta_dot,
        wrap_angle(state.drive_angle),
        state.drive_rate,
        state.phi,
        state.phi_dot,
        state.omega_d,
        state.heading_rate,
        float(g[0]),
        float(g[1]),
        float(g[2]),
    ]


def assemble_observation(
    state: Any,
    command: list[float],
    pressure_kpa: float | None = None,
    noise: np.ndarray | None = None,
) -> np.ndarray:
    """[measured (11) | command | pressure_kpa if given] as float32.

    :param command: task command values, appended unchanged (not noised).
    :param pressure_kpa: privileged inflation pressure [kPa], appended if not ``None``.
    :param noise: additive noise for the measured part (len 11), or ``None``.
    """
    values = measured_values(state)
    if noise is not None:
        values = [v + n for v, n in zip(values, noise.tolist())]
    values += command
    if pressure_kpa is not None:
        values.append(pressure_kpa)
    return np.array(values, dtype=np.float32)

