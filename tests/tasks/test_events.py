"""The event manager and the sensing/actuation parameters it sets (latency, motor saturation,
observation noise), and pressures beyond the calibrated range: each checked against the real
Drake twin by an equivalent plain run."""

from __future__ import annotations

import re

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401
from sphere_env.params import ParameterSpace
from sphere_env.tasks.events import EventManager
from sphere_env.tasks.randomization import RandomizationSpec

ENV = "sphere_env/RampDescent-v3"


def _actions(n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1, 1, size=(n, 2)).astype(np.float32)


def _run(env, actions, options=None, seed=5):
    obs, _ = env.reset(seed=seed, options=options)
    out, torques = [obs], []
    for a in actions:
        obs, _, term, trunc, info = env.step(a)
        out.append(obs)
        torques.append(info["motor_torque_nm"])
        assert not (term or trunc)
    return np.array(out), np.array(torques)


@pytest.mark.parametrize("k", [1, 2])
def test_latency_applies_the_action_of_k_steps_ago(k):
    """With action_latency_steps = k the motors get zero torque for k steps, then each action k
    steps late: the run equals a latency-free run fed the delayed action sequence."""
    acts = _actions(20)
    delayed = np.vstack([np.zeros((k, 2), np.float32), acts[:-k]])
    env = gym.make(ENV, shell_model="injected", randomization="off")
    late, tau_late = _run(env, acts, options={"action_latency_steps": k})
    plain, tau_plain = _run(env, delayed)
    assert np.all(tau_late[:k] == 0.0)
    np.testing.assert_array_equal(tau_late, tau_plain)
    np.testing.assert_allclose(late[:, :11], plain[:, :11], rtol=0, atol=1e-9)


def test_motor_saturation_caps_the_torque_like_a_clipped_action():
    acts = _actions(20, seed=1)
    env = gym.make(ENV, shell_model="point", randomization={"motor_torque_scale": 0.4})
    capped, tau = _run(env, acts)
    plain, tau_plain = _run(
        gym.make(ENV, shell_model="point", randomization="off"), np.clip(acts.astype(np.float64), -0.4, 0.4)
    )
    assert np.max(np.abs(tau[:, 0])) <= 0.4 * 20.0 + 1e-12 and np.max(np.abs(tau[:, 1])) <= 0.4 * 22.0 + 1e-12
    np.testing.assert_array_equal(tau, tau_plain)
    np.testing.assert_allclose(capped[:, :11], plain[:, :11], rtol=0, atol=1e-9)


def test_observation_noise_as_a_parameter_has_the_drawn_scale():
    """Noise drawn per episode: the observed minus the noise-free observation has σ ≈ scale × the
    default σ of each measured component (400 samples: within 20 %)."""
    from sphere_env.tasks.observation import DEFAULT_NOISE_STD

    acts = np.zeros((400, 2), np.float32)
    noisy, _ = _run(gym.make(ENV, randomization={"observation_noise_scale": [3.0, 3.0]}), acts)
    clean, _ = _run(gym.make(ENV, randomization="off"), acts)
    sigma = np.std(noisy[1:, :11] - clean[1:, :11], axis=0)
    np.testing.assert_allclose(sigma, 3.0 * DEFAULT_NOISE_STD, rtol=0.2)


def test_events_report_what_fired_and_the_schedule_moves_pressure():
    spec = {
        "pressure_kpa": 8.0,
        "ground_friction": {"distribution": "uniform", "low": 0.8, "high": 1.2, "mode": "interval", "interval_s": 0.5},
        "pressure_schedule": {"rate_kpa_per_s": -2.0},
    }
    env = gym.make(ENV, randomization=spec)
    _, info = env.reset(seed=0)
    names = {"reset:pressure_kpa", "interval:ground_friction", "schedule:pressure_kpa"}
    assert set(info["events"]) == names == {e["name"] for e in env.unwrapped.events}  # all draw at reset
    fired, mu = [], []
    for _ in range(60):  # 1.2 s
        _, _, _, _, info = env.step(np.zeros(2, np.float32))
        fired.append(info["events"])
        mu.append(info["params"]["ground_friction"])
    assert sum("interval:ground_friction" in f for f in fired) == 2  # at 0.5 s and 1.0 s
    assert len(set(mu)) == 3
    # the schedule ran 1.18 s at -2 kPa/s when the last step started
    assert info["params"]["pressure_kpa"] == pytest.approx(8.0 - 2.0 * 1.18, abs=0.011)
    assert env.unwrapped.twin.pressure_kpa == info["params"]["pressure_kpa"]


def test_draw_changes_nothing_until_started():
    spec = RandomizationSpec.parse(
        {"pressure_kpa": [3.0, 14.0], "action_latency_steps": {"distribution": "choice", "values": [0, 1, 2]}}
    )
    nominal = {"pressure_kpa": 4.0, "action_latency_steps": 0, "observation_noise_scale": 0.0}
    mgr = EventManager(spec, nominal, ParameterSpace.for_calibration(3.0, 14.0))
    a = mgr.draw(np.random.default_rng(1))
    b = mgr.draw(np.random.default_rng(1))
    assert a == b and mgr.params == {} and not mgr.active
    assert isinstance(a["action_latency_steps"], int) and 3.0 <= a["pressure_kpa"] <= 14.0
    mgr.start(a)
    assert mgr.params == a


