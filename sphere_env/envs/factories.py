"""Factories of the registered environments: each joins a task with the generic :class:`SphereEnv`.

Gymnasium calls these with the kwargs of ``gym.make(id, **kwargs)``; each task's documentation
(spaces, rewards, episode end, kwargs) is on its task class.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from sphere_env.envs.env import SphereEnv
from sphere_env.tasks.ramp_descent import RampDescentTask
from sphere_env.tasks.roll import RollTask


def make_ramp_descent(
    *,
    incline_deg: float = 16.0,
    ramp_length_m: float = 4.0,
    lane_half_width_m: float = 1.0,
    omega_ref_range_rad_s: tuple[float, float] = (4.0, 8.0),
    reward_weights: Mapping[str, float] | None = None,
    **kwargs: Any,
) -> SphereEnv:
    """``sphere_env/RampDescent-v1`` (and ``-v0``, registered with the v0 calibration):
    :class:`~sphere_env.tasks.RampDescentTask` on a 16° ramp of 4 m by default (the paper's
    experiment), plus :class:`SphereEnv`'s kwargs."""
    if ramp_length_m is None:
        raise ValueError("ramp_length_m: value None not allowed for RampDescent; give a length in m")
    task = RampDescentTask(lane_half_width_m, omega_ref_range_rad_s, reward_weights)
    return SphereEnv(task, incline_deg=incline_deg, ramp_length_m=ramp_length_m, **kwargs)


def make_roll(
    *,
    omega_ref_range_rad_s: tuple[float, float] = (0.5, 2.5),
    heading_range_rad: float = math.pi / 2,
    yaw_rate_range_rad_s: tuple[float, float] = (-0.5, 0.5),
    command_mode: str = "heading",
    command_resample_s: float | None = None,
    reward_weights: Mapping[str, float] | None = None,
    **kwargs: Any,
) -> SphereEnv:
    """``sphere_env/Roll-v1``: :class:`~sphere_env.tasks.RollTask` on flat ground, plus
    :class:`SphereEnv`'s kwargs."""
    if kwargs.get("ramp_length_m") is not None:
        raise ValueError("ramp_length_m: not used by Roll (flat ground); leave it None")
    task = RollTask(omega_ref_range_rad_s, heading_range_rad, yaw_rate_range_rad_s, command_mode,
                    command_resample_s, reward_weights)
    return SphereEnv(task, **kwargs)
