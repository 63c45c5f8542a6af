"""The asymmetric actor-critic: the actor ignores the privileged components, the critic reads them,
and a saved model keeps both (and per-action exploration noise)."""

import gymnasium as gym
import numpy as np
import pytest
import torch

import sphere_env  # noqa: F401
from sphere_env.training.config import algo_class
from sphere_env.wrappers import ShellModelMixture

PPO = algo_class("ppo")


@pytest.fixture(scope="module")
def env():
    e = gym.make("sphere_env/RampDescent-v3", observe_pressure=True, observe_shell_model=True, shell_model="point")
    yield e
    e.close()


def test_privileged_components_are_the_trailing_pressure_and_shell_one_hot(env):
    lay = env.unwrapped.observation_layout
    assert lay.names[lay.privileged] == ("pressure_kpa", "shell_point", "shell_injected", "shell_hydroelastic")
    obs, info = env.reset(seed=0, options={"pressure_kpa": 7.0})
    np.testing.assert_allclose(obs[lay.privileged], [7.0, 1.0, 0.0, 0.0], rtol=1e-6)


def test_the_one_hot_follows_the_shell_of_each_mixture_episode():
    base = gym.make("sphere_env/RampDescent-v3", observe_shell_model=True, shell_model="injected")
    mix = ShellModelMixture(base, ["injected", "point"])
    seen = set()
    for k in range(8):
        obs, _ = mix.reset(seed=k)
        _, _, _, _, info = mix.step(np.zeros(2, dtype=np.float32))
        one_hot = tuple(obs[-3:])
        assert one_hot == tuple(float(m == info["shell_model"]) for m in ("point", "injected", "hydroelastic"))
        seen.add(info["shell_model"])
    assert seen == {"point", "injected"}
    mix.close()


def test_actor_ignores_and_critic_reads_the_privileged_components(env, tmp_path):
    model = PPO(
        "AsymmetricMlpPolicy",
        env,
        n_steps=64,
        batch_size=64,
        seed=0,
        policy_kwargs=dict(privileged_dims=4, net_arch=[32, 32], log_std_init=[-3.0, -2.0]),
    )
    model.learn(128)  # the critic's weights on the privileged inputs move away from their start
    obs, _ = env.reset(seed=1)
    x = torch.as_tensor(obs[None])
    y = x.clone()
    y[0, -4:] = torch.tensor([13.0, 0.0, 1.0, 0.0])
    pol = model.policy
    with torch.no_grad():
        assert torch.equal(pol.get_distribution(x).distribution.mean, pol.get_distribution(y).distribution.mean)
        assert not torch.equal(pol.predict_values(x), pol.predict_values(y))
    model.save(tmp_path / "m.zip")
    loaded = PPO.load(tmp_path / "m.zip")
    assert loaded.policy.privileged_dims == 4
    with torch.no_grad():
        np.testing.assert_array_equal(loaded.policy.log_std.numpy(), pol.log_std.numpy())
        assert torch.equal(
            loaded.policy.get_distribution(x).distribution.mean, pol.get_distribution(x).distribution.mean
        )


def test_initial_exploration_noise_per_action_component(env):
    model = PPO(
        "AsymmetricMlpPolicy",
        env,
        n_steps=64,
        batch_size=64,
        seed=0,
        policy_kwargs=dict(privileged_dims=4, log_std_init=[-3.0, -2.0]),
    )
    np.testing.assert_allclose(model.policy.log_std.detach().numpy(), [-3.0, -2.0])


@pytest.mark.parametrize("bad", [-1, 22, 2.5, True])
def test_bad_privileged_dims_name_the_field(env, bad):
    with pytest.raises(ValueError, match="privileged_dims"):
        PPO("AsymmetricMlpPolicy", env, policy_kwargs=dict(privileged_dims=bad))


@pytest.mark.parametrize("bad", [[-3.0, -2.0, -1.0], "x", float("nan")])
def test_bad_log_std_init_names_the_field_and_the_action_size(env, bad):
    with pytest.raises(
        ValueError,
        match=r"^policy_kwargs.log_std_init = .*; allowed: a finite number, or 2 \(one per "
        r"action component\)$",
    ):
        PPO("AsymmetricMlpPolicy", env, policy_kwargs=dict(privileged_dims=4, log_std_init=bad))
