"""Training schedules: a change of the task's reward at a given step of one training run.

:class:`RewardSchedule` is an SB3 callback, named in a hyperparameter section as rl-zoo3 names
callbacks::

    callback:
      - sphere_env.training.schedules.RewardSchedule:
          at_steps: 1000000  # YAML reads 1e6 as a string
          reward_weights: {speed_width: 0.5}

From the first step at or after ``at_steps`` environment steps, every training env's reward
weights are ``reward_weights`` applied over its own (``set_reward_weights`` through the vector
env); evaluation envs keep theirs. A run resumed past ``at_steps`` gets the change before its
first step.

Why: the speed term's gaussian of width 1 rad/s pays for coming near the command at all (at
1.5 rad/s off a width of 0.5 pays 1 % of the weight), and a width of 0.5 pulls 2.7 times harder at
the 0.5 rad/s tracking tolerance, where the failed grid episodes of the earlier recipes sat. The
recipe `curriculum_tight` ran the two widths as two phases (a continuation from a checkpoint); this
callback runs them in one run from one command.
"""

from __future__ import annotations

from typing import Any, Mapping

from pydantic import Field
from stable_baselines3.common.callbacks import BaseCallback

from sphere_env.schemas import Schema, allowed, number, validate


class RewardScheduleArgs(Schema):
    """The keyword arguments of :class:`RewardSchedule`."""

    at_steps: number(ge=0.0, le=1e12)
    reward_weights: dict[str, Any] = Field(
        min_length=1, json_schema_extra=allowed("a non-empty mapping term -> weight of the env's reward")
    )


class RewardSchedule(BaseCallback):
    """Set the training envs' reward weights at ``at_steps`` environment steps (module docstring);
    a bad value is refused by name on construction, a weight the env's reward does not take by
    :meth:`check_env` before training."""

    def __init__(self, at_steps: float, reward_weights: Mapping[str, Any], verbose: int = 0):
        super().__init__(verbose)
        args = validate(
            RewardScheduleArgs,
            {"at_steps": at_steps, "reward_weights": reward_weights},
            "callback RewardSchedule",
        )
        self.at_steps = int(args.at_steps)
        self.reward_weights = dict(args.reward_weights)
        self.applied = False

    def check_env(self, env: Any, n_envs: int) -> None:
        """Refuse, before training, weights the env's reward does not take (``ValueError`` naming
        the field); the env keeps its own weights."""
        try:
            env.task.reward_weights_with(self.reward_weights)
        except ValueError as err:
            raise ValueError(f"callback RewardSchedule: {err}") from None

    def _apply_when_due(self) -> None:
        if not self.applied and self.num_timesteps >= self.at_steps:
            self.training_env.env_method("set_reward_weights", self.reward_weights)
            self.applied = True
            self.logger.record("schedule/reward_weights_changed_at_steps", self.num_timesteps)

    def _on_training_start(self) -> None:
        self._apply_when_due()

    def _on_step(self) -> bool:
        self._apply_when_due()
        return True
