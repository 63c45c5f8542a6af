"""Training: bad configs refused before workers, short PPO/SAC runs, reload = in-process actions,
resume continues the step count, training improves the evaluation return."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import yaml

import sphere_env  # noqa: F401
from sphere_env.cli import parse_key_values
from sphere_env.resources import hyperparams_path
from sphere_env.training import train as train_mod
from sphere_env.training.config import resolve_config
from sphere_env.training.env_factory import EvaluationEpisodes
from sphere_env.training.run_folder import latest_checkpoint, load_config
from sphere_env.training.train import main
from sphere_env.training.trainer import train
from tests.conftest import TINY_PPO, TINY_PPO_PARAMS, TINY_SAC

RAMP = "sphere_env/RampDescent-v0"
IMPROVE_STEPS = int(__import__("os").environ.get("SPHERE_IMPROVE_STEPS", 16384))
TASK = {"shell_model": "injected", "omega_ref_range_rad_s": (4.0, 4.5)}
#: Two envs (the workers' seeds 1 and 2), the point shell: the tiny runs of conftest.py's TINY_PPO / TINY_SAC.
TINY = {
    "ppo": {**TINY_PPO, "n_envs": 2, "env_kwargs": {"shell_model": "point"}},
    "sac": {**TINY_SAC, "n_envs": 2, "env_kwargs": {"shell_model": "point"}},
}


@pytest.fixture
def no_workers(monkeypatch):
    """Fail loudly if a vectorized env (and thus a worker) is created."""

    def boom(*a, **k):
        raise AssertionError("a worker was started")

    monkeypatch.setattr("stable_baselines3.common.vec_env.SubprocVecEnv.__init__", boom)
    monkeypatch.setattr("sphere_env.training.session.make_vec_env", boom)


@pytest.mark.parametrize(
    "argv, field",
    [
        (["--algo", "dqn"], "algo"),
        (["--env", "sphere_env/Nope-v0"], "env"),
        (["--params", "learning_rat:0.001"], "hyperparams.learning_rat"),
        (["--params", "n_envs:0"], "n_envs"),
        (["--params", "n_threads:33"], "n_threads"),  # more than n_envs
        (["--params", "n_threads:many"], "n_threads"),
        (["--params", "n_threads:2", "n_workers:2"], "n_threads"),
        (["--params", "n_workers:33"], "n_workers"),
        (["--params", "n_workers:many"], "n_workers"),
        (["--env-kwargs", "randomization:{'pressure_kpa': [1, 50]}"], "field 'env_kwargs.randomization.pressure_kpa'"),
        (
            ["--env-kwargs", "randomization:{'ground_friction': [0.9, 0.5]}"],
            "field 'env_kwargs.randomization.ground_friction'",
        ),
        (["--env-kwargs", "shell_model:'jelly'"], "env_kwargs.shell_model"),
        (["--hyperparams", "env_kwargs:{'shell_model': 'jelly'}"], "env_kwargs.shell_model"),
        (["--hyperparams", "normalize:{'norm_ob': True}"], "normalize.norm_ob"),
        (["--hyperparams", "env_kwargs:{shell_model: jelly}"], "hyperparams.env_kwargs"),  # YAML style: not Python
        (["--hyperparams", "frame_stack:4"], "hyperparams.frame_stack"),  # rl-zoo3 key not implemented here
        (["--hyperparams", "ppo.yml"], "-conf/--conf-file"),
        (["--eval-env-kwargs", "shell_model:'jelly'"], "eval_env_kwargs.shell_model"),
        (
            ["--eval-env-kwargs", "randomization:{'pressure_kpa': [1, 50]}"],
            "field 'eval_env_kwargs.randomization.pressure_kpa'",
        ),
        (["--eval-pressures-kpa", "3", "20"], "eval_pressures_kpa"),
        (
            ["-i", "no/such/model.zip"],
            "trained_agent = 'no/such/model.zip': Path does not point to a file; "
            "allowed: a saved model: a .zip file, or a run folder with model.zip",
        ),
        (["-i", "pyproject.toml"], "trained_agent = 'pyproject.toml': String should match pattern"),
        (["--seeds", "1", "1"], "seeds"),
    ],
)
def test_bad_configs_refused_before_workers(no_workers, tmp_path, capsys, argv, field):
    with pytest.raises(SystemExit) as exc:
        main(argv + ["--run-dir", str(tmp_path / "run"), "--no-progress"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert field in err, err
    assert not (tmp_path / "run").exists()


def test_layout_overrides_replace_the_files_layout():
    """The shipped PPO file steps its envs in blocks, one per usable core (``n_workers: auto``); an
    n_threads override selects threads instead (and vice versa) without having to cancel the other
    key; both null: one process per env."""
    shipped = resolve_config(RAMP, "ppo", build_env=False)
    assert (shipped.n_threads, shipped.n_workers) == (None, "auto")
    assert shipped.n_envs * shipped.hyperparams["n_steps"] == 512 and shipped.n_envs == 2
    threads = resolve_config(RAMP, "ppo", overrides={"n_threads": 2}, build_env=False)
    assert (threads.n_threads, threads.n_workers) == (2, None)
    back = resolve_config(RAMP, "ppo", overrides={"n_workers": 2}, build_env=False)
    assert (back.n_threads, back.n_workers) == (None, 2)
    one_each = resolve_config(RAMP, "ppo", overrides={"n_workers": None}, build_env=False)
    assert (one_each.n_threads, one_each.n_workers) == (None, None)


def test_bad_randomization_message_names_field():
    with pytest.raises(
        ValueError,
        match=r"^field 'env_kwargs\.randomization\.pressure_kpa' = 1\.0: .*; allowed: "
        r"\[3\.0, 14\.0\] kPa, the calibrated range",
    ):
        resolve_config(RAMP, "ppo", env_kwargs={"randomization": {"pressure_kpa": [1.0, 50.0]}})


def test_top_level_randomization_refused_with_where_it_moved(no_workers, tmp_path, capsys):
    """The former layout (randomization beside env_kwargs) fails loudly, in a file or an override."""
    conf = tmp_path / "old.yml"
    conf.write_text(f"{RAMP}:\n  n_envs: 1\n  randomization: off\n")
    for argv in (["-conf", str(conf)], ["--hyperparams", "randomization:'off'"]):
        with pytest.raises(SystemExit):
            main(["--env", RAMP, *argv, "--run-dir", str(tmp_path / "run"), "--no-progress"])
        err = capsys.readouterr().err
        assert (
            "field 'hyperparams.randomization': a top-level key" in err and "moved to env_kwargs.randomization" in err
        ), err
    assert not (tmp_path / "run").exists()


def test_key_values_read_as_python_literals_like_rl_zoo3():
    parsed = parse_key_values(
        [
            "n_envs:4",
            "learning_rate:lin_5e-4",
            "gamma:0.99",
            "use_sde:True",
            "policy_kwargs:dict(net_arch=[64])",
            "env_kwargs:{'randomization': 'off'}",
            "shell_model:'point'",
            "target_kl:None",
        ]
    )
    assert parsed == {
        "n_envs": 4,
        "learning_rate": "lin_5e-4",
        "gamma": 0.99,
        "use_sde": True,
        "policy_kwargs": "dict(net_arch=[64])",
        "env_kwargs": {"randomization": "off"},
        "shell_model": "point",
        "target_kl": None,
    }


def test_rl_zoo3_flags_reach_the_config(tmp_path):
    """-conf, --hyperparams, --env-kwargs, --eval-env-kwargs, --eval-*, --save-freq, -tb, -n, --seed."""
    args = train_mod.build_parser().parse_args(
        [
            "--env",
            RAMP,
            "-conf",
            str(hyperparams_path("ppo")),
            "-params",
            "n_envs:1",
            "n_steps:64",
            "--env-kwargs",
            "shell_model:'point'",
            "randomization:{'pressure_kpa': [4.0, 6.0]}",
            "--eval-env-kwargs",
            "observation_noise_scale:0.5",
            "--eval-freq",
            "-1",
            "--save-freq",
            "128",
            "--eval-episodes",
            "4",
            "--eval-pressures-kpa",
            "5",
            "7",
            "-tb",
            str(tmp_path / "tb"),
            "-n",
            "512",
            "--seed",
            "3",
        ]
    )
    cfg = train_mod._config_from_args(args, args.hyperparams, args.seed)
    assert (cfg.n_envs, cfg.hyperparams["n_steps"], cfg.n_timesteps, cfg.seed) == (1, 64, 512, 3)
    assert cfg.env_kwargs == {
        "shell_model": "point",
        "friction_model": "majd",
        "randomization": {"pressure_kpa": [4.0, 6.0]},
    }  # merged over the YAML's
    assert cfg.make_kwargs(evaluation=True) == {
        **cfg.env_kwargs,
        "randomization": "off",
        "observation_noise_scale": 0.5,
    }
    assert (cfg.eval_freq, cfg.checkpoint_freq, cfg.eval_episodes, cfg.eval_pressures_kpa) == (0, 128, 4, [5.0, 7.0])
    assert cfg.tensorboard_log == str(tmp_path / "tb")
    default = resolve_config(RAMP, "ppo", build_env=False)
    assert default.eval_pressures_kpa == [3.0, 4.31, 14.0] and default.eval_env_kwargs == {"randomization": "off"}


def _first_obs(env_kwargs, seed=7, n=40):
    """Observations of a short zero-torque episode prefix."""
    env = gym.make(RAMP, randomization="off", **env_kwargs)
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for _ in range(n):
        obs, *_ = env.step(np.zeros(2, np.float32))
        out.append(obs)
    env.close()
    return np.array(out)


@pytest.mark.slow
@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_short_run_loads_with_vecnormalize_and_acts_the_same(tmp_path, algo):
    from sphere_env.evaluation.controller_specs import PolicyController

    cfg = resolve_config(
        RAMP,
        algo,
        overrides={**TINY[algo], "n_timesteps": 256},
        seed=1,
        eval_freq=128,
        eval_episodes=1,
        checkpoint_freq=128,
    )
    run, model = train(cfg, tmp_path / "run", progress_bar=False, return_model=True)
    for f in [
        "config.yaml",
        "model.zip",
        "vecnormalize.json",
        "best/best_model.zip",
        "best/vecnormalize.json",
        "learning_curve.csv",
        "learning_curve.png",
        "eval/evaluations.npz",
        "timing.json",
    ]:
        assert (run / f).exists(), f
    assert any((run / "tb").rglob("events.out.tfevents*"))
    assert (run / "monitor" / "train_0.monitor.csv").exists()
    stored = yaml.safe_load((run / "config.yaml").read_text())
    assert stored["seeds"] == {"seed": 1, "workers": [1, 2], "eval": 10_001}
    assert {"drake", "torch", "stable_baselines3", "sphere_env"} <= set(stored["versions"])
    assert stored["randomization_resolved"]["pressure_kpa"]["low"] == 3.0
    assert load_config(run).hyperparams == cfg.hyperparams

    vn = model.get_vec_normalize_env()
    assert vn is not None and vn.obs_rms.count > 1
    loaded = PolicyController(run)
    obs = _first_obs(cfg.env_kwargs)
    in_process = np.array([model.predict(vn.normalize_obs(o), deterministic=True)[0] for o in obs])
    from_disk = np.array([loaded(o) for o in obs])
    np.testing.assert_array_equal(in_process, from_disk)
    assert np.ptp(from_disk) > 0  # a real policy, not a constant


@pytest.mark.slow
def test_resume_continues_step_count(tmp_path):
    cfg = resolve_config(
        RAMP,
        "ppo",
        overrides={**TINY["ppo"], "n_timesteps": 256},
        seed=0,
        eval_freq=128,
        eval_episodes=1,
        checkpoint_freq=128,
    )
    run = train(cfg, tmp_path / "run", progress_bar=False)
    assert latest_checkpoint(run)[0] == 256
    main(["--resume", str(run), "--n-timesteps", "512", "--no-progress"])
    steps, path = latest_checkpoint(run)
    assert steps == 512
    from stable_baselines3 import PPO

    assert PPO.load(run / "model.zip").num_timesteps == 512
    assert (run / "checkpoints" / "rl_model_vecnormalize_512_steps.json").exists()
    curve = np.genfromtxt(run / "learning_curve.csv", delimiter=",", names=True, dtype=None, encoding=None)
    ev = curve[curve["kind"] == "eval"]["timesteps"]
    assert ev.min() <= 256 < ev.max() <= 512  # evaluations from both sessions, continuing counts
    assert yaml.safe_load((run / "config.yaml").read_text())["resumed_from_steps"] == 256


@pytest.mark.slow
def test_training_improves_evaluation_return(tmp_path):
    """RampDescent, injected shell, fixed seed: after a reduced budget the trained policy beats the
    untrained one (whose deterministic action ≈ 0, i.e. zero torque) on fixed evaluation episodes.
    The command range is narrowed to slow speeds (always brake), so a few updates show the trend."""
    from sphere_env.evaluation.controller_specs import PolicyController

    overrides = {"n_timesteps": IMPROVE_STEPS, "env_kwargs": {**TASK, "randomization": "off"}}  # shipped layout
    cfg = resolve_config(RAMP, "ppo", overrides=overrides, seed=0, eval_freq=10**6, eval_episodes=1)
    run = train(cfg, tmp_path / "run", progress_bar=False)

    from stable_baselines3 import PPO

    untrained = PPO(cfg.policy, gym.make(RAMP, **TASK), seed=0, **cfg.algo_kwargs())
    trained = PolicyController(run)

    def score(act):
        env = gym.make(RAMP, randomization="off", **TASK)
        total = 0.0
        for seed in (100, 101, 102, 103):
            obs, _ = env.reset(seed=seed)
            done = False
            while not done:
                obs, r, term, trunc, _ = env.step(act(obs))
                total += r
                done = term or trunc
        env.close()
        return total / 4

    before = score(lambda o: untrained.predict(o, deterministic=True)[0])
    after = score(trained)
    print(f"evaluation return: untrained {before:.3f}, trained {after:.3f}")
    assert after > before + 0.1, (before, after)


TINY1 = {**TINY_PPO, "env_kwargs": {"shell_model": "point"}}


@pytest.mark.slow
def test_evaluations_play_the_fixed_pressure_grid_without_randomization(tmp_path):
    """Training draws pressures; every evaluation plays the calibration's low, nominal and high
    pressures in order (randomization off), the same episodes each time."""
    tiny = {k: v for k, v in TINY1.items() if k != "env_kwargs"}
    cfg = resolve_config(
        RAMP,
        "ppo",
        overrides={**tiny, "n_timesteps": 256},
        env_kwargs={"shell_model": "point"},
        eval_freq=128,
        eval_episodes=3,
        checkpoint_freq=256,
    )
    assert cfg.randomization == {"pressure_kpa": {"distribution": "uniform"}}  # the shipped training spec
    run = train(cfg, tmp_path / "run", progress_bar=False)
    import pandas as pd

    ev = pd.read_csv(run / "monitor" / "eval.monitor.csv", skiprows=1)
    assert ev["pressure_kpa"].tolist() == [3.0, 4.31, 14.0] * 2
    tr = pd.read_csv(run / "monitor" / "train_0.monitor.csv", skiprows=1)
    assert len(tr) >= 2 and not set(tr["pressure_kpa"]) & {3.0, 4.31, 14.0}
    stored = yaml.safe_load((run / "config.yaml").read_text())
    assert stored["eval_pressures_kpa"] == [3.0, 4.31, 14.0] and stored["eval_env_kwargs"] == {"randomization": "off"}


def test_evaluation_episodes_repeat_after_restart():
    env = EvaluationEpisodes(gym.make(RAMP, shell_model="point", randomization="default"), [5.0, 9.0], 100)
    first = [env.reset(seed=k)[0] for k in range(3)]  # the caller's seeds are ignored
    env.restart_evaluation()
    again = [env.reset()[0] for _ in range(3)]
    np.testing.assert_array_equal(np.array(first), np.array(again))
    env.restart_evaluation()
    assert [env.reset()[1]["pressure_kpa"] for _ in range(3)] == [5.0, 9.0, 5.0]


@pytest.mark.slow
def test_trained_agent_continues_with_its_vecnormalize(tmp_path):
    """-i: a new run folder starting from the saved network and VecNormalize statistics."""
    from stable_baselines3 import PPO

    from sphere_env.training.saved import read_stats

    common = [
        "--env",
        RAMP,
        "--hyperparams",
        *TINY_PPO_PARAMS,
        "--env-kwargs",
        "shell_model:'point'",
        "--eval-freq",
        "-1",
        "--no-progress",
    ]
    first = main([*common, "-n", "64", "--run-dir", str(tmp_path / "a")])
    second = main([*common, "-n", "32", "--run-dir", str(tmp_path / "b"), "-i", str(first / "model.zip")])
    vn_a, vn_b = read_stats(first / "vecnormalize.json"), read_stats(second / "vecnormalize.json")
    assert vn_b.obs_rms.count == vn_a.obs_rms.count + 1 + 32  # continued (+ the first reset, 32 steps)
    a, b = PPO.load(first / "model.zip"), PPO.load(second / "model.zip")
    assert b.num_timesteps == 32
    changed = [not np.array_equal(x, y) for x, y in zip(a.policy.state_dict().values(), b.policy.state_dict().values())]
    assert any(changed)
    assert yaml.safe_load((second / "config.yaml").read_text())["trained_agent"] == str(first / "model.zip")
    assert not (second / "eval").exists()  # --eval-freq -1: no evaluations


def test_unchecked_distributions_train_the_same_network_and_restore_the_checks():
    """Turning torch.distributions' argument checks off (the trainer's speed-up) changes no number
    of a PPO run, and the previous setting is back afterwards."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    from sphere_env.training.session import unchecked_distributions

    def run():
        venv = DummyVecEnv([lambda: gym.make("sphere_env/RampDescent-v2", shell_model="point")])
        model = PPO("MlpPolicy", venv, n_steps=64, batch_size=32, n_epochs=2, seed=3, device="cpu")
        model.learn(128)
        return torch.nn.utils.parameters_to_vector(model.policy.parameters()).detach()

    checked = run()
    assert torch.distributions.Distribution._validate_args
    with unchecked_distributions():
        assert not torch.distributions.Distribution._validate_args
        unchecked = run()
    assert torch.distributions.Distribution._validate_args
    assert torch.equal(checked, unchecked)


@pytest.mark.parametrize(
    "text, message",
    [
        ("env_id: sphere_env/RampDescent-v3\n", "field 'algo' is missing"),
        ("algo: ppo\nenv_id: 3\n", "field 'env_id' = 3: Input should be a valid string"),
        ("- a list\n", "the input is a list, not a mapping; allowed keys: ['algo', 'env_id']"),
    ],
)
def test_a_config_that_is_no_training_config_is_refused_by_name(tmp_path, text, message):
    (tmp_path / "config.yaml").write_text(text)
    with pytest.raises(ValueError) as err:
        load_config(tmp_path)
    assert str(err.value) == f"run: {str(tmp_path / 'config.yaml')!r}: {message}"


def test_a_hyperparameter_section_that_is_no_mapping_is_refused_naming_the_file(tmp_path):
    path = tmp_path / "h.yml"
    path.write_text(f"{RAMP}: [64, 64]\n")
    with pytest.raises(ValueError) as err:
        resolve_config(RAMP, "ppo", path, build_env=False)
    assert str(err.value).startswith(
        f"hyperparams file {str(path)!r}, section {RAMP!r}: field 'hyperparams' is a "
        "list, not a mapping; allowed keys: ["
    )
