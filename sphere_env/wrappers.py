"""Gymnasium wrappers for training on the sphere_env tasks.

``ShellModelMixture`` trains one policy across shell contact models: each episode runs on a shell
model drawn from a list, so a policy cannot overfit one model's rolling resistance (the three
models differ most there; see ``evaluation/results/command_span.md``).

``PDResidualAction`` turns a task into residual control over the tuned PD baseline (residual
reinforcement learning: Johannink et al., ICRA 2019; Silver et al., 2018): the agent's action is a
correction added to the PD's action, so learning starts from a controller that already works and only
has to improve on it. It is named in a hyperparameter file the way rl-zoo3 names wrappers::

    env_wrapper:
      - sphere_env.wrappers.PDResidualAction: {scale: 0.5}

A policy trained this way acts on the robot only together with the same PD: evaluation applies the
same combination (:class:`ResidualCombiner`), and ``sphere-env export`` writes the network and the
PD as one graph whose inputs include the PD's state (:mod:`sphere_env.controllers_torch`).
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Mapping, Sequence

import gymnasium as gym
import numpy as np
from pydantic import Field

from sphere_env.envs.kwargs import ResidualKwargs, ShellModelMixtureKwargs
from sphere_env.schemas import allowed, checker, validate


class ResidualCombiner:
    """Applied action = clip(base(obs, info) + ``scale`` · clip(residual, −1, 1), −1, 1).

    :param base: a controller ``(obs, info) -> action`` with ``reset()`` (e.g. the PD baseline).
    :param scale: weight of the residual, in (0, 2] (1: the residual alone can reach the torque
        limits).
    """

    def __init__(self, base: Any, scale: float):
        self.base = base
        self.scale = validate(ResidualKwargs, {"scale": scale}, "ResidualCombiner").scale
        self.base_action = np.zeros(2, dtype=np.float32)  # the base controller's last action

    def reset(self) -> None:
        self.base.reset()

    def __call__(self, obs, info: Mapping[str, Any] | None, residual) -> np.ndarray:
        """The applied action for this step (calls the stateful base controller once)."""
        r = np.clip(np.asarray(residual, dtype=np.float64).reshape(-1), -1.0, 1.0)
        self.base_action = np.asarray(self.base(obs, info), dtype=np.float32)
        a = self.base_action.astype(np.float64) + self.scale * r
        return np.clip(a, -1.0, 1.0).astype(np.float32)


def pd_residual_combiner(env: gym.Env, scale: float = 0.5) -> ResidualCombiner:
    """The combination :class:`PDResidualAction` applies to ``env``: its PD baseline preset
    (:func:`sphere_env.controllers.controller_for`) plus ``scale`` × the residual."""
    from sphere_env.controllers import controller_for

    return ResidualCombiner(controller_for(env, "pd"), scale)


class PDResidualAction(gym.Wrapper):
    """Residual control over the task's PD baseline.

    The action space stays ``Box(-1, 1, (2,))`` ([steer, drive], normalized as the task's): the
    action is a residual, scaled by ``scale`` and added to the PD's action; the sum is clipped to the
    torque limits. With a zero residual the episode is exactly the PD's. ``info`` gains
    ``base_action`` (the PD's) and ``applied_action`` (what the robot received), both normalized.

    :param env: a sphere_env task env with a PD preset (RampDescent, Roll).
    :param scale: weight of the residual, in (0, 2].
    """

    def __init__(self, env: gym.Env, scale: float = 0.5):
        self.combiner = pd_residual_combiner(env, scale)
        super().__init__(env)
        self._obs: Any = None
        self._info: dict[str, Any] = {}

    @property
    def scale(self) -> float:
        return self.combiner.scale

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        self.combiner.reset()
        self._obs, self._info = self.env.reset(seed=seed, options=options)
        return self._obs, self._info

    def step(self, action):
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape != (2,) or not all(math.isfinite(x) for x in a):
            raise ValueError(f"action: value {action!r} must be 2 finite numbers [steer, drive] in [-1, 1]")
        if self._obs is None:
            raise gym.error.ResetNeeded("PDResidualAction: call reset() before step()")
        applied = self.combiner(self._obs, self._info, a)
        obs, reward, terminated, truncated, info = self.env.step(applied)
        info["base_action"] = self.combiner.base_action
        info["applied_action"] = applied
        self._obs, self._info = obs, info
        return obs, reward, terminated, truncated, info


class ShellModelMixture(gym.Wrapper):
    """Each episode on a shell model drawn uniformly from ``shell_models``.

    The shell model is also an ordinary randomizable parameter: ``randomization={"shell_model":
    [...], ...}`` draws it per episode in one env (its twins built on first use), reported like
    every parameter in ``info["params"]``. This wrapper stays because recipes of the learning study
    were trained with it (its draws come from its own generator, so changing it would change them).

    Holds one env per shell model, built like the wrapped one (same id and ``gym.make`` kwargs but
    ``shell_model``); ``reset`` draws the model from the wrapper's generator (seeded by
    ``reset(seed=...)``, which also seeds every held env) and delegates to that env. Spaces are the
    same for all models. ``set_randomization`` reaches every held env. ``info["shell_model"]`` says
    which model ran. Wrappers applied inside it (rl-zoo3 puts its ``Monitor`` there) see only the
    episodes of the wrapped env's own model; this project's trainer wraps the mixture, so its
    monitor files log every episode.

    :param env: a sphere_env env made by ``gymnasium.make``; its own shell model must be one of
        ``shell_models``.
    :param shell_models: distinct names from ``point``, ``injected``, ``hydroelastic``.
    """

    def __init__(self, env: gym.Env, shell_models: Sequence[str] = ("point", "injected")):
        models = validate(ShellModelMixtureKwargs, {"shell_models": shell_models}, "ShellModelMixture").shell_models
        # the wrapped env's own shell model is one of the mixture's
        own = checker(
            Annotated[
                Literal[tuple(models)],
                Field(
                    json_schema_extra=allowed(  # type: ignore[valid-type]
                        f"one of shell_models {list(models)}"
                    )
                ),
            ]
        )(env.unwrapped.shell_model, "ShellModelMixture: the env's shell_model")
        if env.spec is None:
            raise ValueError(
                "env: ShellModelMixture needs an env made by gymnasium.make (it builds its siblings "
                "from the env's spec)"
            )
        super().__init__(env)
        self.shell_models = models
        self.envs = {own: env}
        for m in models:
            if m not in self.envs:
                self.envs[m] = gym.make(env.spec.id, **{**env.spec.kwargs, "shell_model": m})
        self._rng = np.random.default_rng()

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        if seed is not None:
            seeds = np.random.SeedSequence(seed).spawn(len(self.envs) + 1)
            self._rng = np.random.default_rng(seeds[0])
            for child, held in zip(seeds[1:], self.envs.values()):
                held.reset(seed=int(child.generate_state(1)[0]))
        self.env = self.envs[self.shell_models[int(self._rng.integers(len(self.shell_models)))]]
        return self.env.reset(options=options)

    @property
    def randomization(self) -> Any:
        """The randomization spec in force (the same in every held env); assigning to it is
        :meth:`set_randomization`."""
        return self.env.unwrapped.randomization

    @randomization.setter
    def randomization(self, spec: Any) -> None:
        self.set_randomization(spec)

    def set_randomization(self, spec: Any) -> None:
        """``SphereEnv.set_randomization`` on every held env; if one refuses ``spec`` (a ValueError
        naming the field), the others get their previous spec back, so nothing changes."""
        before = [(held.unwrapped, held.unwrapped.randomization) for held in self.envs.values()]
        try:
            for held, _ in before:
                held.set_randomization(spec)
        except ValueError:
            for held, old in before:
                held.set_randomization(old)
            raise

    def close(self) -> None:
        for held in self.envs.values():
            held.close()


#: Wrappers a training run may name (``env_wrapper``) whose action combination evaluation can
#: reproduce on the bare env: class path -> builder of the combiner (env, **kwargs).
ACTION_COMBINERS = {"sphere_env.wrappers.PDResidualAction": pd_residual_combiner}
#: Wrappers that only choose which episodes a run trains on: evaluation needs nothing of them.
TRAINING_ONLY_WRAPPERS = ("sphere_env.wrappers.ShellModelMixture",)
