"""Hostile inputs at the environment boundary: every one ends in an error naming the field, the
value and what is allowed, and a failed call changes nothing."""

import copy
import math
import pickle
import re

import gymnasium as gym
import numpy as np
import pytest
import yaml

from sphere_env.physics.admissibility import MAX_INITIAL_PENETRATION_M
from sphere_env.resources import asset_path
from tests.envs.conftest import rollout

ROLL, RAMP = "sphere_env/Roll-v0", "sphere_env/RampDescent-v0"
ZERO = np.zeros(2, np.float32)


def _steps(env, n, seed=5):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        obs, r, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        out.append((obs, r, info["pressure_kpa"], info["omega_ref"]))
    return out


def _same(a, b):
    return all(np.array_equal(x[0], y[0]) and x[1:] == y[1:] for x, y in zip(a, b))


# ---- pressure-schedule distributions are refused at gym.make --------------------------------------
@pytest.mark.parametrize(
    "rate",
    [
        [0.1, -0.1],
        {"distribution": "normal", "mean": 0.0, "std": -1.0},
        {"distribution": "uniform"},
        {"distribution": "choice", "values": []},
    ],
)
def test_bad_pressure_schedule_is_refused_at_make(rate):
    with pytest.raises(ValueError, match=r"^randomization: field 'pressure_schedule\.rate_kpa_per_s"):
        gym.make(ROLL, randomization={"pressure_schedule": {"rate_kpa_per_s": rate}})


# ---- kwargs load through the id's schema before anything is built ---------------------------------
@pytest.mark.parametrize(
    "env_id, kwargs, message",
    [
        (
            ROLL,
            {"time_step_s": "0.005"},
            "field 'time_step_s' = '0.005': Input should be a valid number; allowed: [0.0001, 0.05] s (cost: ",
        ),
        (ROLL, {"steer_torque_limit_nm": True}, "field 'steer_torque_limit_nm' = True: Input should be a valid number"),
        (
            ROLL,
            {"observation_noise_scale": np.bool_(True)},
            "field 'observation_noise_scale' = np.True_: a bool is not a number",
        ),
        (ROLL, {"hydroelastic_pressure_step_kpa": "0.5"}, "field 'hydroelastic_pressure_step_kpa' = '0.5'"),
        (ROLL, {"render_size": (640, "480")}, "field 'render_size[1]' = '480'"),
        (ROLL, {"render_size": (640, 480, 3)}, "field 'render_size' = (640, 480, 3)"),
        (ROLL, {"observe_shell_model": "yes"}, "field 'observe_shell_model' = 'yes'"),
        (ROLL, {"calibration": 3}, "field 'calibration' = 3"),
        (ROLL, {"heading_range_rad": "1"}, "field 'heading_range_rad' = '1'"),
        (
            ROLL,
            {"lane_half_width_m": 1.0},
            "Roll kwargs: unknown field 'lane_half_width_m'; allowed: [",
        ),  # RampDescent's
        (RAMP, {"command_mode": "heading"}, "RampDescent kwargs: unknown field 'command_mode'; allowed: ["),  # Roll's
        (ROLL, {"ramp_length_m": 5.0}, "Roll kwargs: field 'ramp_length_m' = 5.0: the task has no ramp; allowed: None"),
        (RAMP, {"incline_deg": "16"}, "field 'incline_deg' = '16'"),
        (RAMP, {"settle_time_s": False}, "field 'settle_time_s' = False"),
        (RAMP, {"omega_ref_range_rad_s": ("2", 4.5)}, "field 'omega_ref_range_rad_s[0]' = '2'"),
        (RAMP, {"reward_weights": {"speed": "1"}}, "field 'reward_weights.speed' = '1'"),
        (RAMP, {"reward_weights": {"speed": True}}, "field 'reward_weights.speed' = True"),
    ],
)
def test_strings_bools_and_unknown_kwargs_are_refused_before_anything_is_built(monkeypatch, env_id, kwargs, message):
    def no_twin(*args, **kw):
        raise AssertionError("a twin was built for refused kwargs")

    monkeypatch.setattr("sphere_env.envs.twins.Twin", no_twin)
    with pytest.raises(ValueError) as err:
        gym.make(env_id, **kwargs)
    assert message in str(err.value)


def test_sphere_env_loads_its_kwargs_through_the_schema():
    from sphere_env.envs import SphereEnv
    from sphere_env.tasks import RollTask

    with pytest.raises(ValueError, match="Roll kwargs: field 'time_step_s' = '0.005'"):
        SphereEnv(RollTask(), time_step_s="0.005")
    with pytest.raises(ValueError, match="Roll kwargs: unknown field 'command_mode'"):
        SphereEnv(RollTask(), command_mode="heading")  # a task kwarg goes to the task, not the env
    with pytest.raises(ValueError, match=r"^Roll kwargs: field 'ramp_length_m' = 5\.0: .*; allowed: None"):
        SphereEnv(RollTask(), ramp_length_m=5.0)  # Roll runs on flat ground


