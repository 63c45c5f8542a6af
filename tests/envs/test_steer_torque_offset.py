"""``steer_torque_offset_nm``, a parameter added as one registry record and its action stage
(:mod:`sphere_env.envs.stages`): a constant bias of the steer motor's torque, within the motor's
saturation. Randomized in every mode, reported in ``info["params"]``, acting on the real Drake twin
like the steer torque it adds, and refused out of bounds by name."""

from __future__ import annotations

import re

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401

ENV = "sphere_env/RampDescent-v3"
NAME = "steer_torque_offset_nm"


def _run(env, action, n=25, seed=0, options=None):
    obs, info = env.reset(seed=seed, options=options)
    obs_out, infos = [obs], [info]
    for _ in range(n):
        obs, _, term, trunc, info = env.step(np.asarray(action, np.float32))
        assert not (term or trunc), info.get("truncation_reason")
        obs_out.append(obs)
        infos.append(info)
    return np.array(obs_out), infos


def test_a_positive_offset_turns_the_steer_joint_like_a_positive_steer_action():
    """+5 N m with zero action is the steer torque of action 0.25 (of the 20 N m limit): the same
    torques and the same motion, away from the zero-torque run in the same direction."""
    offset, off_infos = _run(gym.make(ENV, shell_model="point", randomization={NAME: 5.0}), (0.0, 0.0))
    action, act_infos = _run(gym.make(ENV, shell_model="point", randomization="off"), (0.25, 0.0))
    zero, zero_infos = _run(gym.make(ENV, shell_model="point", randomization="off"), (0.0, 0.0))
    assert all(i["params"][NAME] == 5.0 for i in off_infos) and zero_infos[-1]["params"][NAME] == 0.0
    np.testing.assert_array_equal([i["motor_torque_nm"] for i in off_infos[1:]], [[5.0, 0.0]] * 25)
    np.testing.assert_array_equal(offset, action)
    moved = off_infos[-1]["phi"] - zero_infos[-1]["phi"]
    assert abs(moved) > 1e-3 and np.sign(moved) == np.sign(act_infos[-1]["phi"] - zero_infos[-1]["phi"])


def test_the_offset_stays_within_the_motors_saturation():
    env = gym.make(ENV, shell_model="point", randomization={NAME: 5.0, "motor_torque_scale": 0.5})
    _, infos = _run(env, (1.0, 0.0), n=3)
    assert all(i["motor_torque_nm"][0] == 10.0 for i in infos[1:])  # 0.5 × 20 N m, the offset cannot exceed it
    _, infos = _run(env, (-1.0, 0.0), n=3)
    assert all(i["motor_torque_nm"][0] == -5.0 for i in infos[1:])  # −10 + 5


def test_the_offset_is_randomized_in_every_mode():
    reset = gym.make(ENV, shell_model="point", randomization={NAME: [-2.0, 2.0]})
    drawn = {_run(reset, (0.0, 0.0), n=1, seed=s)[1][0]["params"][NAME] for s in range(4)}
    assert len(drawn) == 4 and all(-2.0 <= v <= 2.0 for v in drawn)

    interval = gym.make(
        ENV,
        shell_model="point",
        randomization={NAME: {"low": -2.0, "high": 2.0, "mode": "interval", "interval_s": 0.2}},
    )
    _, infos = _run(interval, (0.0, 0.0), n=25)
    assert len({i["params"][NAME] for i in infos}) == 3  # at reset, 0.2 s and 0.4 s
    # a step's torque takes the offset in force when it starts (before that step's events)
    assert all(i["motor_torque_nm"][0] == before["params"][NAME] for before, i in zip(infos, infos[1:]))

    schedule = gym.make(ENV, shell_model="point", randomization={NAME: {"mode": "schedule", "rate_per_s": 10.0}})
    _, infos = _run(schedule, (0.0, 0.0), n=30)
    values = [i["params"][NAME] for i in infos]
    assert values[:2] == [0.0, 0.0] and values[2] == pytest.approx(0.2) and values[-1] == 5.0  # clipped at the bound
    assert "schedule:steer_torque_offset_nm" in infos[2]["events"]


@pytest.mark.parametrize(
    "where, value, needle",
    [
        (
            "randomization",
            6.0,
            "randomization: field 'steer_torque_offset_nm' = 6.0: Input should be less than or equal to 5; allowed:",
        ),
        ("randomization", [-9.0, 0.0], "randomization: field 'steer_torque_offset_nm[0]' = -9.0"),
        ("options", -5.5, "field 'options.steer_torque_offset_nm' = -5.5: Input should be greater than or equal to -5"),
    ],
)
def test_an_offset_out_of_bounds_is_refused_by_name(where, value, needle):
    env = gym.make(ENV, shell_model="point")
    with pytest.raises(ValueError, match=re.escape(needle)):
        if where == "options":
            env.reset(seed=0, options={NAME: value})
        else:
            env.unwrapped.set_randomization({NAME: value})
