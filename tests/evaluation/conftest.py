"""Tiny trained runs shared by the enjoy, video and export tests (trained with the repository's own
training code, a few hundred steps: the policies are poor, their plumbing is what is tested)."""

from __future__ import annotations

import pytest

TINY = {
    "ppo": {"n_envs": 1, "n_steps": 64, "batch_size": 64, "n_epochs": 1, "n_timesteps": 128},
    "sac": {
        "n_envs": 1,
        "learning_starts": 32,
        "buffer_size": 1000,
        "batch_size": 32,
        "train_freq": 8,
        "gradient_steps": 1,
        "policy_kwargs": {"net_arch": [32, 32]},
        "n_timesteps": 96,
    },
}


def tiny_run(tmp_path_factory, algo: str):
    from sphere_env.training.config import resolve_config
    from sphere_env.training.train import train

    cfg = resolve_config(
        "sphere_env/RampDescent-v2",
        algo,
        overrides={**TINY[algo], "env_kwargs": {"shell_model": "point"}},
        eval_episodes=1,
    )
    return train(cfg, tmp_path_factory.mktemp(f"tiny_{algo}") / "run", progress_bar=False)


@pytest.fixture(scope="session")
def tiny_ppo_run(tmp_path_factory):
    return tiny_run(tmp_path_factory, "ppo")


@pytest.fixture(scope="session")
def tiny_sac_run(tmp_path_factory):
    return tiny_run(tmp_path_factory, "sac")


@pytest.fixture(scope="session")
def tiny_recipe_run(tmp_path_factory):
    """A few hundred steps of the shipped RampDescent-v3 recipe: shell mixture, asymmetric critic."""
    from sphere_env.training.config import resolve_config
    from sphere_env.training.train import train

    cfg = resolve_config("sphere_env/RampDescent-v3", "ppo", overrides={**TINY["ppo"], "n_workers": 1}, eval_episodes=1)
    return train(cfg, tmp_path_factory.mktemp("tiny_recipe") / "run", progress_bar=False)
