"""Bad training arguments end with exit code 2 and one line naming the field, never a traceback;
SAC checkpoints leave the replay buffer out unless asked."""

from __future__ import annotations

import subprocess
import sys

import pytest

from sphere_env.training.config import resolve_config
from sphere_env.training.train import main
from tests.conftest import TINY_PPO_PARAMS

TINY = [
    "--env",
    "sphere_env/RampDescent-v2",
    "-n",
    "32",
    "--eval-freq",
    "-1",
    "--no-progress",
    "--hyperparams",
    *TINY_PPO_PARAMS,
]


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--device", "banana"], "field 'device' = 'banana': String should match pattern"),
        (["--device", "banana"], "; allowed: 'cpu', 'cuda', 'cuda:<n>' (on a machine with CUDA) or 'auto'"),
        (["--device", "mps"], "field 'device' = 'mps': String should match pattern"),
        (["--device", "cuda:7"], "field 'device' = 'cuda:7': names a CUDA device and this machine has none"),
    ],
)
def test_bad_arguments_end_in_one_named_line(tmp_path, capsys, argv, needle):
    with pytest.raises(SystemExit) as exc:
        main([*TINY, "--run-dir", str(tmp_path / "run"), *argv])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0] and "Traceback" not in err[0]
    assert not (tmp_path / "run").exists()


def test_sac_checkpoints_hold_the_replay_buffer_only_when_asked(tmp_path):
    from sphere_env.training.trainer import train

    over = {
        "n_envs": 1,
        "learning_starts": 16,
        "buffer_size": 500,
        "batch_size": 16,
        "train_freq": 8,
        "gradient_steps": 1,
        "policy_kwargs": {"net_arch": [16, 16]},
        "n_timesteps": 64,
        "env_kwargs": {"shell_model": "point"},
    }
    plain = train(
        resolve_config("sphere_env/RampDescent-v2", "sac", overrides=over, eval_freq=0),
        tmp_path / "a",
        progress_bar=False,
    )
    assert not list((plain / "checkpoints").glob("*replay_buffer*"))
    kept = train(
        resolve_config("sphere_env/RampDescent-v2", "sac", overrides=over, eval_freq=0, save_replay_buffer=True),
        tmp_path / "b",
        progress_bar=False,
    )
    assert list((kept / "checkpoints").glob("*replay_buffer*"))
    # a resume reads the buffer back (as data: sphere_env.training.saved.load_replay_buffer)
    from stable_baselines3 import SAC

    from sphere_env.training.saved import load_replay_buffer

    model = SAC("MlpPolicy", "Pendulum-v1", buffer_size=10)
    load_replay_buffer(model, kept / "checkpoints" / "rl_model_replay_buffer_64_steps.pkl")
    assert model.replay_buffer.buffer_size == 500 and model.replay_buffer.pos == 64


def test_help_is_clean_for_every_calibrate_subcommand():
    out = subprocess.run(
        [sys.executable, "-m", "sphere_env.calibration", "--help"], capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0 and "option_strings" not in out.stdout and "±50% sweep" in out.stdout


def test_continuing_a_model_with_other_policy_kwargs_is_refused(tmp_path, capsys):
    first = main([*TINY, "--run-dir", str(tmp_path / "a")])
    with pytest.raises(SystemExit) as exc:
        main(
            [
                *TINY,
                "--run-dir",
                str(tmp_path / "b"),
                "-i",
                str(first / "model.zip"),
                "--hyperparams",
                *TINY_PPO_PARAMS,
                "policy_kwargs:dict(net_arch=[8, 8])",
            ]
        )
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "hyperparams.policy_kwargs" in err and "net_arch" in err
    assert not (tmp_path / "b").exists()
    same = main([*TINY, "--run-dir", str(tmp_path / "c"), "-i", str(first / "model.zip")])  # the file's own kwargs
    assert (same / "model.zip").exists()
