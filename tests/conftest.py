"""Shared test fixtures: the real robot logs, and the tiny training runs of the tests that train.

A tiny run checks plumbing (files, resume, refusals, export), not learning: :data:`TINY_PPO` is the
smallest PPO update the trainer accepts, and a test that trains adds its own budget, env kwargs or
layout over it.
"""

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
ROBOBALL = REPO.parent / "shared" / "data" / "roboball"

#: One env, one 32-step rollout per update, one epoch: the tiny PPO run of every test that trains.
TINY_PPO = {"n_envs": 1, "n_steps": 32, "batch_size": 32, "n_epochs": 1}
#: :data:`TINY_PPO` as ``key:value`` items of ``--hyperparams`` / ``--params`` (the command lines).
TINY_PPO_PARAMS = [f"{k}:{v}" for k, v in TINY_PPO.items()]
#: The wrapper of the residual runs (residual control over the PD baseline).
RESIDUAL_WRAPPER = "sphere_env.wrappers.PDResidualAction"
#: The tiny SAC run (a small buffer and network, a few gradient steps).
TINY_SAC = {
    "n_envs": 1,
    "learning_starts": 32,
    "buffer_size": 1000,
    "batch_size": 32,
    "train_freq": 8,
    "gradient_steps": 1,
    "policy_kwargs": {"net_arch": [32, 32]},
}


@pytest.fixture
def make():
    """``make(env_id, **kwargs)``: ``gym.make``, every env made closed after the test."""
    import gymnasium as gym

    import sphere_env  # noqa: F401  (registers the ids)

    envs = []

    def _make(env_id, **kw):
        env = gym.make(env_id, **kw)
        envs.append(env)
        return env

    yield _make
    for env in envs:
        env.close()


@pytest.fixture(scope="session")
def roboball_dir() -> Path:
    """The real robot logs, read from ../shared (never copied into the repo)."""
    if not ROBOBALL.is_dir():
        pytest.skip(f"real robot logs not found at {ROBOBALL}")
    return ROBOBALL


def _train(tmp_path_factory, name: str, env_id: str, algo: str, overrides: dict) -> Path:
    from sphere_env.training.config import resolve_config
    from sphere_env.training.trainer import train

    cfg = resolve_config(env_id, algo, overrides=overrides, eval_episodes=1)
    return train(cfg, tmp_path_factory.mktemp(name) / "run", progress_bar=False)


@pytest.fixture(scope="session")
def tiny_ppo_run(tmp_path_factory) -> Path:
    """A tiny PPO run folder on RampDescent-v2, point shell (model, statistics, checkpoints)."""
    over = {**TINY_PPO, "n_timesteps": 128, "env_kwargs": {"shell_model": "point"}}
    return _train(tmp_path_factory, "tiny_ppo", "sphere_env/RampDescent-v2", "ppo", over)


@pytest.fixture(scope="session")
def tiny_residual_run(tmp_path_factory) -> Path:
    """A tiny PPO run trained as residual control over the PD baseline (``PDResidualAction``,
    scale 0.5) on RampDescent-v2, point shell."""
    over = {
        **TINY_PPO,
        "n_timesteps": 256,
        "env_kwargs": {"shell_model": "point"},
        "env_wrapper": [{RESIDUAL_WRAPPER: {"scale": 0.5}}],
    }
    return _train(tmp_path_factory, "tiny_residual", "sphere_env/RampDescent-v2", "ppo", over)


@pytest.fixture(scope="session")
def tiny_sac_run(tmp_path_factory) -> Path:
    """A tiny SAC run folder on RampDescent-v2, point shell."""
    over = {**TINY_SAC, "n_timesteps": 96, "env_kwargs": {"shell_model": "point"}}
    return _train(tmp_path_factory, "tiny_sac", "sphere_env/RampDescent-v2", "sac", over)


@pytest.fixture(scope="session")
def tiny_recipe_run(tmp_path_factory) -> Path:
    """A tiny run of the shipped RampDescent-v3 recipe: shell mixture, asymmetric critic."""
    over = {**TINY_PPO, "n_timesteps": 128, "n_workers": 1}
    return _train(tmp_path_factory, "tiny_recipe", "sphere_env/RampDescent-v3", "ppo", over)
