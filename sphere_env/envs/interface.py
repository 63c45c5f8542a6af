"""What :class:`~sphere_env.envs.SphereEnv` takes in and hands out besides the physics: the action
read from any array-like, the ``info`` dicts of a step and of a physics failure, and the action
layout."""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from sphere_env.tasks.task import Task


def read_action(action: Any) -> tuple[float, float]:
    """(steer, drive) of an action: a float array of shape (2,) (the fast path) or anything numpy
    reads as two real numbers; ``ValueError`` naming the action for text, bools, complex or object
    values, another shape, NaN or inf."""
    if type(action) is np.ndarray and action.shape == (2,) and action.dtype.kind == "f":
        a0, a1 = action.tolist()
    else:
        try:
            a = np.asarray(action)
        except (TypeError, ValueError):
            a = np.asarray(None)
        if a.dtype.kind not in "iuf":  # refuses str, bool, complex, object (None, mixed)
            raise ValueError(
                f"action: value {action!r} (dtype {a.dtype}) is not real numbers; expected [steer, drive] floats in [-1, 1]"
            )
        a = a.astype(np.float64)
        if a.shape != (2,):
            raise ValueError(f"action: shape {a.shape} invalid; expected (2,) = [steer, drive] in [-1, 1]")
        a0, a1 = a.tolist()
    if not (math.isfinite(a0) and math.isfinite(a1)):
        raise ValueError(f"action: value {action!r} is not finite (NaN or inf); expected [steer, drive] in [-1, 1]")
    return a0, a1


def zero_terms(task: Task) -> dict[str, float]:
    """Every reward term of ``task`` at 0, by its ``info`` key."""
    return {f"reward_{k}": 0.0 for k in task.reward_terms}


def step_info(
    task: Task,
    state,
    terms: Mapping[str, float],
    success: bool,
    params: Mapping[str, Any],
    tau_nm: np.ndarray,
    fired: list[str],
    reward_keys: Mapping[str, str],
) -> dict[str, Any]:
    """The ``info`` of a reset or step: the reward terms (``reward_<term>``), the episode's
    parameters, the state's main angles and rates, the applied motor torques [N m], the events
    fired and the task's own values."""
    info = {reward_keys[k]: v for k, v in terms.items()} if terms else zero_terms(task)
    info["shell_model"] = params["shell_model"]
    info["pressure_kpa"] = params["pressure_kpa"]
    info["theta"] = state.theta
    info["phi"] = state.phi
    info["omega_d"] = state.omega_d
    info["heading"] = state.heading
    info["position_m"] = state.position_m
    info["time_s"] = state.time_s
    info["is_success"] = success
    info["motor_torque_nm"] = tau_nm.copy()
    info["params"] = dict(params)
    info["events"] = fired
    info.update(task.info())
    return info


def failed_info(
    task: Task, params: Mapping[str, Any], reason: str, tau_nm: np.ndarray, fired: list[str]
) -> dict[str, Any]:
    """The ``info`` of a step truncated by a physics failure (``truncation_reason``)."""
    info = zero_terms(task)
    info.update(
        shell_model=params["shell_model"],
        pressure_kpa=params["pressure_kpa"],
        is_success=False,
        truncation_reason=reason,
        motor_torque_nm=tau_nm.copy(),
        params=dict(params),
        events=fired,
    )
    info.update(task.info())
    return info


def action_layout(steer_torque_limit_nm: float, drive_torque_limit_nm: float) -> list[dict[str, Any]]:
    """The action components as the environment applies them (:meth:`SphereEnv.action_layout`)."""
    return [
        {
            "index": 0,
            "name": "steer",
            "range": [-1.0, 1.0],
            "torque_limit_nm": float(steer_torque_limit_nm),
            "joint": "steer",
            "joint_torque_sign": 1.0,
            "meaning": "steer motor torque / limit; +1 leans the pendulum toward +θ (URDF steer axis +x_PC), "
            "which turns the robot left (heading ψ increases)",
        },
        {
            "index": 1,
            "name": "drive",
            "range": [-1.0, 1.0],
            "torque_limit_nm": float(drive_torque_limit_nm),
            "joint": "drive",
            "joint_torque_sign": -1.0,
            "meaning": "drive motor torque / limit; +1 drives forward (ω_d > 0); the URDF drive axis is −y_PC, "
            "so the joint torque is −a · limit",
        },
    ]
