"""Mode ``schedule`` for any numeric scalar parameter that may change within an episode:
value(t) = value at reset + rate · max(t − delay_s, 0), clipped to the parameter's bounds, the rate
drawn once per episode; checked on the real Drake env (the twin's own parameter) and on the event
manager alone; bad specs refused by name."""

from __future__ import annotations

import math
import re

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401
from sphere_env.params import PARAMETERS, ParameterSpace, schedule_rate
from sphere_env.tasks.events import EventManager
from sphere_env.tasks.randomization import RandomizationSpec

ENV = "sphere_env/RampDescent-v3"
PERIOD_S = 0.02  # the control period at 50 Hz
SPACE = ParameterSpace.for_calibration(3.0, 14.0)


def _episode(env, n, seed, action=(0.0, 0.0)):
    _, info = env.reset(seed=seed)
    infos = [info]
    for _ in range(n):
        _, _, term, trunc, info = env.step(np.asarray(action, np.float32))
        assert not (term or trunc), info.get("truncation_reason")
        infos.append(info)
    return infos


def test_a_friction_scale_schedule_moves_the_twins_parameter_as_the_formula_says():
    spec = {
        "steer_friction_scale": {
            "distribution": "uniform",
            "low": 0.9,
            "high": 1.1,
            "mode": "schedule",
            "rate_per_s": [-1.0, -0.5],
            "delay_s": 0.2,
        }
    }
    env = gym.make(ENV, shell_model="point", randomization=spec)
    _, info = env.reset(seed=3)
    p = info["params"]
    v0, rate = p["steer_friction_scale"], p["steer_friction_scale_rate_per_s"]
    assert 0.9 <= v0 <= 1.1 and -1.0 <= rate <= -0.5  # friction falling as the joint's lubricant warms
    assert info["events"] == ["schedule:steer_friction_scale"]
    twin = env.unwrapped.twin
    assert twin.params["steer_friction_scale"] == v0
    fired = []
    for k in range(40):  # the step starting at t = k · 0.02 s applies value(t)
        _, _, _, _, info = env.step(np.zeros(2, np.float32))
        expected = v0 + rate * max(k * PERIOD_S - 0.2, 0.0)
        assert info["params"]["steer_friction_scale"] == pytest.approx(expected, abs=1e-12)
        assert twin.params["steer_friction_scale"] == info["params"]["steer_friction_scale"]
        fired.append("schedule:steer_friction_scale" in info["events"])
    # nothing moves until the delay has passed, then the value changes at every step
    assert not any(fired[:11]) and all(fired[11:])
    assert twin.params["steer_friction_scale"] < v0 - 0.5 * 0.5


def test_the_same_seed_gives_the_same_schedule_and_another_seed_another():
    spec = {"ground_friction": {"mode": "schedule", "rate_per_s": {"distribution": "normal", "mean": 0.0, "std": 0.5}}}
    env = gym.make(ENV, shell_model="point", randomization=spec)

    def trace(seed):
        return [i["params"]["ground_friction"] for i in _episode(env, 10, seed)]

    a, b, c = trace(7), trace(7), trace(8)
    assert a == b and a != c
    assert a[0] == PARAMETERS["ground_friction"].nominal  # no draw of its own: starts at the nominal value


def test_schedules_clip_to_the_bounds_and_draw_after_every_terms_value():
    spec = RandomizationSpec.parse(
        {
            "payload_mass_kg": {"mode": "schedule", "value": 1.0, "rate_per_s": 100.0},
            "ground_friction": {"mode": "schedule", "rate_per_s": [5.0, 6.0], "delay_s": 0.1},
            "drive_friction_scale": [0.8, 1.2],
        }
    )
    nominal = {name: SPACE.nominal(name) for name in PARAMETERS if PARAMETERS[name].applied_by}
    mgr = EventManager(spec, nominal, SPACE)
    rng = np.random.default_rng(4)
    params = mgr.draw(rng)
    # the order of draws: the terms' values in the spec's order, then the schedules' rates
    ref = np.random.default_rng(4)
    assert params["drive_friction_scale"] == float(ref.uniform(0.8, 1.2, size=1)[0])
    assert params["ground_friction_rate_per_s"] == float(ref.uniform(5.0, 6.0, size=1)[0])
    assert params["payload_mass_rate_kg_per_s"] == 100.0 and params["pressure_rate_kpa_per_s"] == 0.0
    mgr.start(params)
    assert mgr.active
    changed, fired = mgr.step(0.1, rng)
    assert changed == {"payload_mass_kg": 11.0} and fired == ["schedule:payload_mass_kg"]
    changed, fired = mgr.step(1.0, rng)
    assert changed["payload_mass_kg"] == 50.0  # the registry's upper bound
    assert changed["ground_friction"] == math.nextafter(2.0, 0.0)  # an open bound: the nearest float inside
    assert fired == ["schedule:payload_mass_kg", "schedule:ground_friction"]
    assert mgr.step(1.2, rng) == ({}, [])  # at the bounds: nothing changes any more
    assert [e["name"] for e in mgr.describe()] == [
        "schedule:payload_mass_kg",
        "schedule:ground_friction",
        "reset:drive_friction_scale",
    ]
    assert mgr.describe()[1] == {
        "name": "schedule:ground_friction",
        "mode": "schedule",
        "parameter": "ground_friction",
        "delay_s": 0.1,
    }


