"""Calibration-aware randomization: the shell calibration and the shell law's scales as drawn
parameters, checked against the twin they should produce."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401
from sphere_env.models.calibration_files import law_scale_intervals
from sphere_env.models.rigid_body import DEFAULT_URDF, RobotParameters
from sphere_env.models.shell import ShellCalibration

ENV_ID = "sphere_env/RampDescent-v3"


def _omega_d(env, seed: int, options: dict, steps: int = 100) -> np.ndarray:
    obs, info = env.reset(seed=seed, options=options)
    out = []
    for _ in range(steps):
        obs, _, terminated, truncated, info = env.step(np.array([0.1, 0.4], dtype=np.float32))
        out.append(info["omega_d"] if "omega_d" in info else obs[env.unwrapped.observation_layout["omega_d"]])
        if terminated or truncated:
            break
    return np.asarray(out)


def test_a_drawn_calibration_steps_exactly_as_an_env_built_with_it():
    drawn = gym.make(ENV_ID, shell_model="injected", randomization={"calibration": "free_robot"})
    built = gym.make(ENV_ID, shell_model="injected", calibration="free_robot", randomization="off")
    nominal = gym.make(ENV_ID, shell_model="injected", randomization="off")
    opts = {"pressure_kpa": 6.0}
    a, b, c = _omega_d(drawn, 3, opts), _omega_d(built, 3, opts), _omega_d(nominal, 3, opts)
    np.testing.assert_array_equal(a, b)
    assert np.max(np.abs(a - c)) > 1e-3  # the two calibrations differ in the drive direction too


def test_calibration_draws_switch_the_twin_between_episodes_and_are_reported():
    env = gym.make(
        ENV_ID,
        shell_model="injected",
        randomization={"calibration": {"distribution": "choice", "values": ["default", "free_robot"]}},
    )
    seen = set()
    for seed in range(12):
        _, info = env.reset(seed=seed)
        name = info["params"]["calibration"]
        assert env.unwrapped.twin.calibration.source.endswith(f"{name}.yaml")
        seen.add(name)
    assert seen == {"default", "free_robot"}


def test_shell_scales_multiply_the_injected_springs_and_dampers():
    env = gym.make(ENV_ID, shell_model="injected", randomization="off")
    _, _ = env.reset(seed=0, options={"pressure_kpa": 5.0})
    twin = env.unwrapped.twin
    base = twin.shell.law_gains("injected", 5.0)
    env.reset(seed=0, options={"pressure_kpa": 5.0, "shell_stiffness_scale": 1.3, "shell_damping_scale": 0.8})
    gains = np.asarray(twin._forces_context.get_numeric_parameter(0).get_value())[: len(base)]
    np.testing.assert_allclose(gains, base * np.array([1.3, 0.8, 0.8, 1.0, 1.3, 1.0, 1.3]))


def test_less_shell_damping_lets_the_injected_shell_roll_faster():
    env = gym.make(ENV_ID, shell_model="injected", randomization="off")
    stiff = _omega_d(env, 0, {"pressure_kpa": 5.0, "shell_damping_scale": 1.0})
    loose = _omega_d(env, 0, {"pressure_kpa": 5.0, "shell_damping_scale": 0.25})
    n = min(len(stiff), len(loose))
    assert np.mean(loose[:n]) > np.mean(stiff[:n])


def test_law_scale_intervals_follow_the_reported_fit_intervals():
    robot = RobotParameters.from_urdf(DEFAULT_URDF)
    free = ShellCalibration.load("free_robot")
    fit = free.raw["steer_fit"]["models"]["injected"]
    z, (z_lo, z_hi) = fit["params"]["zeta"], fit["ci95_over_windows"]["zeta"]
    got = law_scale_intervals(free, robot)
    # ω_n sits at its floor (its interval is one point): C_inject ∝ ζ alone
    assert got["shell_damping_scale"] == pytest.approx((z_lo / z, z_hi / z))
    k_a, (a_lo, a_hi) = (
        fit["params"]["amplitude_stiffness_nm_per_rad"],
        fit["ci95_over_windows"]["amplitude_stiffness_nm_per_rad"],
    )
    assert got["shell_stiffness_scale"] == pytest.approx((min(1.0, a_lo / k_a), max(1.0, a_hi / k_a)))
    assert law_scale_intervals(ShellCalibration.load("v0_linear"), robot) == {}


def test_the_calibration_condition_draws_within_the_calibrations_intervals():
    from evaluation.experiments.learning import load_recipes

    robot = RobotParameters.from_urdf(DEFAULT_URDF)
    spec = load_recipes()["study_calibration"]["env_kwargs"]["randomization"]
    for name in spec["calibration"]["values"]:
        for scale, (lo, hi) in law_scale_intervals(ShellCalibration.load(name), robot).items():
            assert spec[scale][0] <= lo + 0.005 and spec[scale][1] >= hi - 0.005, (name, scale)


def test_shell_damping_that_tips_the_explicit_drive_damping_over_its_limit_is_refused():
    # at 10 ms the drive joint takes about 61 N m s/rad: Majd friction × 7 (48 N m s/rad) with the
    # injected C_inject (3.5) passes, with C_inject × 4 (14) it does not
    kw = dict(shell_model="injected", time_step_s=0.01)
    gym.make(ENV_ID, **kw, randomization={"drive_friction_scale": 7.0, "shell_damping_scale": 1.0})
    with pytest.raises(ValueError, match=r"drive joint damping .* \+ injected C_inject 14"):
        gym.make(ENV_ID, **kw, randomization={"drive_friction_scale": 7.0, "shell_damping_scale": 4.0})


def test_an_unknown_calibration_name_is_refused_naming_the_field():
    with pytest.raises(ValueError, match=r"calibration.*'nope'.*free_robot"):
        gym.make(ENV_ID, randomization={"calibration": "nope"})


def test_observed_parameters_are_the_episodes_draws_and_come_last():
    names = ("steer_friction_scale", "payload_mass_kg", "calibration")
    env = gym.make(
        ENV_ID,
        randomization={
            "steer_friction_scale": [0.5, 1.5],
            "payload_mass_kg": [0.0, 4.0],
            "calibration": {"distribution": "choice", "values": ["default", "free_robot"]},
        },
        observe_shell_model=True,
        observe_params=names,
    )
    layout = env.unwrapped.observation_layout
    assert layout.names[-3:] == names and layout.privileged.stop == len(layout)
    for seed in range(3):
        obs, info = env.reset(seed=seed)
        p = info["params"]
        want = [p["steer_friction_scale"], p["payload_mass_kg"], ("default", "free_robot").index(p["calibration"])]
        np.testing.assert_allclose(obs[-3:], want, rtol=1e-6)
        obs, *_ = env.step(np.zeros(2, dtype=np.float32))
        np.testing.assert_allclose(obs[-3:], want, rtol=1e-6)


def test_a_parameter_that_cannot_be_observed_is_refused_naming_the_field():
    with pytest.raises(ValueError, match=r"observe_params\[0\]' = 'shell_model'"):
        gym.make(ENV_ID, observe_params=("shell_model",))
