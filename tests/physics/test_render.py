"""Camera frames show motion: the ground carries a grid fixed in the world, so with the camera
following the robot the background moves when the robot does (a plain ground looks the same
wherever the robot is)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from sphere_env.physics import InitialState, Twin, TwinConfig
from sphere_env.physics.terrain import GRID_SPACING_M

W, H = 160, 120


def _background(frame: np.ndarray) -> np.ndarray:
    """The lower third of the frame left and right of the robot (which the camera keeps centred)."""
    rows = frame[2 * H // 3 :].astype(int)
    return np.concatenate([rows[:, : W // 4], rows[:, -W // 4 :]], axis=1)


@pytest.fixture(scope="module")
def flat_twin():
    return Twin(TwinConfig(fixture="free", shell_model="point", incline_deg=0.0, ramp_length_m=None))


def _frame_at(twin: Twin, x_m: float) -> np.ndarray:
    twin.reset(InitialState(position_m=(x_m, 0.0, twin.robot.radius_m)))
    return twin.render_rgb(W, H)


def test_background_moves_with_the_robot_by_the_grid(flat_twin):
    at_0 = _frame_at(flat_twin, 0.0)
    assert np.array_equal(at_0, _frame_at(flat_twin, 0.0))  # rendering is deterministic
    half = _frame_at(flat_twin, GRID_SPACING_M / 2)
    whole = _frame_at(flat_twin, GRID_SPACING_M)
    # The robot and camera moved together: a plain ground would give the same background.
    moved = np.abs(_background(half) - _background(at_0))
    assert (moved > 30).mean() > 0.02, f"only {(moved > 30).mean():.1%} of the background pixels changed"
    # A whole grid period later the background is the same again: the change is the world-fixed grid.
    period = np.abs(_background(whole) - _background(at_0))
    assert (period > 30).mean() < 0.2 * (moved > 30).mean()


def test_rolling_robot_frames_differ_in_the_background():
    import gymnasium as gym

    import sphere_env  # noqa: F401

    env = gym.make(
        "sphere_env/Roll-v1", shell_model="point", randomization="off", render_mode="rgb_array", render_size=(W, H)
    )
    try:
        env.reset(seed=0)
        frames = []
        for k in range(50):  # full drive torque from rest: about 0.4 m in 1 s
            env.step(np.array([0.0, 1.0], np.float32))
            if k >= 44:
                frames.append(env.render())
        distance = np.linalg.norm(np.asarray(env.unwrapped.twin.state().position_m)[:2])
    finally:
        env.close()
    assert distance > 0.2  # the robot moved
    changed = [(np.abs(_background(b) - _background(a)) > 30).mean() for a, b in itertools.pairwise(frames)]
    assert max(changed) > 0.02, changed
