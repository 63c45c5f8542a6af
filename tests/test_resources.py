"""Package-data lookup: the shipped files are found, a missing one is named in the error."""

from __future__ import annotations

import pytest
import yaml

from sphere_env.models.calibration_files import DEFAULT_CALIBRATION
from sphere_env.models.friction import DEFAULT_PRESETS
from sphere_env.models.rigid_body import DEFAULT_URDF
from sphere_env.resources import asset_path, hyperparams_path


def test_defaults_are_the_shipped_assets():
    assert DEFAULT_URDF == asset_path("robot", "roboball.urdf")
    assert DEFAULT_PRESETS == asset_path("friction", "presets.yaml")
    assert DEFAULT_CALIBRATION == asset_path("calibration", "default.yaml")
    for path in (DEFAULT_URDF, DEFAULT_PRESETS, DEFAULT_CALIBRATION):
        assert path.is_file() and path.stat().st_size > 0


def test_hyperparams_of_each_algorithm():
    for algo in ("ppo", "sac"):
        data = yaml.safe_load(hyperparams_path(algo).read_text())
        assert "sphere_env/RampDescent-v0" in data


def test_missing_files_are_named():
    with pytest.raises(FileNotFoundError, match="robot/nothing.urdf"):
        asset_path("robot", "nothing.urdf")
    with pytest.raises(FileNotFoundError, match=r"'dqn'.*ppo\.yml"):
        hyperparams_path("dqn")
    with pytest.raises(ValueError, match="at least one"):
        asset_path()
