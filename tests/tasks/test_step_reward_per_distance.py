"""RampDescent-v3 pays the per-step reward terms per distance down the ramp: a descent at exactly
ω_ref collects the same speed reward whatever ω_ref, where v2's per-second terms pay a slower
descent more (its episode lasts longer)."""

from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401
from sphere_env.tasks import RampDescentTask
from sphere_env.tasks.rewards import RampRewardWeights, RampRewardWeightsPerRamp, gaussian_tolerance
from sphere_env.tasks.task import Scene

RADIUS_M = 0.3  # a rolling radius: the task only sees positions and ω_d, not the robot


def _descent_terms(task: RampDescentTask, omega_d: float, ramp_end_x_m: float = 6.0, dt_s: float = 0.02):
    """Roll straight down at a constant ω_d (x advances by ω_d R dt per step) until the run-out;
    returns the summed reward terms."""
    scene = Scene(control_period_s=dt_s, incline_deg=8.0, ramp_end_x_m=ramp_end_x_m)
    state = SimpleNamespace(position_m=np.zeros(3), omega_d=omega_d, heading=0.0)
    task.reset(state, np.random.default_rng(0), {"omega_ref": omega_d, "omega_ref_after": omega_d}, scene)
    total: dict[str, float] = {}
    done = False
    while not done:
        state.position_m = state.position_m + np.array([omega_d * RADIUS_M * dt_s, 0.0, 0.0])
        terms, done, _ = task.step(state, (0.0, 0.0), np.random.default_rng(0))
        for k, v in terms.items():
            total[k] = total.get(k, 0.0) + v
    return total


@pytest.mark.parametrize("omega_ref", [2.0, 3.0, 4.5])
def test_perfect_tracking_earns_the_full_speed_weight_at_any_speed(omega_ref):
    task = RampDescentTask(step_reward_per="distance", omega_ref_change_min_rad_s=None)
    total = _descent_terms(task, omega_ref)
    # the ramp is covered exactly once: Σ Δx / L = 1, and the gaussian is 1 at zero error
    assert total["speed"] == pytest.approx(RampRewardWeightsPerRamp().speed, rel=1e-9)
    assert total["success"] == RampRewardWeightsPerRamp().success


def test_per_second_terms_pay_a_slow_descent_more():
    slow = _descent_terms(RampDescentTask(step_reward_per="time", omega_ref_change_min_rad_s=None), 2.0)
    fast = _descent_terms(RampDescentTask(step_reward_per="time", omega_ref_change_min_rad_s=None), 4.0)
    # the same perfect tracking, twice the duration: about twice the speed reward
    assert slow["speed"] == pytest.approx(2 * fast["speed"], rel=0.02)


def test_the_distance_weighted_speed_return_peaks_at_the_command():
    """Lagging the command by δ loses reward per distance: exp(−½ (δ/w)²) of the full weight, with
    no longer episode to make up for it (v2's per-second return is largest below the command)."""
    w = RampRewardWeightsPerRamp()
    omega_ref = 2.0
    returns = {}
    for lag in (0.0, 0.25, 0.5, 1.0):
        task = RampDescentTask(step_reward_per="distance", omega_ref_change_min_rad_s=None)
        scene = Scene(control_period_s=0.02, incline_deg=8.0, ramp_end_x_m=6.0)
        state = SimpleNamespace(position_m=np.zeros(3), omega_d=omega_ref - lag, heading=0.0)
        task.reset(state, np.random.default_rng(0), {"omega_ref": omega_ref}, scene)
        total, done = 0.0, False
        while not done:
            state.position_m = state.position_m + np.array([state.omega_d * RADIUS_M * 0.02, 0.0, 0.0])
            terms, done, _ = task.step(state, (0.0, 0.0), np.random.default_rng(0))
            total += terms["speed"]
        returns[lag] = total
        assert total == pytest.approx(w.speed * gaussian_tolerance(-lag, w.speed_width), rel=1e-9)
    assert max(returns, key=returns.get) == 0.0
    per_second = {
        lag: (omega_ref / (omega_ref - lag)) * gaussian_tolerance(-lag, RampRewardWeights().speed_width)
        for lag in (0.0, 0.5, 1.0)
    }
    assert max(per_second, key=per_second.get) == 1.0  # v2's bias, from the same formula


def test_v3_differs_from_v2_in_reward_and_observation_only():
    v2 = gym.make("sphere_env/RampDescent-v2", randomization="off", observe_tracking_state=True)
    v3 = gym.make("sphere_env/RampDescent-v3", randomization="off")
    assert v3.observation_space.shape == v2.observation_space.shape
    o2, _ = v2.reset(seed=5)
    o3, _ = v3.reset(seed=5)
    rng = np.random.default_rng(0)
    r2 = r3 = 0.0
    for _ in range(50):
        a = rng.uniform(-0.3, 0.3, 2).astype(np.float32)
        o2, x2, *_ = v2.step(a)
        o3, x3, *_ = v3.step(a)
        r2, r3 = r2 + x2, r3 + x3
    np.testing.assert_array_equal(o2, o3)  # the same physics and observations
    assert r2 != pytest.approx(r3)
