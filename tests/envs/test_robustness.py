"""Short versions of the action-fuzz and memory-soak benchmark (the full run,
``python -m evaluation.experiments.robustness``, writes ``evaluation/results/robustness.md``)."""

import os

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401  (registers the ids)


def _rss_mb() -> float:
    """Resident set size of this process [MB] (Linux /proc)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def _fuzzed_action(rng):
    """(action, whether it holds a NaN or ±inf): uniform in [-1, 1], ±1e6, 1e6-scale Gaussian, or
    uniform with one NaN or ±inf."""
    k = rng.random()
    if k < 0.4:
        return rng.uniform(-1, 1, 2).astype(np.float32), False
    if k < 0.6:
        return rng.choice([-1e6, 1e6], 2), False
    if k < 0.75:
        return rng.normal(0, 1e6, 2), False
    a = rng.uniform(-1, 1, 2)
    a[rng.integers(2)] = np.nan if k < 0.875 else rng.choice([np.inf, -np.inf])
    return a, True


@pytest.mark.slow
@pytest.mark.parametrize(
    "env_id, shell_model", [("sphere_env/RampDescent-v0", "injected"), ("sphere_env/Roll-v0", "point")]
)
def test_fuzzed_actions_never_crash(env_id, shell_model):
    """NaN/inf actions raise ValueError naming the action; everything else is clipped and stepped,
    with finite observations and rewards."""
    env = gym.make(env_id, shell_model=shell_model, randomization="full")
    rng = np.random.default_rng(1)
    env.reset(seed=1)
    refused = 0
    for _ in range(1500):
        action, non_finite = _fuzzed_action(rng)
        if non_finite:
            with pytest.raises(ValueError, match="action"):
                env.step(action)
            refused += 1
            continue
        obs, reward, terminated, truncated, info = env.step(action)
        assert np.isfinite(obs).all() and np.isfinite(reward), info
        if terminated or truncated:
            env.reset()
    env.close()
    assert refused > 0


@pytest.mark.slow
def test_soak_memory_is_bounded():
    """8,000 random-action steps under full randomization: resident memory stops growing."""
    env = gym.make("sphere_env/RampDescent-v0", shell_model="injected", randomization="full")
    rng = np.random.default_rng(0)
    env.reset(seed=0)
    built = _rss_mb()
    samples = []
    for i in range(1, 8_001):
        _, _, terminated, truncated, _ = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        if terminated or truncated:
            env.reset()
        if i % 2_000 == 0:
            samples.append(_rss_mb())
    env.close()
    assert samples[-1] - samples[0] <= 10.0, samples
    assert samples[-1] - built <= 50.0, (built, samples)
