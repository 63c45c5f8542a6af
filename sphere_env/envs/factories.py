"""Factories of the registered environments: each joins a task with the generic :class:`SphereEnv`.

Gymnasium calls these with the kwargs of ``gym.make(id, **kwargs)``: the task's own keyword
arguments (its constructor's, documented with the spaces, rewards and episode end on the task
class) go to the task, every other one to :class:`SphereEnv`.
"""

from __future__ import annotations

import inspect
from typing import Any

from sphere_env.envs.env import SphereEnv
from sphere_env.tasks.ramp_descent import RampDescentTask
from sphere_env.tasks.roll import RollTask


def _split(task_cls: type, kwargs: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """(task kwargs, env kwargs): the names of ``task_cls``'s constructor go to the task."""
    names = set(inspect.signature(task_cls.__init__).parameters) - {"self"}
    return {k: v for k, v in kwargs.items() if k in names}, {k: v for k, v in kwargs.items() if k not in names}


def make_ramp_descent(*, incline_deg: float = 8.0, ramp_length_m: float = 6.0, **kwargs: Any) -> SphereEnv:
    """``sphere_env/RampDescent-v2``: :class:`~sphere_env.tasks.RampDescentTask` on an 8° ramp of
    6 m by default, plus :class:`SphereEnv`'s kwargs. The superseded ``-v1``/``-v0`` are registered
    with the paper's 16° ramp of 4 m and their task settings (:data:`sphere_env.ENV_IDS`)."""
    if ramp_length_m is None:
        raise ValueError("ramp_length_m: value None not allowed for RampDescent; give a length in m")
    task_kw, env_kw = _split(RampDescentTask, kwargs)
    return SphereEnv(RampDescentTask(**task_kw), incline_deg=incline_deg, ramp_length_m=ramp_length_m, **env_kw)


def make_roll(**kwargs: Any) -> SphereEnv:
    """``sphere_env/Roll-v1`` (and ``-v0``): :class:`~sphere_env.tasks.RollTask` on flat ground,
    plus :class:`SphereEnv`'s kwargs."""
    if kwargs.get("ramp_length_m") is not None:
        raise ValueError("ramp_length_m: not used by Roll (flat ground); leave it None")
    task_kw, env_kw = _split(RollTask, kwargs)
    return SphereEnv(RollTask(**task_kw), **env_kw)
