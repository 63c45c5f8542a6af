"""Every cost-bearing number has a bound that names its cost: the plant time step, the control rate
(and the plant steps one env step simulates), the episode length and the hydroelastic mesh
resolution. A value past a bound is refused at once, by name, with the bound and its cost; the
refusal itself costs nothing (no env is built, no step is run)."""

from __future__ import annotations

import time

import gymnasium as gym
import pytest

import sphere_env  # noqa: F401 - registers the ids
from sphere_env.envs.kwargs import check_episode_length
from sphere_env.evaluation.evaluate import main as evaluate_main
from sphere_env.physics import TwinConfig
from sphere_env.training.train import main as train_main

RAMP = "sphere_env/RampDescent-v3"


@pytest.mark.parametrize(
    "kwargs, needles",
    [
        (dict(time_step_s=1e-9), ["field 'time_step_s' = 1e-09", "[0.0001, 0.05] s", "cost: a simulated second"]),
        (dict(control_frequency_hz=0.5), ["field 'control_frequency_hz' = 0.5", "[1, 1000] Hz", "cost:"]),
        (
            dict(control_frequency_hz=1.0, time_step_s=0.0002),
            ["field 'control_frequency_hz' = 1.0", "5000 plant steps", "at most 1000", "cost:"],
        ),
    ],
    ids=["time_step_s-1e-9", "control_frequency_hz-0.5", "plant-steps-per-action"],
)
def test_make_refuses_a_costly_value_at_once(kwargs, needles):
    t0 = time.perf_counter()
    with pytest.raises(ValueError) as err:
        gym.make(RAMP, **kwargs)
    assert time.perf_counter() - t0 < 5.0
    assert all(n in str(err.value) for n in needles), str(err.value)


def test_a_mesh_finer_than_its_bound_is_refused_with_its_cost():
    with pytest.raises(ValueError, match=r"field 'resolution_hint_m' = 1e-06.*\[0.002, 0.3\] m.*cost: the facets"):
        TwinConfig(shell_model="hydroelastic", resolution_hint_m=1e-6)


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"max_episode_steps": 10**12}, "max_episode_steps' = 1000000000000"),
        ({"max_episode_steps": -1}, "max_episode_steps' = -1"),  # gymnasium's "no time limit"
        ({"control_frequency_hz": 1.0}, "control_frequency_hz' = 1.0"),  # 600 steps at 1 Hz: 600 s
    ],
    ids=["steps-1e12", "no-limit", "slow-control"],
)
def test_an_episode_longer_than_its_bound_is_refused(kwargs, field):
    with pytest.raises(ValueError, match=rf"field 'env_kwargs\.{field}.*at most 300 simulated s.*cost: 60000 plant"):
        check_episode_length(RAMP, kwargs)


def test_train_and_evaluate_refuse_a_long_episode_by_name(tmp_path, capsys):
    for main, argv in (
        (train_main, ["--env", RAMP, "--run-dir", str(tmp_path / "run"), "--env-kwargs", "max_episode_steps:10000000"]),
        (
            evaluate_main,
            ["--controller", "zero", "--out", str(tmp_path / "eval"), "--env-kwargs", "max_episode_steps:-1"],
        ),
    ):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        err = capsys.readouterr().err
        assert exc.value.code == 2 and "field 'env_kwargs.max_episode_steps'" in err, err
    assert not (tmp_path / "run").exists() and not (tmp_path / "eval").exists()
