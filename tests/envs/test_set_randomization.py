"""SphereEnv.set_randomization: validated like the kwarg, effective from the next reset, reachable
through env_method and set_attr on the vector envs training uses."""

from __future__ import annotations

import copy
from functools import partial

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401 - registers the ids

RAMP = "sphere_env/RampDescent-v2"


def test_set_randomization_takes_effect_at_the_next_reset_and_bad_specs_change_nothing():
    env = gym.make(RAMP, shell_model="point", randomization="default")
    _, info = env.reset(seed=0)
    before = info["pressure_kpa"]
    resolved = env.unwrapped.set_randomization({"pressure_kpa": 7.5})
    assert resolved is env.unwrapped.randomization
    _, _, _, _, info = env.step(np.zeros(2, np.float32))
    assert info["pressure_kpa"] == before != 7.5  # the running episode keeps its pressure
    _, info = env.reset(seed=1)
    assert info["pressure_kpa"] == 7.5

    spec = env.unwrapped.randomization
    for bad, field in (
        ({"pressure_kpa": [1.0, 50.0]}, "randomization: field 'pressure_kpa'"),
        ({"ground_friction": [0.9, 0.5]}, "randomization: field 'ground_friction'"),
        ({"no_such_parameter": 1.0}, "randomization: unknown field 'no_such_parameter'"),
        ("fancy", "randomization: field 'base' = 'fancy'"),
    ):
        with pytest.raises(ValueError, match=rf"^{field}"):
            env.unwrapped.set_randomization(bad)
        assert env.unwrapped.randomization is spec
    with pytest.raises(ValueError, match=r"^randomization: field 'pressure_kpa' = 99\.0"):
        env.unwrapped.randomization = {"pressure_kpa": 99.0}  # assignment is set_randomization
    assert env.unwrapped.randomization is spec
    _, info = env.reset(seed=2)
    assert info["pressure_kpa"] == 7.5
    # copies are rebuilt from the constructor arguments: they carry the new spec
    assert copy.deepcopy(env.unwrapped).randomization == spec


def test_randomization_kwarg_and_method_share_one_validation():
    """The same spec gives the same resolved value and the same error either way."""
    env = gym.make(RAMP, shell_model="point").unwrapped
    good = {"pressure_kpa": {"distribution": "uniform"}, "ground_friction": [0.8, 1.0]}
    assert (
        env.set_randomization(good) == gym.make(RAMP, shell_model="point", randomization=good).unwrapped.randomization
    )
    bad = {"pressure_kpa": [3.0, 20.0]}
    with pytest.raises(ValueError) as from_kwarg:
        gym.make(RAMP, shell_model="point", randomization=bad)
    with pytest.raises(ValueError) as from_method:
        env.set_randomization(bad)
    assert str(from_kwarg.value) == str(from_method.value)


def _vec_envs():
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    from sphere_env.training.env_factory import make_env
    from sphere_env.training.vec_env import BatchedSubprocVecEnv, ThreadedVecEnv

    fns = [partial(make_env, RAMP, {"shell_model": "point"}, seed) for seed in (0, 1)]
    return {
        "dummy": lambda: DummyVecEnv(fns),
        "threaded": lambda: ThreadedVecEnv(fns, 2),
        "subproc": lambda: SubprocVecEnv(fns),
        "batched": lambda: BatchedSubprocVecEnv(fns, 2),
    }


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["dummy", "threaded", "subproc", "batched"])
def test_env_method_and_set_attr_reach_the_env(kind):
    venv = _vec_envs()[kind]()
    try:
        venv.env_method("set_randomization", {"pressure_kpa": 5.0})
        venv.reset()
        assert [i["pressure_kpa"] for i in venv.reset_infos] == [5.0, 5.0]
        venv.set_attr("randomization", {"pressure_kpa": 6.0}, indices=[1])
        venv.reset()
        assert [i["pressure_kpa"] for i in venv.reset_infos] == [5.0, 6.0]
        assert venv.get_attr("randomization")[1].terms[0].distribution.value == 6.0
        if kind in ("dummy", "threaded"):  # in-process: the env's error reaches the caller
            with pytest.raises(ValueError, match=r"^randomization: field 'pressure_kpa' = 60\.0"):
                venv.set_attr("randomization", {"pressure_kpa": 60.0})
            with pytest.raises(ValueError, match=r"^randomization: field 'pressure_kpa' = 60\.0"):
                venv.env_method("set_randomization", {"pressure_kpa": 60.0})
            venv.reset()
            assert [i["pressure_kpa"] for i in venv.reset_infos] == [5.0, 6.0]
    finally:
        venv.close()
