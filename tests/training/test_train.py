"""Training: bad configs refused before workers, short PPO/SAC runs, reload = in-process actions,
resume continues the step count, training improves the evaluation return."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import yaml

import sphere_env  # noqa: F401
from sphere_env.training import train as train_mod
from sphere_env.training.config import resolve_config
from sphere_env.training.train import latest_checkpoint, load_config, main, train

RAMP = "sphere_env/RampDescent-v0"
IMPROVE_STEPS = int(__import__("os").environ.get("SPHERE_IMPROVE_STEPS", 16384))
TASK = {"shell_model": "injected", "omega_ref_range_rad_s": (4.0, 4.5)}
TINY = {
    "ppo": {"n_envs": 2, "n_steps": 64, "batch_size": 64, "n_epochs": 2, "env_kwargs": {"shell_model": "point"}},
    "sac": {"n_envs": 2, "learning_starts": 64, "buffer_size": 2000, "batch_size": 32, "train_freq": 8,
            "gradient_steps": 1, "policy_kwargs": {"net_arch": [32, 32]}, "env_kwargs": {"shell_model": "point"}},
}


@pytest.fixture
def no_workers(monkeypatch):
    """Fail loudly if a vectorized env (and thus a worker) is created."""

    def boom(*a, **k):
        raise AssertionError("a worker was started")

    monkeypatch.setattr("stable_baselines3.common.vec_env.SubprocVecEnv.__init__", boom)
    monkeypatch.setattr(train_mod, "make_vec_env", boom)


@pytest.mark.parametrize(
    "argv, field",
    [
        (["--algo", "dqn"], "algo"),
        (["--env", "sphere_env/Nope-v0"], "env"),
        (["--params", "learning_rat:0.001"], "hyperparams.learning_rat"),
        (["--params", "n_envs:0"], "n_envs"),
        (["--params", "n_threads:9"], "n_threads"),
        (["--params", "n_threads:many"], "n_threads"),
        (["--params", "n_threads:2", "n_workers:2"], "n_threads"),
        (["--params", "randomization:{pressure_kpa: [1, 50]}"], "randomization.pressure_kpa"),
        (["--params", "randomization:{ground_friction: [0.9, 0.5]}"], "randomization.ground_friction"),
        (["--params", "env_kwargs:{shell_model: jelly}"], "shell_model"),
        (["--params", "normalize:{norm_ob: true}"], "normalize.norm_ob"),
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
    """The shipped PPO file steps its envs in threads; an n_workers override selects processes
    instead (and vice versa) without having to cancel the file's key."""
    shipped = resolve_config(RAMP, "ppo", build_env=False)
    assert (shipped.n_threads, shipped.n_workers) == ("auto", None)
    assert shipped.n_envs * shipped.hyperparams["n_steps"] == 512 and shipped.n_envs == 2
    procs = resolve_config(RAMP, "ppo", overrides={"n_workers": 2}, build_env=False)
    assert (procs.n_threads, procs.n_workers) == (None, 2)


def test_bad_randomization_message_names_field():
    with pytest.raises(ValueError, match=r"^randomization\.pressure_kpa"):
        resolve_config(RAMP, "ppo", overrides={"randomization": {"pressure_kpa": [1.0, 50.0]}})


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

    cfg = resolve_config(RAMP, algo, overrides={**TINY[algo], "n_timesteps": 256}, seed=1, eval_freq=128,
                         eval_episodes=1, checkpoint_freq=128)
    run, model = train(cfg, tmp_path / "run", progress_bar=False, return_model=True)
    for f in ["config.yaml", "model.zip", "vecnormalize.pkl", "best/best_model.zip", "best/vecnormalize.pkl",
              "learning_curve.csv", "learning_curve.png", "eval/evaluations.npz", "timing.json"]:
        assert (run / f).exists(), f
    assert any((run / "tb").rglob("events.out.tfevents*"))
    assert (run / "monitor" / "train_0.monitor.csv").exists()
    stored = yaml.safe_load((run / "config.yaml").read_text())
    assert stored["seeds"] == {"seed": 1, "workers": [1, 2], "eval": 10_001}
    assert {"drake", "torch", "stable_baselines3", "sphere_env"} <= set(stored["versions"])
    assert stored["randomization_resolved"]["terms"][0]["distribution"]["low"] == 3.0
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
    cfg = resolve_config(RAMP, "ppo", overrides={**TINY["ppo"], "n_timesteps": 256}, seed=0, eval_freq=128,
                         eval_episodes=1, checkpoint_freq=128)
    run = train(cfg, tmp_path / "run", progress_bar=False)
    assert latest_checkpoint(run)[0] == 256
    main(["--resume", str(run), "--n-timesteps", "512", "--no-progress"])
    steps, path = latest_checkpoint(run)
    assert steps == 512
    from stable_baselines3 import PPO

    assert PPO.load(run / "model.zip").num_timesteps == 512
    assert (run / "checkpoints" / "rl_model_vecnormalize_512_steps.pkl").exists()
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

    overrides = {"n_timesteps": IMPROVE_STEPS, "env_kwargs": TASK, "randomization": "off"}  # shipped layout
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
