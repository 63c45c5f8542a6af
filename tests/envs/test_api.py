"""Gymnasium/SB3 API conformance, determinism, pickling and vectorization."""

import importlib.metadata
import pickle
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

from sphere_env.params import SHELL_MODELS
from tests.envs.conftest import ENV_IDS, rollout


def test_ids_registered_on_import_and_via_entry_point():
    for env_id in ENV_IDS:
        assert env_id in gym.envs.registry
    eps = importlib.metadata.entry_points(group="gymnasium.envs")
    (ep,) = [e for e in eps if e.name == "sphere_env"]
    ep.load()()  # idempotent
    # Gymnasium 1.x does not load plugin entry points itself; "module:id" imports the package.
    code = "import gymnasium as gym; e = gym.make('sphere_env:sphere_env/Roll-v0', shell_model='point'); print(e.spec.max_episode_steps)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "500"


@pytest.mark.parametrize("shell_model", SHELL_MODELS)
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_gymnasium_and_sb3_check_env(make, env_id, shell_model):
    from gymnasium.utils.env_checker import check_env as gym_check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = make(env_id, shell_model=shell_model)
    gym_check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env, warn=True, skip_render_check=True)
    obs, info = env.reset(seed=3)
    assert env.observation_space.contains(obs) and info["shell_model"] == shell_model
    assert env.action_space.shape == (2,) and env.action_space.dtype == np.float32


def test_checkers_pass_with_the_tracking_state_observed(make):
    """The configuration ppo.yml trains: the checkers, the space, and a deep copy that resets to
    the same observation (the tracking state restarts with the episode)."""
    import copy

    from gymnasium.utils.env_checker import check_env as gym_check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = make("sphere_env/RampDescent-v2", shell_model="injected", observe_tracking_state=True)
    gym_check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env, warn=True, skip_render_check=True)
    obs, _ = env.reset(seed=3)
    for _ in range(20):
        obs, *_ = env.step(np.array([0.0, 0.5], dtype=np.float32))
    layout = env.unwrapped.observation_layout
    assert env.observation_space.contains(obs) and obs[layout["speed_error_integral"]] != 0.0
    twin = copy.deepcopy(env)
    assert np.array_equal(twin.reset(seed=4)[0], env.reset(seed=4)[0])


def _same(a, b):
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (tuple, list)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and np.array_equal(a, b)
    return type(a) is type(b) and a == b


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_same_seed_same_rollout_different_seed_different_pressure(make, env_id):
    kw = dict(randomization="full", observation_noise_scale=1.0)
    a = rollout(make(env_id, **kw), 220, seed=7)
    b = rollout(make(env_id, **kw), 220, seed=7)
    assert len(a) >= 221 and _same(a, b)
    c = rollout(make(env_id, **kw), 1, seed=8)
    assert c[0][1]["pressure_kpa"] != a[0][1]["pressure_kpa"]
    assert c[0][1]["params"] != a[0][1]["params"]


def test_reset_reuses_diagram_and_explicit_options(make):
    env = make("sphere_env/Roll-v0")
    u = env.unwrapped
    env.reset(seed=0)
    diagram = u.twin.diagram
    obs, info = env.reset(
        options={
            "pressure_kpa": 6.5,
            "omega_ref": 1.2,
            "heading_ref": 0.3,
            "initial_state": {"theta": 0.2, "drive_rate": 1.0},
        }
    )
    assert u.twin.diagram is diagram
    assert info["pressure_kpa"] == 6.5 and u.twin.pressure_kpa == 6.5
    assert obs[0] == pytest.approx(0.2) and obs[3] == pytest.approx(1.0) and obs[11] == pytest.approx(1.2)
    assert info["heading_ref"] == 0.3
    with pytest.raises(ValueError, match=r"^field 'options\.pressure_kpa' = 99\.0"):
        env.reset(options={"pressure_kpa": 99.0})
    with pytest.raises(ValueError, match="unknown field 'options.bogus'"):
        env.reset(options={"bogus": 1})


def test_privileged_pressure_is_opt_in(make):
    obs, info = make("sphere_env/RampDescent-v0").reset(seed=0)
    assert obs.shape == (13,)
    obs, info = make("sphere_env/RampDescent-v0", observe_pressure=True).reset(seed=0)
    assert obs.shape == (14,) and obs[-1] == pytest.approx(info["pressure_kpa"], rel=1e-6)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_pickle_roundtrip_continues_identically(make, env_id):
    env = make(env_id, shell_model="point", randomization="full")
    clone = pickle.loads(pickle.dumps(env))
    try:
        assert _same(rollout(env, 50, seed=4), rollout(clone, 50, seed=4))
    finally:
        clone.close()


def _factory(env_id):
    def thunk():
        import sphere_env  # noqa: F401

        return gym.make(env_id, shell_model="point")

    return thunk


def test_async_vector_env_two_workers():
    venv = gym.vector.AsyncVectorEnv([_factory("sphere_env/RampDescent-v0")] * 2)
    try:
        obs, info = venv.reset(seed=[1, 2])
        assert obs.shape == (2, 13) and info["pressure_kpa"][0] != info["pressure_kpa"][1]
        for _ in range(20):
            obs, rew, term, trunc, info = venv.step(venv.action_space.sample())
        assert obs.shape == (2, 13) and np.all(np.isfinite(rew))
    finally:
        venv.close()


@pytest.mark.slow  # spawns two worker processes (≈4 s idle, ≈9 s on a loaded machine)
def test_sb3_subproc_vec_env_two_workers():
    from stable_baselines3.common.vec_env import SubprocVecEnv

    venv = SubprocVecEnv([_factory("sphere_env/Roll-v0")] * 2)
    try:
        venv.seed(3)
        obs = venv.reset()
        assert obs.shape == (2, 13)
        for _ in range(20):
            obs, rew, done, infos = venv.step(np.array([venv.action_space.sample() for _ in range(2)]))
        assert obs.shape == (2, 13) and len(infos) == 2 and "reward_speed" in infos[0]
    finally:
        venv.close()


def test_checkers_pass_on_the_recipe_env_with_its_mixture_and_privileged_components(make):
    """What training/hyperparams/ppo.yml's RampDescent-v3 section trains on: the checkers accept the
    env with the privileged pressure and shell one-hot, inside the shell-model mixture."""
    from gymnasium.utils.env_checker import check_env as gym_check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    from sphere_env.wrappers import ShellModelMixture

    env = make("sphere_env/RampDescent-v3", shell_model="injected", observe_pressure=True, observe_shell_model=True)
    gym_check_env(env.unwrapped, skip_render_check=True)
    mix = ShellModelMixture(env, ["injected", "point"])
    sb3_check_env(mix, warn=True, skip_render_check=True)
    obs, _ = mix.reset(seed=1)
    assert mix.observation_space.contains(obs)
    mix.close()
