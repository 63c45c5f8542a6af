"""Hostile inputs to the environments, one pytest case each (the cases of
``evaluation/experiments/robustness.py``): every bad ``gym.make`` kwarg, randomization spec, ``reset``
option and action is refused with a ``ValueError`` naming its field, and a refused ``reset`` or
``step`` leaves the running episode exactly as it was."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401
from sphere_env.evaluation.experiments.robustness import (
    BAD_ACTIONS,
    kwarg_cases,
    lockstep,
    option_cases,
    randomization_cases,
)

ENV_IDS = ("sphere_env/RampDescent-v0", "sphere_env/Roll-v0")


def _cases(fn):
    return [pytest.param(env_id, *(c if isinstance(c, tuple) else (c,)), id=f"{env_id.split('/')[1]}-{i}")
            for env_id in ENV_IDS for i, c in enumerate(fn(env_id))]


@pytest.mark.parametrize("env_id, kwargs, field", _cases(kwarg_cases))
def test_bad_make_kwargs_are_refused_by_name(env_id, kwargs, field):
    with pytest.raises(ValueError, match=field):
        gym.make(env_id, **{"shell_model": "point", **kwargs})


@pytest.mark.parametrize("env_id, spec", _cases(randomization_cases))
def test_bad_randomization_specs_are_refused_by_name(env_id, spec):
    with pytest.raises(ValueError, match="randomization"):
        gym.make(env_id, shell_model="point", randomization=spec)


@pytest.fixture(scope="module")
def running():
    """A running episode and its twin, per env id (stepped in lockstep to tell a changed env)."""
    pairs = {}
    for env_id in ENV_IDS:
        env, ref = (gym.make(env_id, shell_model="point", randomization="full", disable_env_checker=True)
                    for _ in range(2))
        for e in (env, ref):
            e.reset(seed=0)
        pairs[env_id] = (env, ref)
    return pairs


@pytest.mark.parametrize("env_id, options, field", _cases(option_cases))
def test_bad_reset_options_are_refused_and_change_nothing(running, env_id, options, field):
    env, ref = running[env_id]
    with pytest.raises(ValueError, match=field):
        env.reset(options=options)
    assert lockstep(env, ref)  # the episode carries on as if the reset had not been tried


@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize("name, action", BAD_ACTIONS, ids=[n for n, _ in BAD_ACTIONS])
def test_bad_actions_are_refused_and_change_nothing(running, env_id, name, action):
    env, ref = running[env_id]
    with pytest.raises(ValueError, match="action"):
        env.step(action)
    assert lockstep(env, ref)


def test_lockstep_tells_a_changed_episode_apart(running):
    """The check above can fail: two episodes at different pressures do not step alike."""
    env, ref = (gym.make("sphere_env/Roll-v0", shell_model="point") for _ in range(2))
    env.reset(seed=0, options={"pressure_kpa": 12.0})
    ref.reset(seed=0, options={"pressure_kpa": 4.0})
    assert not lockstep(env, ref)
    env.reset(seed=0, options={"pressure_kpa": 4.0})
    ref.reset(seed=0, options={"pressure_kpa": 4.0})
    assert lockstep(env, ref)
    assert np.isfinite(env.step(np.zeros(2, np.float32))[0]).all()
