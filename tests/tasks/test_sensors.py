"""The observation as a robot computes it from its sensors (``policy.json``'s ``from_sensors``)
against the env's observation of the same state: a real free-robot log's channels, sample by
sample, on flat ground and on the 16° ramp."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401
from sphere_env.physics import InitialState
from sphere_env.tasks.sensors import FROM_SENSORS, SensorObserver, channel

ENV = "sphere_env/RampDescent-v3"
LOG = "free_robot/data2-conv.csv"
STEPS = 60


def _samples(roboball_dir) -> list[dict[str, float]]:
    """Every second sample (10 ms log, 50 Hz policy) around the log's fastest drive."""
    import pandas as pd

    path = roboball_dir / LOG
    if not path.exists():
        pytest.skip(f"{path} not present")
    d = pd.read_csv(path)
    k = int(np.argmax(np.abs(d["drive_shaft.velocity"].to_numpy())))
    rows = d.iloc[max(k - STEPS, 0) : max(k - STEPS, 0) + 2 * STEPS : 2]
    return [dict(r) for _, r in rows.iterrows()]


def _state_of(sample, encoder0: float, y_m: float) -> InitialState:
    """The twin state the sensors read: R_W,PC = Rz(ψ) Rx(φ) Ry(α) from the IMU, the IMU's angular
    velocity, the steer and drive encoders (drive zero at the run's start), centre at lane offset y."""
    psi, phi, alpha = (channel(sample, c) for c in ("shell_yaw.position", "pipe_roll.position", "pitch_joint.position"))
    rz = np.array([[math.cos(psi), -math.sin(psi), 0], [math.sin(psi), math.cos(psi), 0], [0, 0, 1]])
    rx = np.array([[1, 0, 0], [0, math.cos(phi), -math.sin(phi)], [0, math.sin(phi), math.cos(phi)]])
    ry = np.array([[math.cos(alpha), 0, math.sin(alpha)], [0, 1, 0], [-math.sin(alpha), 0, math.cos(alpha)]])
    R = rz @ rx @ ry
    w = (
        channel(sample, "shell_yaw.velocity") * np.array([0, 0, 1.0])
        + channel(sample, "pipe_roll.velocity") * rz[:, 0]
        + channel(sample, "pitch_joint.velocity") * (rz @ rx)[:, 1]
    )
    return InitialState(
        theta=channel(sample, "roll_joint.position"),
        theta_dot=channel(sample, "roll_joint.velocity"),
        drive_angle=-(channel(sample, "drive_shaft.position") - encoder0),
        drive_rate=-channel(sample, "drive_shaft.velocity"),
        roll=math.atan2(R[2, 1], R[2, 2]),
        pitch=math.asin(-R[2, 0]),
        heading=math.atan2(R[1, 0], R[0, 0]),
        position_m=(1.0, y_m, 5.0),
        angular_velocity_rad_s=tuple(float(x) for x in w),
    )


@pytest.mark.parametrize("incline_deg", [0.0, 16.0])
def test_a_real_log_through_the_documented_computation_matches_the_env_observation(roboball_dir, incline_deg):
    samples = _samples(roboball_dir)
    env = gym.make(ENV, observe_tracking_state=True, randomization="off", incline_deg=incline_deg)
    u = env.unwrapped
    names = u.observation_layout.names
    assert set(names) <= set(FROM_SENSORS)
    sensors = SensorObserver(names, u.control_period_s, incline_deg=incline_deg)
    enc0, y = channel(samples[0], "drive_shaft.position"), 0.3
    seq = gym.make(ENV, observe_tracking_state=True, randomization="off", incline_deg=incline_deg).unwrapped
    task_obs, robot_obs = [], []
    for k, sample in enumerate(samples):
        init = _state_of(sample, enc0, y)
        options = {"initial_state": init, "omega_ref": 2.0, "omega_ref_after": 2.0}
        # the instantaneous components: a reset into the state, through the public API
        obs, _ = env.reset(seed=0, options=options)
        robot = sensors.observe(sample, 2.0, lateral_offset_m=y)
        # the tracking state: one run whose task steps through the same states
        if k == 0:
            seq.reset(seed=0, options=options)
        else:
            seq.twin.reset(init)
            seq.task.step(seq.twin.state(), (0.0, 0.0), seq.np_random)
        cmd = dict(zip(seq.task.command_names, seq.task.command(seq.twin.state())))
        obs = obs.copy()
        for n in ("speed_error_integral", "omega_d_rate"):
            obs[names.index(n)] = cmd[n]
        task_obs.append(obs)
        robot_obs.append(robot)
    task_obs, robot_obs = np.array(task_obs), np.array(robot_obs)
    assert np.max(np.abs(task_obs[:, names.index("omega_d")])) > 0.5  # the window rolls
    assert np.max(np.abs(task_obs[:, names.index("speed_error_integral")])) > 0.1
    for i, n in enumerate(names):
        np.testing.assert_allclose(robot_obs[:, i], task_obs[:, i], rtol=1e-5, atol=2e-5, err_msg=n)
