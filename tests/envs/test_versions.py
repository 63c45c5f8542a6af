"""Env versions: -v1 uses the shipped calibration, -v0 keeps the earlier linear-law calibration."""

import warnings

import gymnasium as gym
import numpy as np
import pytest

import sphere_env
from sphere_env.resources import asset_path


def _rollout(env_id: str, **kwargs) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # gymnasium flags the superseded -v0
        env = gym.make(env_id, randomization="off", **kwargs)
    obs, _ = env.reset(seed=3)
    rng = np.random.default_rng(0)
    out = [obs]
    for _ in range(40):
        obs, *_ = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        out.append(obs)
    env.close()
    return np.array(out)


@pytest.mark.parametrize("task", ["RampDescent", "Roll"])
def test_v0_is_v1_with_the_v0_calibration(task):
    v0 = _rollout(f"sphere_env/{task}-v0")
    v1 = _rollout(f"sphere_env/{task}-v1")
    v1_with_v0_cal = _rollout(f"sphere_env/{task}-v1", calibration=str(asset_path("calibration", "v0_linear.yaml")))
    np.testing.assert_array_equal(v0, v1_with_v0_cal)
    assert np.abs(v0 - v1).max() > 1e-3  # the fitted steer law changes the motion


def test_every_version_is_registered():
    for env_id in sphere_env.ENV_IDS:
        assert env_id in gym.registry
    assert {"sphere_env/RampDescent-v2", "sphere_env/RampDescent-v1", "sphere_env/Roll-v1"} <= set(sphere_env.ENV_IDS)
