"""Factories of the registered environments: each joins a task with the generic :class:`SphereEnv`.

Gymnasium calls these with the kwargs of ``gym.make(id, **kwargs)``. Each kwarg goes by its name
to the task (the fields of its schema, documented with the spaces, rewards and episode end on the
task class) or to :class:`SphereEnv`, and each value is checked once, by the schema of the
constructor it goes to. A name neither takes is refused first, naming every kwarg of the id (the
fields of :class:`~sphere_env.envs.kwargs.RampDescentEnvKwargs`,
:class:`~sphere_env.envs.kwargs.RollEnvKwargs`), before anything is built.
"""

from __future__ import annotations

from typing import Any

from sphere_env.envs.env import SphereEnv
from sphere_env.envs.kwargs import RampDescentEnvKwargs, RollEnvKwargs
from sphere_env.schemas import Schema, keys
from sphere_env.tasks.ramp_descent import RampDescentKwargs, RampDescentTask
from sphere_env.tasks.roll import RollKwargs, RollTask


def _split(
    schema: type[Schema], task_schema: type[Schema], name: str, kwargs: dict[str, Any]
) -> tuple[dict[str, Any], dict[str, Any]]:
    """(task kwargs, env kwargs) of ``kwargs`` by name (the task's are the fields of
    ``task_schema``); a name that is no field of ``schema`` (the id's) is a ``ValueError`` naming
    it and every allowed one. The values pass on as given: each constructor checks its own, and a
    copy of the env (pickle) is rebuilt from them."""
    allowed = keys(schema)
    unknown = next((k for k in kwargs if k not in allowed), None)
    if unknown is not None:
        raise ValueError(f"{name} kwargs: unknown field {unknown!r}; allowed: {sorted(allowed)}")
    names = task_schema.model_fields
    return {k: v for k, v in kwargs.items() if k in names}, {k: v for k, v in kwargs.items() if k not in names}


def make_ramp_descent(*, incline_deg: float = 8.0, ramp_length_m: float = 6.0, **kwargs: Any) -> SphereEnv:
    """``sphere_env/RampDescent-v2``: :class:`~sphere_env.tasks.RampDescentTask` on an 8° ramp of
    6 m by default, plus :class:`SphereEnv`'s kwargs. The superseded ``-v1``/``-v0`` are registered
    with the paper's 16° ramp of 4 m and their task settings (:data:`sphere_env.ENV_IDS`)."""
    kwargs = {"incline_deg": incline_deg, "ramp_length_m": ramp_length_m, **kwargs}
    task_kw, env_kw = _split(RampDescentEnvKwargs, RampDescentKwargs, RampDescentTask.name, kwargs)
    return SphereEnv(RampDescentTask(**task_kw), **env_kw)


def make_roll(**kwargs: Any) -> SphereEnv:
    """``sphere_env/Roll-v1`` (and ``-v0``): :class:`~sphere_env.tasks.RollTask` on flat ground,
    plus :class:`SphereEnv`'s kwargs."""
    task_kw, env_kw = _split(RollEnvKwargs, RollKwargs, RollTask.name, kwargs)
    return SphereEnv(RollTask(**task_kw), **env_kw)
