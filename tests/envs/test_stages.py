"""The env's action and sensor stages (:mod:`sphere_env.envs.stages`): one per parameter the env
applies, each a no-op at its neutral value, and together the torques and observations the
environment produced when it applied these parameters inline in ``step()`` (the reference below
is that code, in the normalized action domain; bit for bit, signed zeros included). A seeded
rollout through the real simulation with every stage active in every mode is
``tests/envs/test_recorded_rollouts.py``'s case ``RampDescent-v3_point_stages``."""

from __future__ import annotations

from collections import deque

import numpy as np
import pytest

from sphere_env.envs.stages import (
    ACTION_STAGES,
    SENSOR_STAGES,
    ActionPipeline,
    ActionStage,
    SensorPipeline,
    StageContext,
    stage,
)
from sphere_env.params import ENV_PARAMETERS, PARAMETERS
from sphere_env.tasks.observation import DEFAULT_NOISE_STD, assemble_observation, observation_vector, sensor_readings

LIMITS = (20.0, 22.0)
CONTEXT = StageContext(LIMITS, DEFAULT_NOISE_STD)
NEUTRAL = {"action_latency_steps": 0, "motor_torque_scale": 1.0, "steer_torque_offset_nm": 0.0}


def _bits(tau) -> tuple[str, ...]:
    return tuple(float(t).hex() for t in tau)


class _Reference:
    """The actuation as ``SphereEnv.step`` computed it inline: latency on the clipped action, then
    saturation in [-1, 1], then × the limits, then the steer offset within the saturation."""

    def __init__(self, params):
        self.pending = deque([(0.0, 0.0)] * params["action_latency_steps"])

    def __call__(self, a0, a1, params):
        s0, s1 = a0, a1
        if params["action_latency_steps"]:
            self.pending.append((a0, a1))
            s0, s1 = self.pending.popleft()
        cap = params["motor_torque_scale"]
        if cap < 1.0:
            s0, s1 = min(max(s0, -cap), cap), min(max(s1, -cap), cap)
        tau = [s0 * LIMITS[0], -s1 * LIMITS[1]]
        if params["steer_torque_offset_nm"]:
            lim = cap * LIMITS[0]
            tau[0] = min(max(tau[0] + params["steer_torque_offset_nm"], -lim), lim)
        return tau


def test_every_parameter_the_env_applies_has_one_stage():
    staged = list(ACTION_STAGES) + list(SENSOR_STAGES)
    assert sorted(staged) == sorted(ENV_PARAMETERS)
    assert all(PARAMETERS[name].applied_by == "env" for name in staged)


def test_a_stage_is_registered_once_and_only_for_a_parameter_the_env_applies():
    class Twice(ActionStage):
        parameter = "motor_torque_scale"

    class TwinOne(ActionStage):
        parameter = "pressure_kpa"

    with pytest.raises(ValueError, match="'motor_torque_scale' already has a stage"):
        stage(Twice)
    with pytest.raises(ValueError, match="'pressure_kpa' is not applied by the environment"):
        stage(TwinOne)
    assert ACTION_STAGES["motor_torque_scale"] is not Twice and "pressure_kpa" not in ACTION_STAGES


@pytest.mark.parametrize("latency", [0, 1, 3])
@pytest.mark.parametrize("cap", [1.0, 0.6, 0.05])
@pytest.mark.parametrize("offset", [0.0, 3.0, -5.0])
def test_the_action_stages_give_the_inline_actuations_torques_bit_for_bit(latency, cap, offset):
    rng = np.random.default_rng([latency, int(cap * 100), int(offset + 10)])
    actions = [(0.0, 0.0), (-0.0, -0.0), (1.0, -1.0), (cap, -cap), (-cap, cap)]
    actions += [tuple(float(x) for x in np.clip(rng.uniform(-1.3, 1.3, 2), -1, 1)) for _ in range(40)]
    params = {"action_latency_steps": latency, "motor_torque_scale": cap, "steer_torque_offset_nm": offset}
    pipeline, reference = ActionPipeline(CONTEXT), _Reference(params)
    pipeline.reset(params)
    for a0, a1 in actions:
        assert _bits(pipeline(a0, a1, params)) == _bits(reference(a0, a1, params)), (a0, a1, params)


def test_the_action_stages_take_the_parameters_in_force_at_each_step():
    """Saturation and offset may change within an episode (interval and schedule events)."""
    params = dict(NEUTRAL, action_latency_steps=2)
    pipeline, reference = ActionPipeline(CONTEXT), _Reference(params)
    pipeline.reset(params)
    rng = np.random.default_rng(5)
    for _ in range(60):
        params["motor_torque_scale"] = float(rng.choice([1.0, rng.uniform(0.01, 1.0)]))
        params["steer_torque_offset_nm"] = float(rng.choice([0.0, rng.uniform(-5.0, 5.0)]))
        a0, a1 = (float(x) for x in rng.uniform(-1, 1, 2))
        assert _bits(pipeline(a0, a1, params)) == _bits(reference(a0, a1, params))


def test_latency_delays_the_torques_and_starts_from_a_zero_actions():
    pipeline = ActionPipeline(CONTEXT)
    pipeline.reset(dict(NEUTRAL, action_latency_steps=2))
    out = [pipeline(a, -a, NEUTRAL | {"action_latency_steps": 2}) for a in (0.5, 0.25, 1.0, -1.0)]
    assert _bits(out[0]) == _bits(out[1]) == _bits((0.0, -0.0))
    assert out[2:] == [(10.0, 11.0), (5.0, 5.5)]
    pipeline.reset(NEUTRAL)  # a new episode without latency: nothing pending
    assert pipeline(1.0, 1.0, NEUTRAL) == (20.0, -22.0)


def test_at_their_neutral_values_the_stages_change_nothing():
    pipeline = ActionPipeline(CONTEXT)
    pipeline.reset(NEUTRAL)
    assert pipeline(0.3, -0.7, NEUTRAL) == (0.3 * 20.0, 0.7 * 22.0)
    sensors, rng = SensorPipeline(CONTEXT), np.random.default_rng(0)
    sensors.reset({"observation_noise_scale": 0.0})
    before = rng.bit_generator.state
    readings = [float(i) for i in range(11)]
    assert sensors(readings, {"observation_noise_scale": 0.0}, rng) == readings
    assert rng.bit_generator.state == before  # no draw


class _State:
    theta, theta_dot, drive_angle, drive_rate, phi, phi_dot = 0.1, -0.2, 3.5, 1.0, 0.05, 0.3
    omega_d, heading_rate, gravity_in_pipe = 2.0, -0.1, np.array([0.1, -0.2, -0.97])
    pendulum_pitch, pendulum_pitch_rate = -0.3, 0.4


@pytest.mark.parametrize("extra", [(), ("pendulum_pitch", "pendulum_pitch_rate")])
def test_the_noise_stage_draws_once_per_reading_and_adds_it(extra):
    std = np.concatenate([DEFAULT_NOISE_STD, [0.005, 0.05][: len(extra)]])
    sensors = SensorPipeline(StageContext(LIMITS, std))
    params = {"observation_noise_scale": 2.0}
    got = observation_vector(sensors(sensor_readings(_State, extra), params, np.random.default_rng(3)), [1.5])
    noise = np.random.default_rng(3).normal(0.0, std * 2.0)
    want = assemble_observation(_State, [1.5], noise=noise, extra_names=extra)
    assert got.tobytes() == want.tobytes()
