"""Termination and physics-failure checks: pure functions of a TwinState."""

from __future__ import annotations

import math
from typing import Any

#: A state beyond these is treated as a physics failure (the solver diverged) [SI units].
MAX_SPEED_M_S = 50.0
MAX_RATE_RAD_S = 500.0


def ramp_status(position_m, ramp_end_x_m: float, lane_half_width_m: float) -> tuple[bool, bool]:
    """(reached the run-out, left the ramp sideways) for a sphere centre ``position_m`` [m].

    The ramp runs from x = 0 downhill along +x_W to x = ``ramp_end_x_m`` (horizontal distance);
    the lane is |y| ≤ ``lane_half_width_m``.
    """
    x, y = float(position_m[0]), float(position_m[1])
    return x >= ramp_end_x_m, abs(y) > lane_half_width_m


def physics_failure(state: Any) -> str | None:
    """A reason string if the state is non-finite or implausible (a diverged solve), else None."""
    values = (
        state.theta,
        state.theta_dot,
        state.drive_angle,
        state.drive_rate,
        state.phi,
        state.phi_dot,
        state.omega_d,
        state.heading_rate,
        *state.position_m.tolist(),
        *state.velocity_m_s.tolist(),
    )
    if not math.isfinite(sum(values)):  # any NaN or inf makes the sum non-finite
        return "physics_failure: non-finite state"
    v = state.velocity_m_s
    if abs(v[0]) > MAX_SPEED_M_S or abs(v[1]) > MAX_SPEED_M_S or abs(v[2]) > MAX_SPEED_M_S:
        return f"physics_failure: speed beyond {MAX_SPEED_M_S} m/s"
    if max(abs(state.theta_dot), abs(state.drive_rate), abs(state.omega_d), abs(state.phi_dot)) > MAX_RATE_RAD_S:
        return f"physics_failure: joint or shell rate beyond {MAX_RATE_RAD_S} rad/s"
    return None