@pytest.mark.parametrize(
    "spec, field",
    [
        ({"action_latency_steps": 2.5}, "randomization: field 'action_latency_steps' = 2.5"),
        ({"action_latency_steps": 9}, "randomization: field 'action_latency_steps' = 9"),
        (
            {"action_latency_steps": {"distribution": "choice", "values": [1], "mode": "interval", "interval_s": 1}},
            "randomization: field 'action_latency_steps.mode' = 'interval'",
        ),
        ({"motor_torque_scale": 0.0}, "randomization: field 'motor_torque_scale' = 0.0"),
        ({"motor_torque_scale": [0.5, 1.5]}, "randomization: field 'motor_torque_scale[1]' = 1.5"),
    ],
)
def test_bad_fault_specs_are_refused_naming_the_field(spec, field):
    env = gym.make(ENV)
    with pytest.raises(ValueError, match=re.escape(field)):
        env.unwrapped.set_randomization(spec)


@pytest.mark.parametrize("shell_model", ["point", "injected", "hydroelastic"])
def test_pressures_beyond_the_calibrated_range_need_extrapolation_and_run(shell_model):
    env = gym.make(ENV, shell_model=shell_model, randomization="off")
    with pytest.raises(
        ValueError,
        match=r"^field 'options\.pressure_kpa' = 1\.5: .*; allowed: .*\[3\.0, 14\.0\] kPa, the calibrated range",
    ):
        env.reset(seed=0, options={"pressure_kpa": 1.5})
    env = gym.make(ENV, shell_model=shell_model, randomization="off", pressure_extrapolation_kpa=3.5)
    for p in (1.5, 17.5):
        _, info = env.reset(seed=0, options={"pressure_kpa": p})
        for _ in range(100):
            _, _, term, trunc, info = env.step(np.zeros(2, np.float32))
            assert not trunc, info.get("truncation_reason")
        assert info["params"]["pressure_kpa"] == p and info["omega_d"] > 0.5  # rolls downhill


def test_the_shell_model_is_a_parameter_drawn_per_episode():
    """``randomization={"shell_model": [...]}``: each episode runs on a drawn shell, reported in
    ``info`` and the privileged one-hot, and is the episode a plain env of that shell runs."""
    acts = _actions(15, seed=2)
    opts = {"pressure_kpa": 6.0, "omega_ref": 3.0, "omega_ref_after": 3.0}
    mix = gym.make(ENV, randomization={"shell_model": ["point", "injected"]}, observe_shell_model=True)
    names = mix.unwrapped.observation_layout.names
    seen = set()
    for seed in range(6):
        obs, info = mix.reset(seed=seed, options=opts)
        shell = info["shell_model"]
        seen.add(shell)
        hot = obs[[names.index(f"shell_{m}") for m in ("point", "injected", "hydroelastic")]]
        assert list(hot) == [float(shell == m) for m in ("point", "injected", "hydroelastic")]
        out = [obs]
        for a in acts:
            out.append(mix.step(a)[0])
        plain = gym.make(ENV, shell_model=shell, randomization="off", observe_shell_model=True)
        ref, _ = _run(plain, acts, options=opts, seed=seed)
        np.testing.assert_allclose(np.array(out)[:, :11], ref[:, :11], rtol=0, atol=1e-9)
    assert seen == {"point", "injected"}


def test_a_reset_option_picks_the_shell_and_hydroelastic_pressures_snap_to_its_grid():
    env = gym.make(ENV, randomization="off")  # injected by default
    _, info = env.reset(seed=0, options={"shell_model": "hydroelastic", "pressure_kpa": 5.2})
    assert info["shell_model"] == "hydroelastic" and info["pressure_kpa"] == 5.0  # the 0.5 kPa grid from 3
    assert env.unwrapped.twin.config.shell_model == "hydroelastic"
    _, info = env.reset(seed=0, options={"pressure_kpa": 5.2})
    assert info["shell_model"] == "injected" and info["pressure_kpa"] == 5.2


@pytest.mark.parametrize(
    "spec, needle",
    [
        (
            {"shell_model": "rubber"},
            "randomization: field 'shell_model' = 'rubber': Input should be 'point', 'injected' or 'hydroelastic'",
        ),
        ({"shell_model": ["point", "jelly"]}, "randomization: field 'shell_model[1]' = 'jelly'"),
        (
            {"shell_model": {"distribution": "uniform", "values": ["point"]}},
            "randomization: field 'shell_model.distribution' = 'uniform': Input should be 'fixed' or 'choice'",
        ),
        ({"shell_model": 3}, "randomization: field 'shell_model' = 3"),
    ],
)
def test_bad_shell_model_specs_are_refused_naming_the_field(spec, needle):
    with pytest.raises(ValueError, match=re.escape(needle)):
        gym.make(ENV).unwrapped.set_randomization(spec)
