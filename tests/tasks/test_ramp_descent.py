"""RampDescent-v2: a command that changes at mid-ramp, and success that requires tracking it."""

import math

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401
from sphere_env.controllers import controller_for, run_episode
from sphere_env.tasks import RampDescentTask, Scene

from .test_task_functions import fake_state

SCENE = Scene(control_period_s=0.02, incline_deg=8.0, ramp_end_x_m=6.0)


def _drive(task, omega_d, x_from, x_to, n, y=0.0):
    """Step the task n times with a constant ω_d while x goes from x_from to x_to."""
    out = None
    for x in np.linspace(x_from, x_to, n):
        out = task.step(fake_state(omega_d=omega_d, position_m=np.array([x, y, 0.3])), (0.0, 0.0), None)
    return out


def test_command_changes_at_mid_ramp_by_at_least_the_minimum():
    task = RampDescentTask()
    lo, hi = task.omega_ref_range_rad_s
    rng = np.random.default_rng(0)
    changes = []
    for _ in range(500):
        task.reset(fake_state(), rng, {}, SCENE)
        assert lo <= task.omega_ref_start <= hi and lo <= task.omega_ref_after <= hi
        changes.append(task.omega_ref_after - task.omega_ref_start)
    changes = np.array(changes)
    assert np.all(np.abs(changes) >= task.omega_ref_change_min_rad_s - 1e-12)
    assert (changes > 0).any() and (changes < 0).any()  # both braking and pushing are asked for
    task.reset(fake_state(), rng, {"omega_ref": 2.0, "omega_ref_after": 4.0}, SCENE)
    _drive(task, 2.0, 0.0, 2.9, 10)
    assert task.omega_ref == 2.0
    _drive(task, 2.0, 3.0, 3.1, 2)  # crossing x = ramp_end / 2
    assert task.omega_ref == 4.0 and task.info()["omega_ref_start"] == 2.0