def test_an_env_parameter_schedule_acts_where_the_env_applies_it():
    """A motor saturation falling at 1 /s from 1: the applied torque follows the cap. The env reads
    its actuation parameters when it computes a step's torque, before that step's events (as for an
    interval event), so the torque of step k is capped by the value the events of step k − 1 set."""
    spec = {"motor_torque_scale": {"mode": "schedule", "rate_per_s": -1.0}}
    env = gym.make(ENV, shell_model="point", randomization=spec)
    infos = _episode(env, 30, seed=0, action=(1.0, -1.0))
    for k, info in enumerate(infos[1:]):
        assert info["params"]["motor_torque_scale"] == pytest.approx(1.0 - k * PERIOD_S, abs=1e-12)
        cap = 1.0 - max(k - 1, 0) * PERIOD_S
        np.testing.assert_allclose(info["motor_torque_nm"], [20.0 * cap, 22.0 * cap], rtol=0, atol=1e-9)


def test_pressure_kpa_with_mode_schedule_is_the_pressure_schedule():
    """The general spelling of the pressure's schedule runs the same episode as ``pressure_schedule``."""
    old = {"pressure_kpa": [6.0, 10.0], "pressure_schedule": {"rate_kpa_per_s": [-3.0, -1.0], "delay_s": 0.1}}
    new = {"pressure_kpa": {"low": 6.0, "high": 10.0, "mode": "schedule", "rate_per_s": [-3.0, -1.0], "delay_s": 0.1}}
    runs = []
    for spec in (old, new):
        env = gym.make(ENV, shell_model="injected", randomization=spec)
        runs.append([(i["params"], i["events"][-1:], i["theta"]) for i in _episode(env, 30, seed=11)[1:]])
        assert env.unwrapped.events[-1] == {
            "name": "schedule:pressure_kpa",
            "mode": "schedule",
            "parameter": "pressure_kpa",
            "delay_s": 0.1,
        }
    assert runs[0] == runs[1]
    assert runs[0][-1][0]["pressure_kpa"] < runs[0][0][0]["pressure_kpa"]
    assert schedule_rate("pressure_kpa").name == "pressure_rate_kpa_per_s"


