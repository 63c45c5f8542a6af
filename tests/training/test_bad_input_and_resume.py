"""Training refuses bad hyperparameters before anything is written; resume falls back to the newest
readable checkpoint, restarts a run stopped before its first checkpoint, keeps the original command
and drops history past the restored checkpoint; tiny budgets write a handful of checkpoints."""

from __future__ import annotations

import csv
from collections.abc import Mapping

import numpy as np
import pytest
import yaml

from sphere_env.training.config import resolve_config
from sphere_env.training.run_folder import latest_checkpoint
from sphere_env.training.schemas import check_section
from sphere_env.training.train import main
from sphere_env.training.trainer import train
from tests.conftest import TINY_PPO, TINY_PPO_PARAMS

RAMP = "sphere_env/RampDescent-v0"
TINY = {**TINY_PPO, "env_kwargs": {"shell_model": "point"}}


@pytest.mark.parametrize(
    "param, field",
    [
        ("ent_coef:abc", "hyperparams.ent_coef"),
        ("n_epochs:0", "hyperparams.n_epochs"),
        ("gamma:2.0", "hyperparams.gamma"),
        ("gamma:0", "hyperparams.gamma"),
        ("gae_lambda:1.5", "hyperparams.gae_lambda"),
        ("learning_rate:-1", "hyperparams.learning_rate"),
        ("learning_rate:lin_-3", "hyperparams.learning_rate"),
        ("clip_range:0", "hyperparams.clip_range"),
        ("max_grad_norm:0", "hyperparams.max_grad_norm"),
        ("n_steps:true", "hyperparams.n_steps"),
        ("batch_size:12.5", "hyperparams.batch_size"),
        ("vf_coef:.nan", "hyperparams.vf_coef"),
        ("policy_kwargs:[64, 64]", "hyperparams.policy_kwargs"),
        ("n_envs:100000", "n_envs"),
        (
            (
                "env_kwargs:{'randomization': {'pressure_kpa': {'distribution': 'uniform'}, "
                "'pressure_schedule': {'rate_kpa_per_s': [0.5, -0.5]}}}"
            ),
            "env_kwargs.randomization",
        ),
    ],
)
def test_bad_hyperparameters_refused_before_anything_is_written(tmp_path, capsys, param, field):
    with pytest.raises(SystemExit) as exc:
        main(["--hyperparams", param, "--run-dir", str(tmp_path / "run"), "--n-timesteps", "10", "--no-progress"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert field in err, err
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(
    "algo, section, message",
    [
        (
            "ppo",
            {"policy_kwargs": {"net_arch": [-64, 64]}},
            "field 'hyperparams.policy_kwargs.net_arch[0]' = -64: Input should be greater than or equal to 1; allowed: a "
            "list of layer sizes >= 1",
        ),
        (
            "ppo",
            {"policy_kwargs": "dict(net_arch=dict(pi=[64, 0]))"},
            "field 'hyperparams.policy_kwargs.net_arch' = {'pi': [64, 0]}: ",
        ),
        (
            "ppo",
            {"policy_kwargs": {"activation_fn": "sigmoid"}},
            "field 'hyperparams.policy_kwargs.activation_fn' = 'sigmoid': String should match pattern",
        ),
        (
            "ppo",
            {"policy_kwargs": {"activation_fn": "leakyrelu"}},
            "field 'hyperparams.policy_kwargs.activation_fn' = 'leakyrelu': ",
        ),
        ("ppo", {"learning_rate": "lin_0"}, "field 'hyperparams.learning_rate' = 'lin_0': "),
        ("ppo", {"learning_rate": "lin_1e999"}, "field 'hyperparams.learning_rate' = 'lin_1e999': "),
        ("ppo", {"clip_range": "lin_x"}, "field 'hyperparams.clip_range' = 'lin_x': "),
        (
            "sac",
            {"gradient_steps": 0},
            "field 'hyperparams.gradient_steps' = 0: Input should be greater than or equal to "
            "1; allowed: an integer >= 1 or -1 (as many as env steps)",
        ),
        ("sac", {"ent_coef": "auto_0"}, "field 'hyperparams.ent_coef' = 'auto_0': "),
        ("ppo", [64, 64], "field 'hyperparams' is a list, not a mapping; allowed keys: ["),
    ],
)
def test_bad_values_are_refused_by_name(algo, section, message):
    with pytest.raises(ValueError) as err:
        check_section(algo, section)
    assert str(err.value).startswith(message), err.value
    if isinstance(section, Mapping):
        assert "; allowed: " in str(err.value)


@pytest.mark.parametrize(
    "algo, section",
    [
        ("ppo", {"learning_rate": "lin_3e-4", "clip_range": "lin_0.2"}),
        ("ppo", {"learning_rate": "lin_.0003"}),
        ("ppo", {"policy_kwargs": "dict(activation_fn=nn.LeakyReLU)"}),
        ("ppo", {"policy_kwargs": {"activation_fn": "Tanh"}}),
        ("ppo", {"policy_kwargs": {"activation_fn": "leaky_relu"}}),
        ("sac", {"gradient_steps": -1}),
    ],
)
def test_good_values_pass(algo, section):
    check_section(algo, section)


@pytest.mark.parametrize(
    "value, ok",
    [
        ("auto", True),
        ("auto_0.1", True),
        (0.05, True),
        ("auto_-1", False),
        ("autox", False),
        (-0.1, False),
        (True, False),
    ],
)
def test_sac_entropy_coefficient(value, ok):
    if ok:
        check_section("sac", {"ent_coef": value})
    else:
        with pytest.raises(ValueError, match=r"^field 'hyperparams\.ent_coef'"):
            check_section("sac", {"ent_coef": value})


def test_shipped_hyperparameters_pass_the_checks():
    for algo in ("ppo", "sac"):
        for env_id in (RAMP, "sphere_env/Roll-v0"):
            resolve_config(env_id, algo, build_env=False)


def test_tiny_budget_writes_few_checkpoints(tmp_path):
    cfg = resolve_config(RAMP, "ppo", overrides={**TINY, "n_timesteps": 10}, eval_episodes=1)
    assert cfg.checkpoint_freq >= 32 and cfg.eval_freq >= 32
    run = train(cfg, tmp_path / "run", progress_bar=False)
    assert len(list((run / "checkpoints").glob("rl_model_*_steps.zip"))) <= 2


def _checkpointed_run(tmp_path, n=64):
    """A tiny run of ``n`` steps with a checkpoint every 32 (a run of its own: the tests damage it)."""
    cfg = resolve_config(
        RAMP, "ppo", overrides={**TINY, "n_timesteps": n}, eval_freq=32, eval_episodes=1, checkpoint_freq=32
    )
    return train(cfg, tmp_path / "run", progress_bar=False, command=["original", "command"])


def test_resume_falls_back_past_truncated_checkpoint_and_missing_vecnormalize(tmp_path, capsys):
    run = _checkpointed_run(tmp_path)
    assert latest_checkpoint(run)[0] == 64
    ck = run / "checkpoints"
    data = (ck / "rl_model_64_steps.zip").read_bytes()
    (ck / "rl_model_64_steps.zip").write_bytes(data[: len(data) // 2])  # truncated newest
    (ck / "rl_model_vecnormalize_32_steps.json").unlink()  # the one before has no statistics
    # a 3rd, older good one
    import shutil

    first = sorted(ck.glob("rl_model_*_steps.zip"))
    assert {p.name for p in first} == {"rl_model_32_steps.zip", "rl_model_64_steps.zip"}
    shutil.copy(ck / "rl_model_32_steps.zip", ck / "rl_model_0_steps.zip")
    # no statistics for 0 either: nothing usable → refused, config untouched
    before = (run / "config.yaml").read_text()
    with pytest.raises(SystemExit):
        main(["--resume", str(run), "--n-timesteps", "96", "--no-progress"])
    err = capsys.readouterr().err
    assert "rl_model_64_steps.zip" in err and "vecnormalize" in err.lower()
    assert (run / "config.yaml").read_text() == before
    # restore the statistics of step 32: resume falls back to it and says so
    (ck / "rl_model_0_steps.zip").unlink()
    shutil.copy(run / "vecnormalize.json", ck / "rl_model_vecnormalize_32_steps.json")
    main(["--resume", str(run), "--n-timesteps", "96", "--no-progress"])
    err = capsys.readouterr().err
    assert "falling back to the checkpoint at 32 steps" in err
    conf = yaml.safe_load((run / "config.yaml").read_text())
    assert conf["command"] == ["original", "command"]
    assert conf["resumed_from_steps"] == 32
    assert len(conf["resume_commands"]) == 1 and "--resume" in conf["resume_commands"][0]["command"]
    # episodes logged after step 32 by the first session are gone: the curve restarts at 32
    with open(run / "learning_curve_train.csv") as f:
        steps = [int(r["timesteps"]) for r in csv.DictReader(f)]
    assert steps == sorted(steps)
    ev = np.load(run / "eval" / "evaluations.npz")["timesteps"]
    assert list(ev) == sorted(ev) and len(ev) == len(set(ev))


def test_a_run_stopped_after_its_last_checkpoint_is_saved_from_it_and_then_refuses_more(tmp_path, capsys):
    """Stopped during the last rollout, after the checkpoint at the budget and before the final save:
    a resume saves that checkpoint as the run's model (no step trained, its rate unknown); once saved,
    a resume at the same budget is refused."""
    import json
    import zipfile

    run = _checkpointed_run(tmp_path)
    for name in ("model.zip", "vecnormalize.json", "timing.json"):
        (run / name).unlink()
    ck = run / "checkpoints"
    main(["--resume", str(run), "--n-timesteps", "64", "--no-progress"])
    assert "stopped before its final save" in capsys.readouterr().err
    timing = json.loads((run / "timing.json").read_text())
    assert timing["num_timesteps"] == 64 and timing["steps_this_session"] == 0 and timing["steps_per_s"] is None
    with zipfile.ZipFile(run / "model.zip") as a, zipfile.ZipFile(ck / "rl_model_64_steps.zip") as b:
        assert a.read("policy.pth") == b.read("policy.pth")
    assert json.loads((run / "vecnormalize.json").read_text()) == json.loads(
        (ck / "rl_model_vecnormalize_64_steps.json").read_text()
    )
    with pytest.raises(SystemExit):
        main(["--resume", str(run), "--n-timesteps", "64", "--no-progress"])
    assert "already reached" in capsys.readouterr().err


def test_run_stopped_before_first_checkpoint_restarts_or_is_reused(tmp_path, capsys):
    run = _checkpointed_run(tmp_path, n=32)
    import shutil

    shutil.rmtree(run / "checkpoints")
    (run / "model.zip").unlink()  # as if killed before the first checkpoint
    main(["--resume", str(run), "--n-timesteps", "32", "--no-progress"])
    assert "restarting from scratch" in capsys.readouterr().err
    assert latest_checkpoint(run)[0] >= 32 and (run / "model.zip").exists()
    shutil.rmtree(run / "checkpoints")
    (run / "model.zip").unlink()
    main(
        [
            "--run-dir",
            str(run),
            "--n-timesteps",
            "32",
            "--no-progress",
            "--hyperparams",
            *TINY_PPO_PARAMS,
            "--env-kwargs",
            "shell_model:'point'",
        ]
    )
    assert "starting over" in capsys.readouterr().err
    assert (run / "model.zip").exists()


def test_resume_continues_the_monitor_logs_without_a_repeat_or_a_time_jump(tmp_path):
    """Two envs with 10-step episodes; the session's newest checkpoint is lost, so the resume
    restores step 64 and re-runs what came after: each Monitor CSV keeps exactly the episodes
    learning_curve_train.csv has of its env, and episode times never go backwards."""
    over = {**TINY, "n_envs": 2, "n_timesteps": 128, "env_kwargs": {"shell_model": "point", "max_episode_steps": 10}}
    cfg = resolve_config(RAMP, "ppo", overrides=over, eval_freq=0, checkpoint_freq=64)
    run = train(cfg, tmp_path / "run", progress_bar=False)
    (run / "checkpoints" / "rl_model_128_steps.zip").unlink()
    main(["--resume", str(run), "--n-timesteps", "192", "--no-progress"])
    with open(run / "learning_curve_train.csv") as f:
        rows = list(csv.DictReader(f))
    steps = [int(r["timesteps"]) for r in rows]
    assert steps == sorted(steps) and steps[-1] <= 192
    total = 0
    for rank in ("0", "1"):
        lines = (run / "monitor" / f"train_{rank}.monitor.csv").read_text().splitlines()
        assert lines[0].startswith("#") and lines[1].startswith("r,l,t")
        mon = list(csv.DictReader(lines[1:]))
        assert len(mon) == sum(r["env"] == rank for r in rows) > 0
        t = [float(m["t"]) for m in mon]
        assert t == sorted(t)  # the resumed session's times continue (they restarted at 0 before)
        total += len(mon)
    assert total == len(rows)


def test_one_process_per_env_is_bounded_before_anything_starts(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(
            [
                "--hyperparams",
                "n_envs:100",
                "n_workers:None",
                "--run-dir",
                str(tmp_path / "run"),
                "--n-timesteps",
                "10",
                "--no-progress",
            ]
        )
    assert exc.value.code == 2
    assert "field 'hyperparams.n_envs' = 100 with n_workers: null" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()
    with pytest.raises(
        ValueError,
        match=r"^field 'hyperparams.n_timesteps' = 1000000000000.0: .*allowed: an integer within \[1, 10000000000\]",
    ):
        resolve_config(RAMP, "ppo", overrides={**TINY, "n_timesteps": 1e12}, build_env=False)
