"""Reading the twin's state: the plant's positions and velocities as a :class:`TwinState`.

:func:`read_state` turns [q; v] into the quantities the envs, tasks and calibration use (steer and
drive angles, pipe angle φ, shell rate ω_d, heading, pose, velocities, gravity in the pipe frame,
pendulum pitch) with plain float math, about 10 µs a call, so reading the state every control step
costs next to nothing. The indices of each coordinate come from the diagram's layout
(:mod:`sphere_env.physics.diagram`), whose base is a free body (quaternion), a planar joint or a
stand.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from sphere_env.physics.config import TwinState
from sphere_env.physics.forces import cross3, pipe_angle_expressions
from sphere_env.physics.terrain import Terrain


def read_state(
    positions_velocities: np.ndarray, layout: Mapping[str, Any], terrain: Terrain, time_s: float, pressure_kpa: float
) -> TwinState:
    """θ, φ, ω_d, heading, pose and rates from the plant's [q; v] (names and signs: docs/design.md),
    indexed by the diagram's ``layout``; ``time_s`` and ``pressure_kpa`` are passed through.

    Plain float math on [q; v] (≈10 µs): R_WPC from the normalized base quaternion, φ and φ̇
    from :func:`pipe_angle_expressions` (the same definition the injected law uses),
    ω_d = ω_WPC·ŷ − q̇_d, ψ = atan2(−ŷ_x, ŷ_y), gravity in the pipe frame
    g_P = −(row z of R_WP)ᵀ with R_WP = R_WPC R_y(−q_d) (the drive axis is −y_PC).
    Pendulum pitch α = atan2(−r_x, r_z) with r = R_WPCᵀ ẑ_W (row z of R_WPC); its rate from
    ṙ = −ω_PC × r, ω_PC = R_WPCᵀ ω_W.
    """
    x = positions_velocities.tolist()
    nq = layout["nq"]
    q_d, qd_dot = x[layout["drive_q"]], x[nq + layout["drive_v"]]
    if layout["base"] == "quaternion":
        i, j = layout["base_q"], nq + layout["base_v"]
        qw, qx, qy, qz = x[i : i + 4]
        k = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
        y_W = (k * (qx * qy - qw * qz), 1.0 - k * (qx * qx + qz * qz), k * (qy * qz + qw * qx))
        row_z = (k * (qx * qz - qw * qy), k * (qy * qz + qw * qx), 1.0 - k * (qx * qx + qy * qy))
        p_W, w_W, v_W = x[i + 4 : i + 7], x[j : j + 3], x[j + 3 : j + 6]
        x_W = (1.0 - k * (qy * qy + qz * qz), k * (qx * qy + qw * qz), k * (qx * qz - qw * qy))
        z_W = (k * (qx * qz + qw * qy), k * (qy * qz - qw * qx), 1.0 - k * (qx * qx + qy * qy))
        w0 = w_W[0] * x_W[0] + w_W[1] * x_W[1] + w_W[2] * x_W[2]  # ω_PC in PC
        w1 = w_W[0] * y_W[0] + w_W[1] * y_W[1] + w_W[2] * y_W[2]
        w2 = w_W[0] * z_W[0] + w_W[1] * z_W[1] + w_W[2] * z_W[2]
        r0, r1, r2 = row_z
        r0_dot, r2_dot = -(w1 * r2 - w2 * r1), -(w0 * r1 - w1 * r0)
        alpha = math.atan2(-r0, r2)
        alpha_dot = (r0 * r2_dot - r2 * r0_dot) / max(r0 * r0 + r2 * r2, 1e-12)
    elif layout["base"] == "planar":  # coords (y_W, z_W, φ) about world x
        i, j = layout["base_q"], nq + layout["base_v"]
        c, sn = math.cos(x[i + 2]), math.sin(x[i + 2])
        y_W, row_z = (0.0, c, sn), (0.0, sn, c)
        p_W, w_W, v_W = (0.0, x[i], x[i + 1]), (x[j + 2], 0.0, 0.0), (0.0, x[j], x[j + 1])
        alpha = alpha_dot = 0.0  # rotation about world x only: no pitch
    else:  # stand: pitch center welded 1 m above the origin
        y_W, row_z = (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
        p_W, w_W, v_W = (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        alpha = alpha_dot = 0.0
    phi, phi_dot, _ = pipe_angle_expressions(y_W, w_W, terrain.normal_at(p_W))
    y_dot = cross3(w_W, y_W)
    c, sn = math.cos(q_d), -math.sin(q_d)
    return TwinState(
        time_s=time_s,
        theta=x[layout["steer_q"]],
        theta_dot=x[nq + layout["steer_v"]],
        drive_angle=q_d,
        drive_rate=qd_dot,
        phi=phi,
        phi_dot=phi_dot,
        omega_d=w_W[0] * y_W[0] + w_W[1] * y_W[1] + w_W[2] * y_W[2] - qd_dot,
        heading=math.atan2(-y_W[0], y_W[1]),
        heading_rate=(y_W[0] * y_dot[1] - y_W[1] * y_dot[0]) / max(y_W[0] ** 2 + y_W[1] ** 2, 1e-12),
        position_m=np.array(p_W),
        velocity_m_s=np.array(v_W),
        gravity_in_pipe=-np.array((row_z[0] * c - row_z[2] * sn, row_z[1], row_z[0] * sn + row_z[2] * c)),
        pressure_kpa=pressure_kpa,
        pendulum_pitch=alpha,
        pendulum_pitch_rate=alpha_dot,
    )
