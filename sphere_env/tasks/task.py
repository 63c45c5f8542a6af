"""The task interface (dm_control ``Task`` spirit): what an episode asks of the robot.

A :class:`Task` owns its command, its observation layout, its reward terms, its termination and
its default initial state. It sees only :class:`~sphere_env.physics.TwinState` snapshots (or
anything with the same attributes), plain numbers and the env's random generator; it never
touches Drake. :class:`~sphere_env.envs.SphereEnv` composes a twin and a task into a Gymnasium
environment.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from sphere_env.schemas import validate
from sphere_env.tasks.observation import ObservationLayout


@dataclass(frozen=True)
class Scene:
    """What a task may know about the world it runs in (plain numbers).

    :param control_period_s: policy period [s]; per-step reward terms scale with it.
    :param incline_deg: ground incline of this episode [deg].
    :param ramp_end_x_m: x_W where the ramp ends and the flat run-out starts [m]; ``inf`` without one.
    """

    control_period_s: float
    incline_deg: float
    ramp_end_x_m: float


class Task:
    """Base class. Subclasses set the class attributes and implement the methods.

    :cvar name: task name (``"RampDescent"``, ``"Roll"``).
    :cvar ramp: whether the task runs on a finite ramp (then the incline may be randomized).
    :cvar reward_terms: names of the reward terms (reported as ``info["reward_<term>"]``).
    :cvar command_names: command components appended to the measured observation.
    :cvar command_options: command values settable through ``reset(options=...)``.
    :cvar command_option_bounds: allowed [low, high] of each command option (unit in its docs);
        :func:`sphere_env.envs.kwargs.reset_options` turns them into the options' schema.
    :cvar extra_names: measured components observed after the command
        (:data:`~sphere_env.tasks.observation.EXTRA_COMPONENTS`).
    """

    name: str = "Task"
    ramp: bool = False
    reward_terms: tuple[str, ...] = ()
    command_names: tuple[str, ...] = ()
    command_options: tuple[str, ...] = ()
    command_option_bounds: Mapping[str, tuple[float, float]] = {}
    extra_names: tuple[str, ...] = ()

    # ---- layout ---------------------------------------------------------------------------------
    def observation_layout(
        self,
        observe_pressure: bool = False,
        observe_shell_model: bool = False,
        history_steps: int = 0,
        observe_params: tuple[str, ...] = (),
    ) -> ObservationLayout:
        """The observation's components in order: measured, then this task's command and extra
        measured components, then ``history_steps`` earlier observations and actions, then the
        privileged pressure and shell one-hot if observed."""
        return ObservationLayout(
            self.command_names, observe_pressure, self.extra_names, observe_shell_model, history_steps, observe_params
        )

    # ---- reward ---------------------------------------------------------------------------------
    def reward_weights_with(self, overrides: Mapping[str, Any]) -> Any:
        """The current reward weights with ``overrides`` (a mapping term -> weight, e.g.
        ``{"speed_width": 0.5}``) applied, validated like the ``reward_weights`` kwarg
        (``ValueError`` naming the field); the task keeps its own."""
        current = getattr(self, "reward_weights", None)
        if current is None:
            raise ValueError(f"reward_weights: the {self.name} task has no reward weights to set")
        if not isinstance(overrides, Mapping):
            raise ValueError(f"reward_weights: value {overrides!r} must be a mapping term -> weight")
        return validate(type(current), {**current.model_dump(), **dict(overrides)}, root="reward_weights")

    def set_reward_weights(self, overrides: Mapping[str, Any]) -> Any:
        """Apply ``overrides`` over the current reward weights (:meth:`reward_weights_with`); on a
        ``ValueError`` nothing changes. Returns the new weights."""
        self.reward_weights = self.reward_weights_with(overrides)
        return self.reward_weights

    # ---- episode --------------------------------------------------------------------------------
    def initial_state(self) -> dict[str, Any]:
        """Default initial state of an episode, as :class:`~sphere_env.physics.InitialState` fields
        (``{}``: at rest at the origin)."""
        return {}

    def reset(self, state: Any, rng: np.random.Generator, options: Mapping[str, Any], scene: Scene) -> None:
        """Start an episode from ``state``: draw the command (``options``, already loaded through
        the reset options' schema, may fix it)."""
        raise NotImplementedError

    def command(self, state: Any) -> list[float]:
        """The command part of the observation for ``state``."""
        raise NotImplementedError

    def step(
        self, state: Any, action: tuple[float, float], rng: np.random.Generator
    ) -> tuple[dict[str, float], bool, bool]:
        """After a control step: (reward terms, terminated, success)."""
        raise NotImplementedError

    def info(self) -> dict[str, Any]:
        """Task values for ``info`` (e.g. the current command)."""
        return {}
