"""A bad ``env_method`` or ``set_attr`` through a vector env raises in the caller; the workers stay
alive, their envs unchanged, and the vector env keeps stepping (every layout the trainer builds)."""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest
from stable_baselines3.common.vec_env import DummyVecEnv

from sphere_env.training.env_factory import make_env
from sphere_env.training.vec_env import BatchedSubprocVecEnv, SafeSubprocVecEnv, ThreadedVecEnv
from tests.conftest import TINY_PPO

KW = {"shell_model": "point", "randomization": {"pressure_kpa": {"distribution": "uniform"}}}


def _fns(n):
    return [partial(make_env, "sphere_env/RampDescent-v2", KW, seed=i) for i in range(n)]


LAYOUTS = {
    "blocks": lambda: BatchedSubprocVecEnv(_fns(4), n_workers=2),
    "one env per worker": lambda: BatchedSubprocVecEnv(_fns(3), n_workers=3),
    "threads": lambda: ThreadedVecEnv(_fns(4), n_threads=2),
    "dummy": lambda: DummyVecEnv(_fns(2)),
    "one process per env (SB3's SubprocVecEnv)": lambda: SafeSubprocVecEnv(_fns(2)),
}


@pytest.mark.parametrize("layout", list(LAYOUTS))
def test_bad_calls_raise_in_the_caller_and_leave_the_envs_working(layout):
    venv = LAYOUTS[layout]()
    try:
        before = venv.get_attr("randomization")
        with pytest.raises(ValueError, match="pressure_kpa"):
            venv.env_method("set_randomization", {"pressure_kpa": [1.0, 99.0]})
        with pytest.raises(ValueError):
            venv.set_attr("randomization", {"no_such_parameter": 1.0})
        with pytest.raises(AttributeError):
            venv.env_method("no_such_method")
        assert venv.get_attr("randomization") == before  # unchanged
        venv.env_method("set_randomization", {"pressure_kpa": 7.0})  # a good call still works
        venv.seed(0)
        venv.reset()
        for _ in range(3):
            obs, *_ = venv.step(np.zeros((venv.num_envs, 2), dtype=np.float32))
        assert np.isfinite(obs).all()
    finally:
        venv.close()


def test_training_with_one_process_per_env_runs_on_the_safe_layout(tmp_path):
    from sphere_env.training.config import resolve_config
    from sphere_env.training.env_factory import make_vec_env
    from sphere_env.training.trainer import train

    over = {
        **TINY_PPO,
        "n_envs": 2,
        "n_workers": None,
        "n_timesteps": 64,
        "env_kwargs": {"shell_model": "point"},
    }
    cfg = resolve_config("sphere_env/RampDescent-v0", "ppo", overrides=over, eval_freq=0, checkpoint_freq=0)
    venv = make_vec_env(cfg, None)
    try:
        assert isinstance(venv, SafeSubprocVecEnv)
    finally:
        venv.close()
    run = train(cfg, tmp_path / "run", progress_bar=False)
    assert (run / "model.zip").exists() and len(list((run / "monitor").glob("train_*.monitor.csv"))) == 2
