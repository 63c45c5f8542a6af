"""Policies beyond SB3's own: an asymmetric actor-critic whose critic sees privileged observations.

Training on a mixture of shell models and pressures, the value of a state depends on the shell and
the pressure the actor cannot know (a real robot does not observe them). With a symmetric critic the
value of the same observation is the average over the mixture, and the advantages of each shell's
episodes are biased by the others'. :class:`AsymmetricActorCriticPolicy` gives the critic the env's
privileged components (``observe_pressure``, ``observe_shell_model``: the trailing
``observation_layout.privileged`` slice) and zeroes them for the actor, so the deployed policy is a
function of the robot's own measurements only (the asymmetric actor-critic of Pinto et al., 2018).

Registered with PPO under the name ``AsymmetricMlpPolicy`` on import of
:mod:`sphere_env.training`, so a hyperparameter file says ``policy: AsymmetricMlpPolicy`` with
``policy_kwargs: {privileged_dims: 4}``.
"""

from __future__ import annotations

from typing import Annotated, Any

import gymnasium as gym
import torch as th
from pydantic import Field
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

from sphere_env.schemas import Finite, allowed, checker, count, fixed_tuple


class DropPrivileged(BaseFeaturesExtractor):
    """The flat observation with its last ``privileged_dims`` components set to zero (same size, so
    the actor and critic networks share one input width)."""

    def __init__(self, observation_space: gym.spaces.Box, privileged_dims: int = 0):
        n = int(observation_space.shape[0])
        super().__init__(observation_space, n)
        mask = th.ones(n)
        if privileged_dims:
            mask[n - privileged_dims :] = 0.0
        self.register_buffer("mask", mask)

    def forward(self, observations: th.Tensor) -> th.Tensor:
        return th.flatten(observations, start_dim=1) * self.mask


class AsymmetricActorCriticPolicy(ActorCriticPolicy):
    """:class:`~stable_baselines3.common.policies.ActorCriticPolicy` whose actor ignores the last
    ``privileged_dims`` observation components and whose critic sees all of them.

    :param privileged_dims: number of trailing privileged components (pressure: 1, shell one-hot: 3),
        between 0 and the observation size.
    :param log_std_init: initial log standard deviation of the Gaussian actions: one number, or one
        per action component (e.g. less exploration noise on the steer torque than on the drive).
    """

    def __init__(
        self,
        observation_space: gym.spaces.Box,
        action_space: gym.spaces.Space,
        lr_schedule: Any,
        *args: Any,
        privileged_dims: int = 0,
        log_std_init: float | list[float] = 0.0,
        **kwargs: Any,
    ):
        n, n_actions = int(observation_space.shape[0]), int(action_space.shape[0])
        log_std_init = checker(
            Annotated[
                Finite | fixed_tuple(Finite, n_actions, ""),
                Field(json_schema_extra=allowed(f"a finite number, or {n_actions} (one per action component)")),
            ]
        )(log_std_init, "policy_kwargs.log_std_init")
        per_action = list(log_std_init) if isinstance(log_std_init, tuple) else None
        self._log_std_per_action = per_action
        kwargs["log_std_init"] = 0.0 if per_action is not None else log_std_init
        # the actor keeps at least one component of the observation
        self.privileged_dims = checker(count(0, n - 1))(privileged_dims, "policy_kwargs.privileged_dims")
        kwargs["share_features_extractor"] = False
        super().__init__(observation_space, action_space, lr_schedule, *args, **kwargs)
        if per_action is not None:
            with th.no_grad():
                self.log_std.copy_(th.tensor(per_action, dtype=self.log_std.dtype))

    def make_features_extractor(self) -> BaseFeaturesExtractor:
        # ActorCriticPolicy builds the actor's extractor first (features_extractor, then
        # pi_features_extractor = it) and the critic's second (vf_features_extractor).
        if getattr(self, "_actor_extractor_built", False):
            return super().make_features_extractor()
        self._actor_extractor_built = True
        return DropPrivileged(self.observation_space, self.privileged_dims)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data["privileged_dims"] = self.privileged_dims
        if self._log_std_per_action is not None:
            data["log_std_init"] = self._log_std_per_action
        data.pop("share_features_extractor", None)
        return data


def register() -> None:
    """Make ``AsymmetricMlpPolicy`` a policy name of PPO (as ``MlpPolicy`` is)."""
    from stable_baselines3 import PPO

    PPO.policy_aliases.setdefault("AsymmetricMlpPolicy", AsymmetricActorCriticPolicy)
