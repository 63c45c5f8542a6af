"""The reward schedule: the training envs' reward weights change at the given step and not before,
the env's reward follows its new weights, and weights the env's reward does not take are refused by
name before training."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3 import PPO
from stable_baselines3.common.logger import configure
from stable_baselines3.common.vec_env import DummyVecEnv

from sphere_env.training.config import resolve_config
from sphere_env.training.schedules import RewardSchedule
from tests.conftest import TINY_PPO

RAMP = "sphere_env/RampDescent-v3"
SCHEDULE = "sphere_env.training.schedules.RewardSchedule"


def _speed_terms(env, width):
    env.unwrapped.set_reward_weights({"speed_width": width})
    env.reset(seed=3)
    return np.array([env.step(np.array([0.0, 0.3]))[4]["reward_speed"] for _ in range(20)])


def test_the_reward_follows_weights_set_between_episodes():
    """The same seeded episode and actions under speed widths of 1.0 and then 0.5 rad/s: the narrower
    gaussian pays less wherever the speed error is not zero, and a refused change changes nothing."""
    env = gym.make(RAMP, randomization="off", max_episode_steps=50)
    wide, narrow = _speed_terms(env, 1.0), _speed_terms(env, 0.5)
    assert np.all(narrow <= wide + 1e-12) and np.any(narrow < 0.9 * wide)
    assert env.unwrapped.task.reward_weights.speed_width == 0.5
    with pytest.raises(ValueError, match="field 'reward_weights.speed_width'"):
        env.unwrapped.set_reward_weights({"speed_width": 0.0})
    assert env.unwrapped.task.reward_weights.speed_width == 0.5  # a refused change changes nothing


def _weights_after(total_steps, schedule, already=0):
    envs = DummyVecEnv([lambda: gym.make(RAMP, randomization="off", max_episode_steps=10) for _ in range(2)])
    model = PPO("MlpPolicy", envs, n_steps=16, batch_size=32, n_epochs=1, device="cpu")
    model.set_logger(configure(None, []))
    if already:
        model.learn(already)
    model.learn(total_steps, callback=schedule, reset_num_timesteps=not already)
    widths = [w.speed_width for w in envs.env_method("set_reward_weights", {})]
    envs.close()
    return widths


def test_the_weights_change_at_the_given_step_and_not_before():
    assert _weights_after(64, RewardSchedule(1e6, {"speed_width": 0.5})) == [1.0, 1.0]
    assert _weights_after(64, RewardSchedule(32, {"speed_width": 0.5})) == [0.5, 0.5]
    # a run continued past the step gets the change too
    assert _weights_after(32, RewardSchedule(16, {"speed_width": 0.25}), already=64) == [0.25, 0.25]


@pytest.mark.parametrize(
    "kwargs, needle",
    [
        ({"at_steps": 1e5, "reward_weights": {"nope": 1.0}}, "reward_weights.nope"),
        ({"at_steps": 1e5, "reward_weights": {"speed_width": -1.0}}, "reward_weights.speed_width"),
        ({"at_steps": -1, "reward_weights": {"speed_width": 0.5}}, "field 'at_steps'"),
        ({"at_steps": 1e5, "reward_weights": {}}, "field 'reward_weights'"),
    ],
)
def test_a_schedule_it_cannot_run_is_refused_by_name_before_training(kwargs, needle):
    over = {**TINY_PPO, "callback": [{SCHEDULE: kwargs}]}
    with pytest.raises(ValueError, match="callback") as err:
        resolve_config(RAMP, "ppo", overrides=over, eval_freq=0)
    assert needle in str(err.value)
