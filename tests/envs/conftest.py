"""Env test helpers."""

import numpy as np

import sphere_env  # noqa: F401  (registers the ids)
from sphere_env.params import SHELL_MODELS  # noqa: F401  (imported by the env tests)

ENV_IDS = ("sphere_env/RampDescent-v0", "sphere_env/Roll-v0")


def rollout(env, n_steps, seed, action_seed=123, actions=None):
    """Seeded random-action rollout; returns the list of (obs, reward, terminated, truncated, info)."""
    rng = np.random.default_rng(action_seed)
    out = [env.reset(seed=seed)]
    for _ in range(n_steps):
        a = rng.uniform(-1, 1, 2).astype(np.float32) if actions is None else actions
        step = env.step(a)
        out.append(step)
        if step[2] or step[3]:
            out.append(env.reset())
    return out
