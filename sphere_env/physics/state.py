"""Reading the twin's state: the plant's positions and velocities as a :class:`TwinState`.

:func:`read_state` turns [q; v] into the quantities the envs, tasks and calibration use (steer and
drive angles, pipe angle φ, shell rate ω_d, heading, pose, velocities, gravity in the pipe frame,
pendulum pitch) with plain float math, about 7 µs a call, so reading the state every control step
costs next to nothing. The indices of each coordinate come from the diagram's layout
(:mod:`sphere_env.physics.diagram`), whose base is a free body (quaternion), a planar joint or a
stand.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from sphere_env.physics.config import TwinState
from sphere_env.physics.forces import COS_PHI_FLOOR
from sphere_env.physics.terrain import Terrain


def read_state(
    positions_velocities: np.ndarray, layout: Mapping[str, Any], terrain: Terrain, time_s: float, pressure_kpa: float
) -> TwinState:
    """θ, φ, ω_d, heading, pose and rates from the plant's [q; v] (names and signs: docs/design.md),
    indexed by the diagram's ``layout``; ``time_s`` and ``pressure_kpa`` are passed through.

    Plain float math on [q; v] (≈7 µs): R_WPC from the normalized base quaternion, φ and φ̇
    from :func:`~sphere_env.physics.forces.pipe_angle_expressions` (the same definition the injected law uses),
    ω_d = ω_WPC·ŷ − q̇_d, ψ = atan2(−ŷ_x, ŷ_y), gravity in the pipe frame
    g_P = −(row z of R_WP)ᵀ with R_WP = R_WPC R_y(−q_d) (the drive axis is −y_PC).
    Pendulum pitch α = atan2(−r_x, r_z) with r = R_WPCᵀ ẑ_W (row z of R_WPC); its rate from
    ṙ = −ω_PC × r, ω_PC = R_WPCᵀ ω_W.

    The state is read every control step, so the projections of ``pipe_angle_expressions``
    and the products it shares with ω_d and ψ̇ are written out here, each the same floating-point
    operations in the same order as the functions they stand for (the results are bit-identical).
    """
    x = positions_velocities.tolist()
    nq = layout["nq"]
    q_d, qd_dot = x[layout["drive_q"]], x[nq + layout["drive_v"]]
    base = layout["base"]
    if base == "quaternion":
        i, j = layout["base_q"], nq + layout["base_v"]
        qw, qx, qy, qz = x[i : i + 4]
        k = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
        y0, y1, y2 = k * (qx * qy - qw * qz), 1.0 - k * (qx * qx + qz * qz), k * (qy * qz + qw * qx)
        r0, r1, r2 = k * (qx * qz - qw * qy), k * (qy * qz + qw * qx), 1.0 - k * (qx * qx + qy * qy)
        p_W, v_W = x[i + 4 : i + 7], x[j + 3 : j + 6]
        wx, wy, wz = x[j : j + 3]
        # ω_PC in PC: ω_W projected on the columns x, y, z of R_WPC
        w0 = wx * (1.0 - k * (qy * qy + qz * qz)) + wy * (k * (qx * qy + qw * qz)) + wz * (k * (qx * qz - qw * qy))
        w1 = wx * y0 + wy * y1 + wz * y2
        w2 = wx * (k * (qx * qz + qw * qy)) + wy * (k * (qy * qz - qw * qx)) + wz * (1.0 - k * (qx * qx + qy * qy))
        r0_dot, r2_dot = -(w1 * r2 - w2 * r1), -(w0 * r1 - w1 * r0)
        alpha = math.atan2(-r0, r2)
        alpha_dot = (r0 * r2_dot - r2 * r0_dot) / max(r0 * r0 + r2 * r2, 1e-12)
    elif base == "planar":  # coords (y_W, z_W, φ) about world x
        i, j = layout["base_q"], nq + layout["base_v"]
        c, sn = math.cos(x[i + 2]), math.sin(x[i + 2])
        y0, y1, y2 = 0.0, c, sn
        r0, r1, r2 = 0.0, sn, c
        p_W, v_W = (0.0, x[i], x[i + 1]), (0.0, x[j], x[j + 1])
        wx, wy, wz = x[j + 2], 0.0, 0.0
        alpha = alpha_dot = 0.0  # rotation about world x only: no pitch
    else:  # stand: pitch center welded 1 m above the origin
        y0, y1, y2 = 0.0, 1.0, 0.0
        r0, r1, r2 = 0.0, 0.0, 1.0
        p_W, v_W = (0.0, 0.0, 1.0), (0.0, 0.0, 0.0)
        wx = wy = wz = 0.0
        alpha = alpha_dot = 0.0
    # pipe_angle_expressions(y_W, w_W, n_W): ŷ·n, ŷ×n, ẏ·n with ẏ = ω × ŷ, then φ and φ̇
    n0, n1, n2 = terrain.normal_at(p_W)
    s = y0 * n0 + y1 * n1 + y2 * n2
    c0, c1, c2 = y1 * n2 - y2 * n1, y2 * n0 - y0 * n2, y0 * n1 - y1 * n0
    yd0, yd1, yd2 = wy * y2 - wz * y1, wz * y0 - wx * y2, wx * y1 - wy * y0  # ẏ = ω × ŷ (cross3)
    cos_phi = max(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2), COS_PHI_FLOOR)
    c, sn = math.cos(q_d), -math.sin(q_d)
    state = _new_state(TwinState)
    # TwinState's frozen __init__ sets each field through object.__setattr__ (≈4 µs): the snapshot
    # read every control step fills its __dict__ at once instead (every field, as __init__ would).
    state.__dict__.update(
        time_s=time_s,
        theta=x[layout["steer_q"]],
        theta_dot=x[nq + layout["steer_v"]],
        drive_angle=q_d,
        drive_rate=qd_dot,
        phi=math.atan2(s, cos_phi),
        phi_dot=(yd0 * n0 + yd1 * n1 + yd2 * n2) / cos_phi,
        omega_d=wx * y0 + wy * y1 + wz * y2 - qd_dot,
        heading=math.atan2(-y0, y1),
        heading_rate=(y0 * yd1 - y1 * yd0) / max(y0**2 + y1**2, 1e-12),
        position_m=np.array(p_W),
        velocity_m_s=np.array(v_W),
        gravity_in_pipe=np.array((-(r0 * c - r2 * sn), -r1, -(r0 * sn + r2 * c))),
        pressure_kpa=pressure_kpa,
        pendulum_pitch=alpha,
        pendulum_pitch_rate=alpha_dot,
    )
    return state


_new_state = object.__new__
