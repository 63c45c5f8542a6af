"""RampDescent-v4 and Roll-v2 apply each calibration's fitted drive direction (its ``drive_law``);
RampDescent-v3 and the other versions from before the drive fit do not, whatever the calibration.

The expected values are read from the calibration files themselves, and the twins are the real
simulation: the force system's parameters in its context, and the motion they give."""

import warnings

import gymnasium as gym
import numpy as np
import pytest

import sphere_env
from sphere_env import safe_yaml
from sphere_env.models.calibration_schema import shipped_calibrations
from sphere_env.models.steer_law import LAW_GAIN_NAMES
from sphere_env.physics.forces import GAIN_NAMES
from sphere_env.resources import asset_path

SHIPPED = shipped_calibrations()
#: The paper's drive direction: C_drive = C_inject, no spin damping, the drive friction law × 1.
PAPER = {"injected_rolling_damping_factor": 1.0, "spin_damping_nms_per_rad": 0.0, "drive_friction_scale": 1.0}


def _file(name: str) -> dict:
    return safe_yaml.load_file(asset_path("calibration", f"{name}.yaml"))


def _expected(name: str, shell_model: str) -> dict:
    """The drive direction a calibration file applies to ``shell_model``, read from the file."""
    law = _file(name).get("drive_law")
    if law is None or shell_model not in law.get("shell_models", ("injected", "hydroelastic")):
        return dict(PAPER)
    out = {k: float(law.get(k, v)) for k, v in PAPER.items()}
    if shell_model != "injected":
        out["injected_rolling_damping_factor"] = 1.0
    if shell_model == "point":
        out["spin_damping_nms_per_rad"] = 0.0
    return out


def _env(env_id: str, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # gymnasium flags the superseded versions
        return gym.make(env_id, randomization="off", **kwargs)


def _in_force(env) -> dict:
    """The drive direction the twin's force system holds after a reset, from its context."""
    twin = env.unwrapped.twin
    g = dict(zip(GAIN_NAMES, twin._forces_context.get_numeric_parameter(0).get_value()))
    c_inject = twin.shell.injected_gains(twin.pressure_kpa)[1]
    law = dict(zip(LAW_GAIN_NAMES, twin.shell.law_gains(twin.config.shell_model, twin.pressure_kpa)))
    return {
        "injected_rolling_damping_factor": g["C_drive"] / c_inject if law["C_drive"] else 1.0,
        "spin_damping_nms_per_rad": g["C_spin"],
        "drive_friction_scale": g["drive_friction_scale"] / twin.params["drive_friction_scale"],
    }


def _motion(env, steps: int = 60) -> np.ndarray:
    obs, _ = env.reset(seed=5)
    rng = np.random.default_rng(1)
    out = [obs]
    for _ in range(steps):
        obs, *_ = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        out.append(obs)
    return np.array(out)


def test_every_shipped_calibration_records_its_drive_fit():
    for name in SHIPPED:
        rec = _file(name).get("drive_fit")
        assert rec is not None, name
        if rec["fitted"]:
            applied = [m for m, r in rec["models"].items() if r["applied"]]
            assert applied and rec["fit_on"] and rec["commit"] and rec["log"], name
        else:
            assert rec["reason"] and "drive_law" not in _file(name), name
    assert any(_file(name)["drive_fit"]["fitted"] for name in SHIPPED)


@pytest.mark.parametrize("shell_model", ["injected", "point"])
@pytest.mark.parametrize("calibration", SHIPPED)
def test_v4_applies_the_calibrations_drive_fit_and_v3_does_not(calibration, shell_model):
    want = _expected(calibration, shell_model)
    v4 = _env("sphere_env/RampDescent-v4", calibration=calibration, shell_model=shell_model)
    v3 = _env("sphere_env/RampDescent-v3", calibration=calibration, shell_model=shell_model)
    m4, m3 = _motion(v4), _motion(v3)
    for k, v in _in_force(v4).items():
        assert v == pytest.approx(want[k], rel=1e-12), (k, "v4")
    assert _in_force(v3) == pytest.approx(PAPER, rel=1e-12)
    if want == PAPER:
        np.testing.assert_array_equal(m4, m3)  # nothing applied: the same motion
    else:
        assert np.abs(m4 - m3).max() > 1e-2  # the fitted drive direction moves the robot differently
    v4.close()
    v3.close()


def test_v3_is_v4_with_the_papers_drive_direction():
    """As -v0 is -v1 with the v0 calibration: the versions differ by the drive law only."""
    v3 = _motion(_env("sphere_env/RampDescent-v3"))
    v4_paper = _motion(_env("sphere_env/RampDescent-v4", calibration_drive_law=False))
    np.testing.assert_array_equal(v3, v4_paper)
    roll_v1 = _motion(_env("sphere_env/Roll-v1"))
    roll_v2 = _motion(_env("sphere_env/Roll-v2"))
    assert np.abs(roll_v1 - roll_v2).max() > 1e-2
    np.testing.assert_array_equal(roll_v1, _motion(_env("sphere_env/Roll-v2", calibration_drive_law=False)))


def test_versions_from_before_the_drive_fit_keep_the_papers_drive_direction():
    for env_id, (_, _, kwargs) in sphere_env.ENV_IDS.items():
        new = env_id in ("sphere_env/RampDescent-v4", "sphere_env/Roll-v2")
        assert kwargs.get("calibration_drive_law", True) is new, env_id