@pytest.mark.parametrize(
    "spec, needle",
    [
        (
            {"shell_model": {"value": "point", "mode": "schedule", "rate_per_s": 1.0}},
            "randomization: field 'shell_model.mode' = 'schedule': Input should be 'reset'; allowed: ['reset'] "
            "(shell_model changes only between episodes)",
        ),
        (
            {"payload_com_offset_m": {"mode": "schedule", "rate_per_s": 0.1}},
            "randomization: field 'payload_com_offset_m.mode' = 'schedule': Input should be 'reset' or 'interval'; "
            "allowed: ['reset', 'interval'] (payload_com_offset_m is a vector: no schedule)",
        ),
        (
            {"action_latency_steps": {"mode": "schedule", "rate_per_s": 1.0}},
            "randomization: field 'action_latency_steps.mode' = 'schedule': Input should be 'reset'",
        ),
        ({"time_step_s": {"mode": "schedule", "rate_per_s": 1.0}}, "randomization: unknown field 'time_step_s'"),
        (
            {"pressure_rate_kpa_per_s": {"mode": "schedule", "rate_per_s": 1.0}},
            "randomization: unknown field 'pressure_rate_kpa_per_s'",
        ),
        (
            {"ground_friction": {"mode": "schedule", "rate_per_s": 0.1, "delay_s": -1.0}},
            "randomization: field 'ground_friction.delay_s' = -1.0: Input should be greater than or equal to 0",
        ),
        (
            {"ground_friction": {"mode": "schedule", "rate_per_s": "fast"}},
            "randomization: field 'ground_friction.rate_per_s' = 'fast'",
        ),
        (
            {"ground_friction": {"mode": "schedule", "rate_per_s": [0.2, 0.1]}},
            "randomization: field 'ground_friction.rate_per_s' = [0.2, 0.1]",
        ),
        (
            {"ground_friction": {"mode": "schedule"}},
            "randomization: field 'ground_friction.rate_per_s' is missing: mode 'schedule' needs a rate of change",
        ),
        (
            {"ground_friction": {"value": 1.0, "rate_per_s": 0.1}},
            "randomization: field 'ground_friction.rate_per_s' = 0.1 is only for mode 'schedule'; allowed: leave it out for "
            "mode 'reset'",
        ),
        (
            {"ground_friction": {"value": 1.0, "mode": "interval", "interval_s": 1.0, "delay_s": 1.0}},
            "randomization: field 'ground_friction.delay_s' = 1.0 is only for mode 'schedule'; allowed: leave it out for "
            "mode 'interval'",
        ),
        (
            {"ground_friction": {"value": 1.0, "mode": "schedule", "rate_per_s": 0.1, "interval_s": 1.0}},
            "randomization: field 'ground_friction.interval_s' = 1.0 is only for mode 'interval'; allowed: leave it out for "
            "mode 'schedule'",
        ),
        (
            {"ground_friction": {"distribution": None}},
            "randomization: field 'ground_friction.distribution' = None: only mode 'schedule' may leave out the draw",
        ),
        (
            {"pressure_kpa": {"mode": "schedule", "rate_per_s": -0.1}, "pressure_schedule": {"rate_kpa_per_s": -0.1}},
            "randomization: field 'pressure_schedule' = {'rate_kpa_per_s': -0.1}: 'pressure_kpa' has mode 'schedule' "
            "already; allowed: one pressure schedule",
        ),
    ],
)
def test_bad_schedule_specs_are_refused_by_name_and_change_nothing(spec, needle):
    env = gym.make(ENV, shell_model="point")
    before = env.unwrapped.randomization
    with pytest.raises(ValueError, match=re.escape(needle)):
        env.unwrapped.set_randomization(spec)
    assert env.unwrapped.randomization is before
    with pytest.raises(ValueError, match=re.escape(needle)):
        gym.make(ENV, shell_model="point", randomization=spec)


def test_a_schedule_round_trips_through_the_spec_object_and_replaces_a_presets_pressure_schedule():
    spec = RandomizationSpec.parse(
        {
            "base": "full",
            "steer_friction_scale": {"mode": "schedule", "rate_per_s": 0.1},
            "pressure_kpa": {"distribution": "uniform", "mode": "schedule", "rate_per_s": [-0.2, 0.0]},
        }
    )
    assert spec.pressure_schedule is None
    assert RandomizationSpec.parse(spec) == spec
    term = next(t for t in spec.terms if t.parameter == "steer_friction_scale")
    assert term.distribution is None and term.mode == "schedule" and term.delay_s == 0.0


def test_a_schedule_that_can_raise_friction_is_checked_for_stability_at_the_bound():
    """Friction torques are explicit: a schedule that may rise can reach the registry bound (10 ×),
    where the default steer friction law diverges at 5 ms, so it is refused; a falling one is not."""
    from sphere_env.envs.twins import largest

    with pytest.raises(ValueError, match=r"steer_friction_scale 10\) diverges"):
        gym.make(
            ENV, shell_model="point", randomization={"steer_friction_scale": {"mode": "schedule", "rate_per_s": 0.1}}
        )

    rise = RandomizationSpec.parse(
        {"steer_friction_scale": {"value": 1.0, "mode": "schedule", "rate_per_s": [-0.1, 0.1]}}
    )
    fall = RandomizationSpec.parse({"steer_friction_scale": {"value": 1.2, "mode": "schedule", "rate_per_s": -0.1}})
    assert largest(rise, "steer_friction_scale") == PARAMETERS["steer_friction_scale"].high
    assert largest(fall, "steer_friction_scale") == 1.2
