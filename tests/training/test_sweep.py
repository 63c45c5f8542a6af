"""Sweeps: one run folder per trial, an aggregate learning curve with bootstrap intervals, and the
same results whether the trials run on Ray or locally one by one."""

from __future__ import annotations

import numpy as np
import pytest

from sphere_env.training.config import resolve_config
from sphere_env.training.sweep import aggregate_learning_curves, bootstrap_ci, run_sweep, trial_folders
from sphere_env.training.train import main
from tests.conftest import TINY_PPO

RAMP = "sphere_env/RampDescent-v2"
TINY = {**TINY_PPO, "n_timesteps": 256}


def _configs(seeds=(0, 1)):
    return [
        resolve_config(
            RAMP,
            "ppo",
            overrides=TINY,
            env_kwargs={"shell_model": "point"},
            seed=s,
            eval_freq=128,
            eval_episodes=2,
            checkpoint_freq=256,
        )
        for s in seeds
    ]


def _params(run):
    from stable_baselines3 import PPO

    return PPO.load(run / "model.zip", device="cpu").policy.state_dict()


def test_trial_folders_group_seeds_by_configuration():
    a = resolve_config(RAMP, "ppo", overrides=TINY, seed=0, build_env=False)
    b = resolve_config(RAMP, "ppo", overrides=TINY, seed=1, build_env=False)
    c = resolve_config(RAMP, "ppo", overrides={**TINY, "learning_rate": 1e-3}, seed=0, build_env=False)
    assert trial_folders([a, b, c]) == [(0, "config0_seed0"), (0, "config0_seed1"), (1, "config1_seed0")]
    with pytest.raises(ValueError, match="^seeds"):
        trial_folders([a, a])


def test_a_sweep_without_trials_is_refused(tmp_path):
    with pytest.raises(ValueError, match=r"^trials = \[\]: .*; allowed: at least one configuration"):
        run_sweep([], tmp_path / "sweep")
    assert not (tmp_path / "sweep").exists()


def test_bootstrap_interval_brackets_the_mean_and_needs_two_trials():
    vals = np.array([[1.0, 10.0], [2.0, 10.0], [3.0, 10.0], [6.0, 10.0]])
    low, high = bootstrap_ci(vals)
    assert low[0] < vals[:, 0].mean() < high[0] and low[1] == high[1] == 10.0
    assert np.isnan(bootstrap_ci(vals[:1])[0]).all()


@pytest.mark.slow
def test_ray_sweep_equals_trials_run_locally_one_by_one(tmp_path):
    pytest.importorskip("ray")
    local = run_sweep(_configs(), tmp_path / "local")
    on_ray = run_sweep(_configs(), tmp_path / "ray", ray_address="local", ray_cpus=1)
    for name in ("config0_seed0", "config0_seed1"):
        assert (local / name / "learning_curve.csv").read_bytes() == (on_ray / name / "learning_curve.csv").read_bytes()
        pa, pb = _params(local / name), _params(on_ray / name)
        assert all(np.array_equal(pa[k].numpy(), pb[k].numpy()) for k in pa)
    assert not all(
        np.array_equal(x.numpy(), y.numpy())
        for x, y in zip(_params(local / "config0_seed0").values(), _params(local / "config0_seed1").values())
    )
    agg = (local / "learning_curve_aggregate.csv").read_text()
    assert agg == (on_ray / "learning_curve_aggregate.csv").read_text()
    import pandas as pd

    df = pd.read_csv(local / "learning_curve_aggregate.csv")
    assert df["timesteps"].tolist() == [128, 256] and (df["n_trials"] == 2).all()
    assert (df["return_ci_low"] <= df["return_mean"]).all() and (df["return_mean"] <= df["return_ci_high"]).all()
    assert (on_ray / "learning_curve_aggregate.png").exists()


def test_sweep_refuses_bad_trials_before_any_folder(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(
            [
                "--env",
                RAMP,
                "--seeds",
                "0",
                "1",
                "--trial",
                "learning_rate:-1",
                "--run-dir",
                str(tmp_path / "s"),
                "--no-progress",
            ]
        )
    assert "hyperparams.learning_rate" in capsys.readouterr().err
    assert not (tmp_path / "s").exists()


def test_aggregate_without_evaluations_is_skipped(tmp_path):
    (tmp_path / "sweep.yaml").write_text("trials: [{folder: config0_seed0, config: 0, seed: 0}]\n")
    assert aggregate_learning_curves(tmp_path) is None