# ---- a reset that raises changes nothing ------------------------------------------------------------
@pytest.mark.parametrize(
    "options, field",
    [
        ({"pressure_kpa": 12.0, "initial_state": {"roll": math.nan}}, "initial_state.roll"),
        ({"pressure_kpa": 12.0, "omega_ref": math.nan}, "options.omega_ref"),
        (
            {"ground_friction": 0.5, "omega_ref": 1e9},
            "field 'options.omega_ref' = 1000000000.0: Input should be less than or equal to 30; allowed: [-30, 30]",
        ),
        ({"pressure_kpa": 12.0, "omega_ref": True}, "field 'options.omega_ref' = True"),  # a bool is not a number
        ({"pressure_kpa": 12.0, "omega_ref": "1.0"}, "field 'options.omega_ref' = '1.0'"),  # nor is a string
        ({"pressure_kpa": 12.0, "initial_state": {"theta": True}}, "field 'options.initial_state.theta' = True"),
        ({"pressure_kpa": 12.0, "heading_ref": "north"}, "options.heading_ref"),
        ({"pressure_kpa": 12.0, "pressure_rate_kpa_per_s": [1.0]}, "options.pressure_rate_kpa_per_s"),
        ({"pressure_kpa": 12.0, "initial_state": {"position_m": (0.0, 0.0, -0.5)}}, "initial_state.position_m"),
        ({"pressure_kpa": 12.0, "initial_state": {"spin": 1.0}}, "options.initial_state"),
        ({"pressure_kpa": 99.0}, "field 'options.pressure_kpa' = 99.0"),
        ([("pressure_kpa", 12.0)], "field 'options' is a list, not a mapping"),
        ("pressure_kpa=12", "field 'options' is a str, not a mapping"),
    ],
)
def test_a_failed_reset_leaves_the_running_episode_unchanged(make, options, field):
    env, ref = make(ROLL, randomization="full"), make(ROLL, randomization="full")
    for e in (env, ref):
        e.reset(seed=3)
        _steps(e, 3)
    with pytest.raises(ValueError) as err:
        env.reset(options=options)
    assert field in str(err.value)
    # The episode carries on exactly as if the reset had never been called (pressure, command,
    # physics, random generator), and so does the next seedless reset.
    assert _same(_steps(env, 5), _steps(ref, 5))
    assert np.array_equal(env.reset()[0], ref.reset()[0])
    assert _same(_steps(env, 3), _steps(ref, 3))


def test_bad_seed_is_refused_before_anything_changes(make):
    env = make(ROLL)
    env.reset(seed=1)
    for seed in (-1, 1.5, "7", True, np.int64(3)):
        with pytest.raises(ValueError, match=re.escape(f"seed = {seed!r}: ")) as err:
            env.reset(seed=seed)
        assert str(err.value).endswith("; allowed: an integer >= 0 or None")
    env.step(ZERO)


def test_fresh_env_with_failed_first_reset_says_reset_is_needed(make):
    env = make(ROLL)  # as registered: without Gymnasium's passive checker wrapper
    with pytest.raises(ValueError, match="options.omega_ref"):
        env.reset(options={"omega_ref": math.nan})
    with pytest.raises(RuntimeError, match=r"call reset\(\) before step\(\)"):
        env.step(ZERO)
    env.reset(seed=0)
    env.step(ZERO)


# ---- physics edge cases --------------------------------------------------------------------------
@pytest.mark.parametrize(
    "friction_model, joint",
    [
        ({"law": "viscous", "params": {"c": 300.0}}, "steer"),
        ({"drive": {"law": "viscous", "params": {"c": 300.0}}}, "drive"),
    ],
)
def test_friction_that_diverges_at_the_time_step_is_refused(friction_model, joint):
    with pytest.raises(ValueError, match=f"friction_model: {joint} joint damping 30[0-9.]* N m s/rad .*allowed: <="):
        gym.make(ROLL, friction_model=friction_model)


def test_friction_scale_that_diverges_is_refused(make):
    fm = {"law": "viscous", "params": {"c": 100.0}}
    with pytest.raises(ValueError, match="steer_friction_scale 3"):
        gym.make(ROLL, friction_model=fm, randomization={"steer_friction_scale": [1.0, 3.0]})
    env = make(ROLL, friction_model=fm)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="options: friction_model: steer"):
        env.reset(options={"steer_friction_scale": 3.0})


def test_just_under_the_explicit_limit_the_robot_runs(make):
    """Steer limit at 5 ms ≈ 144 N m s/rad; the issue's c = 300 diverged within 10 steps."""
    env = make(ROLL, friction_model={"steer": {"law": "viscous", "params": {"c": 140.0}}}, randomization="off")
    env.reset(seed=0)
    for _ in range(30):
        obs, r, term, trunc, info = env.step(np.ones(2, np.float32))
        assert not trunc, info.get("truncation_reason")


