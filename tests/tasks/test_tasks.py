"""Task objects (command, layout, reward terms, termination) without Drake."""

import math
import subprocess
import sys

import numpy as np
import pytest

from sphere_env import controllers
from sphere_env.envs.kwargs import reset_options
from sphere_env.schemas import validate
from sphere_env.tasks import MEASURED_COMPONENTS, ObservationLayout, RampDescentTask, RollTask, Scene

from .test_task_functions import fake_state


def test_tasks_and_controllers_import_no_drake():
    code = (
        "import sys, sphere_env.tasks, sphere_env.controllers, sphere_env.params, sphere_env.schemas; "
        "print(any(m.startswith('pydrake') for m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_layouts_are_exported_by_the_tasks():
    measured = [c[0] for c in MEASURED_COMPONENTS]
    ramp = RampDescentTask(extended_observation=False).observation_layout()  # v0/v1
    assert ramp.names == (*measured, "omega_ref", "heading_error")
    assert ramp["omega_d"] == 6 and ramp["omega_ref"] == 11 and ramp.command == slice(11, 13)
    v2 = RampDescentTask().observation_layout(observe_pressure=True)
    assert v2.names == (
        *measured,
        "omega_ref",
        "heading_error",
        "lateral_error",
        "pendulum_pitch",
        "pendulum_pitch_rate",
        "pressure_kpa",
    )
    assert v2.command == slice(11, 14) and v2.extra == slice(14, 16)
    roll = RollTask(command_mode="yaw_rate").observation_layout(observe_pressure=True)
    assert roll.names[-3:] == ("omega_ref", "yaw_rate_ref", "pressure_kpa") and len(roll) == 14
    with pytest.raises(KeyError, match="heading_error"):
        roll["heading_error"]
    # The PD baseline reads the same indices (imported, not retyped).
    assert (controllers.OMEGA_D, controllers.DRIVE_RATE, controllers.CMD_SPEED, controllers.CMD_HEADING) == (
        ramp["omega_d"],
        ramp["drive_rate"],
        ramp["omega_ref"],
        ramp["heading_error"],
    )
    assert ObservationLayout(("a",)) == ObservationLayout(("a",)) != ObservationLayout(("b",))


def test_ramp_task_command_reward_and_termination():
    # The v0/v1 settings: one command, success = reaching the run-out.
    task = RampDescentTask(
        lane_half_width_m=0.5,
        omega_ref_range_rad_s=(5.0, 5.0),
        omega_ref_change_min_rad_s=None,
        tracking_tolerance_rad_s=None,
        extended_observation=False,
    )
    scene = Scene(control_period_s=0.02, incline_deg=16.0, ramp_end_x_m=3.0)
    task.reset(fake_state(), np.random.default_rng(0), {}, scene)
    assert task.omega_ref == 5.0 and task.info()["omega_ref"] == 5.0 and task.info()["omega_ref_after"] == 5.0
    assert task.command(fake_state(heading=0.3)) == pytest.approx([5.0, -0.3])
    terms, done, success = task.step(fake_state(omega_d=5.0, position_m=np.array([1.0, 0.1, 0.3])), (0.0, 0.0), None)
    assert not done and not success and terms["speed"] == pytest.approx(0.02)  # full speed term × period
    assert set(terms) == set(task.reward_terms)
    _, done, success = task.step(fake_state(position_m=np.array([3.1, 0.0, 0.3])), (0.0, 0.0), None)
    assert done and success  # reached the run-out
    terms, done, success = task.step(fake_state(position_m=np.array([1.0, -0.6, 0.3])), (0.0, 0.0), None)
    assert done and not success and terms["off_ramp"] < 0  # left the lane
    task.reset(fake_state(), np.random.default_rng(0), {"omega_ref": 7.5}, scene)
    assert task.omega_ref == 7.5
    # options reach the task loaded through its reset options' schema, which refuses a NaN command
    with pytest.raises(ValueError, match="field 'options.omega_ref' = nan"):
        validate(reset_options(task), {"omega_ref": math.nan}, root="options")


def test_roll_task_resamples_its_command():
    task = RollTask(command_mode="yaw_rate", command_resample_s=0.5)
    rng = np.random.default_rng(3)
    task.reset(fake_state(), rng, {}, Scene(0.02, 0.0, math.inf))
    first = (task.omega_ref, task.yaw_rate_ref)
    task.step(fake_state(time_s=0.3), (0.0, 0.0), rng)
    assert (task.omega_ref, task.yaw_rate_ref) == first
    task.step(fake_state(time_s=0.5), (0.0, 0.0), rng)
    assert (task.omega_ref, task.yaw_rate_ref) != first


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(command_mode="spin"), "command_mode"),
        (dict(heading_range_rad=4.0), "heading_range_rad"),
        (dict(command_resample_s=0), "command_resample_s"),
        (dict(reward_weights={"speed_width": 0}), "reward_weights"),
    ],
)
def test_bad_task_kwargs_name_the_field(kwargs, name):
    with pytest.raises(ValueError, match=name):
        RollTask(**kwargs)


def test_unknown_names_are_refused_with_what_is_allowed():
    with pytest.raises(
        ValueError, match=r"^field 'extra_names' = \('pendulum_pitch', 'altitude'\): .*; allowed: names from \["
    ):
        ObservationLayout(("omega_ref",), extra_names=("pendulum_pitch", "altitude"))
    with pytest.raises(
        ValueError, match=r"^field 'name' = 'pid': Input should be 'pd' or 'zero'; allowed: \['pd', 'zero'\]$"
    ):
        controllers.controller_for(None, "pid")


def test_unknown_sensor_components_are_refused_with_what_is_allowed():
    from sphere_env.tasks.sensors import FROM_SENSORS, SensorObserver

    with pytest.raises(
        ValueError,
        match=r"^field 'names' = \('theta', 'pressure_kpa'\): .*; allowed: component names "
        r"with a sensor computation: \[",
    ):
        SensorObserver(("theta", "pressure_kpa"), 0.02)
    assert SensorObserver(tuple(FROM_SENSORS), 0.02).names == tuple(FROM_SENSORS)
