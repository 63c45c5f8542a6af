"""One generic env composes a twin and any task; the applied torque is reported in info."""

import numpy as np
import pytest

from sphere_env.envs import SphereEnv
from sphere_env.tasks import Task


class HoldStill(Task):
    """A minimal task: stay at rest; reward −|ω_d| per step, never terminates."""

    name = "HoldStill"
    reward_terms = ("still",)
    command_names = ("zero",)

    def initial_state(self):
        return {"theta": 0.2}

    def reset(self, state, rng, options, scene):
        self.dt = scene.control_period_s

    def command(self, state):
        return [0.0]

    def step(self, state, action, rng):
        return {"still": -abs(state.omega_d) * self.dt}, False, False


def test_a_new_task_composes_with_the_generic_env():
    env = SphereEnv(HoldStill(), shell_model="point", randomization="off")
    obs, info = env.reset(seed=0)
    assert obs.shape == env.observation_space.shape == (12,) and env.observation_layout["zero"] == 11
    assert obs[env.observation_layout["theta"]] == pytest.approx(0.2)  # the task's initial state
    obs, r, term, trunc, info = env.step(np.array([0.0, 1.0], np.float32))
    assert r == info["reward_still"] < 0 and not (term or trunc)
    with pytest.raises(ValueError, match="no_such"):
        SphereEnv(HoldStill(), no_such=1)


@pytest.mark.parametrize("env_id", ["sphere_env/RampDescent-v0", "sphere_env/Roll-v0"])
def test_info_reports_the_applied_motor_torque(make, env_id):
    env = make(env_id, shell_model="point", steer_torque_limit_nm=10.0, drive_torque_limit_nm=20.0)
    _, info = env.reset(seed=0)
    assert list(info["motor_torque_nm"]) == [0.0, 0.0]
    _, _, _, _, info = env.step(np.array([0.5, 2.0], np.float32))  # drive clipped to +1
    # +1 drive = forward: the drive joint axis is −y, so the joint torque is −a·limit
    assert list(info["motor_torque_nm"]) == [5.0, -20.0]