def test_injected_shell_too_stiff_for_the_step_is_refused(tmp_path):
    data = yaml.safe_load(asset_path("calibration", "default.yaml").read_text())
    data["omega_n"].update(intercept_rad_s=300.0, slope_rad_s_per_kpa=0.0)
    path = tmp_path / "stiff.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(
        ValueError, match=r"calibration: omega_n reaches 300 .*allowed at time_step_s=0.005 s: omega_n <= 200"
    ):
        gym.make(ROLL, shell_model="injected", calibration=str(path))
    gym.make(ROLL, shell_model="point", calibration=str(path)).close()  # point contact ignores ω_n


def test_initial_position_inside_the_ground_is_refused(make):
    env = make(RAMP)
    env.reset(seed=0)
    alpha = math.radians(16.0)
    n = np.array([math.sin(alpha), 0.0, math.cos(alpha)])
    R = env.unwrapped.twin.robot.radius_m
    ok = (R - 0.9 * MAX_INITIAL_PENETRATION_M) * n
    env.reset(options={"initial_state": {"position_m": tuple(ok)}})
    deep = (R - 1.5 * MAX_INITIAL_PENETRATION_M) * n
    with pytest.raises(ValueError, match=r"field 'options.initial_state.position_m' = .* allowed: at least"):
        env.reset(options={"initial_state": {"position_m": tuple(deep)}})
    with pytest.raises(ValueError, match="incline 16°"):
        env.reset(options={"initial_state": {"position_m": (0.0, 0.0, -0.5)}})


@pytest.mark.parametrize(
    "init",
    [
        {"angular_velocity_rad_s": (0.0, 5e3, 0.0)},
        {"velocity_m_s": (0.0, 0.0, -1e300)},
        {"theta_dot": 501.0},
        {"drive_rate": -1e150},
    ],
)
def test_initial_rates_beyond_the_failure_limits_are_refused(make, init):
    env = make(ROLL)
    env.reset(seed=0)
    with pytest.raises(
        ValueError, match=rf"field 'options.initial_state.{next(iter(init))}(\[\d\])?' = .*allowed: .*physics failure"
    ):
        env.reset(options={"initial_state": init})


def test_observation_noise_scale_is_bounded():
    with pytest.raises(ValueError, match=r"field 'observation_noise_scale' = 1e\+40: .*allowed: \[0, 100\]"):
        gym.make(ROLL, observation_noise_scale=1e40)


@pytest.mark.parametrize(
    "action",
    [np.array([0.1 + 1j, 0.0]), ["0.1", "0.2"], np.array(["1", "0"]), [True, False], [0.1, None], "ab", {"steer": 0.1}],
)
def test_non_real_actions_are_refused(make, action):
    env = make(ROLL)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action: value"):
        env.step(action)
    env.step([0.1, -0.2])  # lists and ints still step
    env.step(np.array([1, 0]))


def test_step_after_the_episode_ended_raises(make):
    env = make(RAMP)
    alpha = math.radians(16.0)
    R = env.unwrapped.twin.robot.radius_m
    off_lane = (R * math.sin(alpha), 1.5, R * math.cos(alpha))  # outside the 1 m lane: terminates
    env.reset(seed=0, options={"initial_state": {"position_m": off_lane}})
    obs, r, term, trunc, info = env.step(ZERO)
    assert term
    with pytest.raises(RuntimeError, match=r"episode has ended \(terminated\); call reset\(\)"):
        env.step(ZERO)
    env.reset(options={"initial_state": {"angular_velocity_rad_s": (499.0, 499.0, 499.0)}})  # flung off
    obs, r, term, trunc, info = env.step(ZERO)
    assert trunc and info["truncation_reason"].startswith("physics_failure")
    with pytest.raises(RuntimeError, match="episode has ended .truncated: physics_failure"):
        env.step(ZERO)
    env.reset(seed=1)
    env.step(ZERO)


# ---- copies ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("copier", [copy.deepcopy, lambda e: pickle.loads(pickle.dumps(e))])
def test_copies_made_mid_episode_say_they_need_a_reset(make, copier):
    env = make(ROLL, randomization="full")
    env.reset(seed=2)
    _steps(env, 3)
    dup = copier(env)
    with pytest.raises(RuntimeError, match=r"copy .* made during an episode.*call reset\(\)"):
        dup.step(ZERO)
    # After a reset the copy is a full environment: same seed, same rollout as the original.
    a, b = rollout(env, 20, seed=9), rollout(dup, 20, seed=9)
    assert all(np.array_equal(x[0], y[0]) for x, y in zip(a, b))
    dup.close()
