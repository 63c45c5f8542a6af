"""The shipped hyperparameter files train with rl-zoo3 as they are, and this trainer continues an
rl-zoo3 model (-i) with its VecNormalize statistics. rl-zoo3 is the ``zoo`` extra, part of the
``test`` extra that ``make test`` installs (constraints.txt pins python-dateutil 2.9, which its
pytablewriter → typepy chain needs); skipped only where it is not installed."""

from __future__ import annotations

import subprocess
import sys

import pytest

pytest.importorskip("rl_zoo3")

from sphere_env.resources import hyperparams_path
from sphere_env.training.run_folder import load_config
from sphere_env.training.train import main
from tests.conftest import TINY_PPO_PARAMS

RAMP = "sphere_env/RampDescent-v1"


@pytest.mark.slow
def test_rl_zoo3_trains_with_the_shipped_yaml_and_this_trainer_continues_it(tmp_path):
    cmd = [
        sys.executable,
        "-m",
        "rl_zoo3.train",
        "--gym-packages",
        "sphere_env",
        "--env",
        RAMP,
        "--algo",
        "ppo",
        "-conf",
        str(hyperparams_path("ppo")),
        "-n",
        "128",
        "--eval-freq",
        "-1",
        "-f",
        str(tmp_path / "logs"),
        "--seed",
        "0",
        "-params",
        *TINY_PPO_PARAMS,
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "'randomization': {'pressure_kpa': {'distribution': 'uniform'}}" in done.stdout  # read from env_kwargs
    run = tmp_path / "logs" / "ppo" / "sphere_env-RampDescent-v1_1"
    model = run / "sphere_env-RampDescent-v1.zip"
    assert model.exists() and (run / "sphere_env-RampDescent-v1" / "vecnormalize.pkl").exists()

    ours = main(
        [
            "--env",
            RAMP,
            "-i",
            str(model),
            "-n",
            "64",
            "--eval-freq",
            "-1",
            "--run-dir",
            str(tmp_path / "ours"),
            "--hyperparams",
            *TINY_PPO_PARAMS,
            "--no-progress",
        ]
    )
    assert (ours / "model.zip").exists() and load_config(ours).trained_agent == str(model)


@pytest.mark.slow
def test_rl_zoo3_trains_the_learning_recipe_with_its_asymmetric_policy(tmp_path):
    """``--gym-packages sphere_env.zoo`` registers AsymmetricMlpPolicy: rl-zoo3 trains
    RampDescent-v3's section (shell mixture, privileged critic inputs) as it is."""
    cmd = [
        sys.executable,
        "-m",
        "rl_zoo3.train",
        "--gym-packages",
        "sphere_env.zoo",
        "--env",
        "sphere_env/RampDescent-v3",
        "--algo",
        "ppo",
        "-conf",
        str(hyperparams_path("ppo")),
        "-n",
        "128",
        "--eval-freq",
        "-1",
        "-f",
        str(tmp_path / "logs"),
        "--seed",
        "0",
        "-params",
        *TINY_PPO_PARAMS,
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    from stable_baselines3 import PPO

    model = PPO.load(tmp_path / "logs" / "ppo" / "sphere_env-RampDescent-v3_1" / "sphere_env-RampDescent-v3.zip")
    assert type(model.policy).__name__ == "AsymmetricActorCriticPolicy" and model.policy.privileged_dims == 4


@pytest.mark.slow
def test_rl_zoo3_optuna_tunes_a_shipped_section(tmp_path):
    """rl-zoo3's hyperparameter search runs on a shipped section (one random trial, a tiny budget);
    the evaluation env needs the section's observation kwargs (rl-zoo3 builds it from
    --eval-env-kwargs alone)."""
    cmd = [
        sys.executable,
        "-m",
        "rl_zoo3.train",
        "--gym-packages",
        "sphere_env.zoo",
        "--env",
        RAMP.replace("v1", "v2"),
        "--algo",
        "ppo",
        "-conf",
        str(hyperparams_path("ppo")),
        "-n",
        "1024",
        "-optimize",
        "--n-trials",
        "1",
        "--n-jobs",
        "1",
        "--sampler",
        "random",
        "--pruner",
        "none",
        "--n-evaluations",
        "1",
        "--eval-episodes",
        "1",
        "-f",
        str(tmp_path / "logs"),
        "--seed",
        "0",
        "-params",
        "n_envs:1",
        "--eval-env-kwargs",
        "observe_tracking_state:True",
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=900, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "Trial 0 finished with value" in done.stderr + done.stdout
    assert list((tmp_path / "logs" / "ppo").glob("report_sphere_env-RampDescent-v2_1-trials-*"))