def test_success_needs_tracking_after_settling_not_only_the_run_out():
    task = RampDescentTask(settle_time_s=0.5, tracking_tolerance_rad_s=0.5)
    opts = {"omega_ref": 2.0, "omega_ref_after": 4.0}
    # Tracks both commands (errors only inside the settling windows): success at the run-out.
    task.reset(fake_state(), np.random.default_rng(0), opts, SCENE)
    _drive(task, 0.0, 0.0, 0.5, 25)  # 0.5 s spin-up, not judged
    _drive(task, 2.1, 0.5, 2.99, 50)
    _drive(task, 2.0, 3.0, 3.2, 25)  # just after the change: not judged
    _drive(task, 3.9, 3.2, 5.9, 50)
    assert task.tracking_rmse_rad_s() == pytest.approx(
        0.1, rel=0.02
    )  # the crossing sample is judged against the old command
    terms, done, success = _drive(task, 3.9, 6.1, 6.1, 1)
    assert done and success and terms["success"] > 0 and task.info()["reached_runout"]
    # Coasting at one speed reaches the run-out too, but misses the second command: no success.
    task.reset(fake_state(), np.random.default_rng(0), opts, SCENE)
    _drive(task, 3.0, 0.0, 5.9, 200)
    assert task.tracking_rmse_rad_s() > 0.5
    terms, done, success = _drive(task, 3.0, 6.1, 6.1, 1)
    assert done and not success and terms["success"] == 0.0 and task.info()["reached_runout"]
    # Leaving the lane ends the episode without success.
    task.reset(fake_state(), np.random.default_rng(0), opts, SCENE)
    terms, done, success = _drive(task, 2.0, 1.0, 1.0, 1, y=1.2)
    assert done and not success and terms["off_ramp"] < 0 and not task.info()["reached_runout"]
    fresh = RampDescentTask()
    assert math.isnan(fresh.tracking_rmse_rad_s())
    assert fresh.info()["tracking_rmse_rad_s"] == 0.0 and fresh.info()["tracking_samples"] == 0


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(omega_ref_change_min_rad_s=3.0), "omega_ref_change_min_rad_s"),
        (dict(omega_ref_change_min_rad_s=-1.0), "omega_ref_change_min_rad_s"),
        (dict(settle_time_s=math.nan), "settle_time_s"),
        (dict(settle_time_s=-1), "settle_time_s"),
        (dict(tracking_tolerance_rad_s=0.0), "tracking_tolerance_rad_s"),
        (dict(tracking_tolerance_rad_s="abc"), "tracking_tolerance_rad_s"),
    ],
)
def test_bad_ramp_kwargs_name_the_field(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make("sphere_env/RampDescent-v2", **kwargs)


def test_options_of_the_second_command_are_checked_and_only_offered_with_a_change():
    env = gym.make("sphere_env/RampDescent-v2", shell_model="point")
    with pytest.raises(ValueError, match="omega_ref_after"):
        env.reset(seed=0, options={"omega_ref_after": 31.0})
    env1 = gym.make("sphere_env/RampDescent-v1", shell_model="point")
    with pytest.raises(ValueError, match="omega_ref_after"):
        env1.reset(seed=0, options={"omega_ref_after": 3.0})


@pytest.mark.parametrize("shell_model", ["point", "injected"])
def test_zero_torque_does_not_succeed_where_pd_can(shell_model):
    """On the twin, at the nominal pressure: the tuned PD baseline tracks a profile that asks for a
    slow upper half and a faster lower half, which zero torque, coasting, misses."""
    env = gym.make("sphere_env/RampDescent-v2", shell_model=shell_model, randomization="off")
    lo, hi = env.unwrapped.task.omega_ref_range_rad_s
    opts = {"omega_ref": lo + 0.5, "omega_ref_after": hi - 0.75}
    zero = run_episode(env, controller_for(env, "zero"), seed=0, options=opts)
    pd = run_episode(env, controller_for(env, "pd"), seed=0, options=opts)
    assert not zero["is_success"] and zero["info"]["tracking_rmse_rad_s"] > 0.5
    assert pd["is_success"] and pd["info"]["reached_runout"]
    assert pd["info"]["tracking_rmse_rad_s"] < 0.5


def test_tracking_state_integrates_the_speed_error_against_the_command_in_force():
    task = RampDescentTask(observe_tracking_state=True)
    assert task.command_names[-2:] == ("speed_error_integral", "omega_d_rate")
    task.reset(fake_state(omega_d=0.0), np.random.default_rng(0), {"omega_ref": 2.0, "omega_ref_after": 4.0}, SCENE)
    assert task.command(fake_state(omega_d=0.0))[-2:] == [0.0, 0.0]
    _drive(task, 1.0, 0.0, 2.0, 10)  # 10 steps of (2 − 1) rad/s × 0.02 s
    integral, rate = task.command(fake_state())[-2:]
    assert integral == pytest.approx(0.2) and rate == pytest.approx(0.0)
    _drive(task, 1.5, 2.0, 2.0, 1)  # ω_d rose by 0.5 rad/s in one period
    assert task.command(fake_state())[-1] == pytest.approx(0.5 / 0.02)
    assert task.command(fake_state())[-2] == pytest.approx(0.2 + 0.5 * 0.02)
    _drive(task, 1.5, 3.1, 3.1, 1)  # crosses mid-ramp: the error is taken against the new 4 rad/s
    assert task.command(fake_state())[-2] == pytest.approx(0.21 + 2.5 * 0.02)
    _drive(task, -30.0, 3.2, 3.2, 10)  # winds up far beyond the clip
    assert task.command(fake_state())[-2] == 3.0
    task.reset(fake_state(omega_d=0.0), np.random.default_rng(0), {}, SCENE)  # a new episode starts afresh
    assert task.command(fake_state())[-2:] == [0.0, 0.0]


def test_tracking_state_observation_on_the_twin_matches_the_observed_speeds():
    """On the real twin under the PD: the observed integral and rate follow from the observed ω_d and
    ω_ref of consecutive steps; the default layout of v2 is unchanged."""
    assert len(gym.make("sphere_env/RampDescent-v2").observation_space.low) == 16
    env = gym.make("sphere_env/RampDescent-v2", shell_model="point", observe_tracking_state=True)
    layout = env.unwrapped.observation_layout
    assert env.observation_space.shape == (18,) and layout["speed_error_integral"] == 14
    pd = controller_for(env, "pd")
    obs, _ = env.reset(seed=0)
    integral, prev = 0.0, float(obs[layout["omega_d"]])
    for _ in range(100):
        obs, *_ = env.step(pd(obs))
        w = float(obs[layout["omega_d"]])
        integral += (float(obs[layout["omega_ref"]]) - w) * 0.02
        assert obs[layout["omega_d_rate"]] == pytest.approx((w - prev) / 0.02, rel=1e-4, abs=1e-3)
        assert obs[layout["speed_error_integral"]] == pytest.approx(integral, rel=1e-4, abs=1e-5)
        prev = w
    with pytest.raises(ValueError, match="observe_tracking_state"):
        gym.make("sphere_env/RampDescent-v2", observe_tracking_state=1)
