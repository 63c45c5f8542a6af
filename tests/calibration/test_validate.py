"""Validation of a twin run against its own log, PME sign, tolerances as an exit code."""

import numpy as np
import pytest

from sphere_env.analysis.metrics import pme_percent
from sphere_env.calibration.__main__ import main
from sphere_env.calibration.manifest import load_manifest
from sphere_env.calibration.validate import parse_tolerances, validate
from sphere_env.physics import InitialState, Twin, TwinConfig

from .conftest import synth_log, write_manifest


@pytest.fixture(scope="module")
def steer_log(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("val")
    twin = Twin(
        TwinConfig(fixture="steer_plane", shell_model="injected", steer_friction="majd_steer", drive_friction="none")
    )
    synth_log(tmp / "sf.csv", twin, InitialState(theta=0.38, roll=-0.37), 3.0)
    return write_manifest(
        tmp / "m.yaml", [{"name": "sf", "file": "sf.csv", "fixture": "steer_plane", "group": "steer_free"}]
    )


def test_twin_against_its_own_log_has_zero_rmse(steer_log):
    logs = [t.load() for t in load_manifest(steer_log).trials]
    (row,) = validate(logs, ["injected"], steer_friction="majd_steer", drive_friction="none")
    assert row.rmse["phi"] < 1e-6 and row.rmse["theta"] < 1e-6
    assert np.isnan(row.rmse["omega_d"]) and np.isnan(row.pme_percent)  # not logged
    (other,) = validate(logs, ["point"], steer_friction="majd_steer", drive_friction="none")
    assert other.rmse["phi"] > 0.05  # a different model is visibly different


def test_tolerance_sets_exit_code(steer_log, tmp_path):
    base = ["validate", "--manifest", str(steer_log), "--models", "point", "injected", "--drive-friction", "none"]
    assert main(base + ["--tol", "phi=1.0", "theta=1.0"]) == 0
    assert main(base + ["--tol", "phi=0.01"]) == 1  # point contact misses the shell dynamics
    assert main(base + ["--tol", "phi=0.01", "--tol-models", "injected", "--plot", str(tmp_path / "o.png")]) == 0
    assert (tmp_path / "o.png").stat().st_size > 1000
    assert main(base + ["--tol", "phi"]) == 2  # malformed tolerance: named error


def test_pme_sign_and_window():
    e = np.array([0.0, 1.0, 2.0, 4.0])
    assert pme_percent(e, 0.5 * e) == pytest.approx(50.0)  # sim underestimates -> positive
    assert pme_percent(e, 1.5 * e) == pytest.approx(-50.0)
    assert pme_percent(e, np.array([0, 1, 1, 4.0]), mask=np.array([1, 1, 0, 1], bool)) == pytest.approx(0.0)


def test_tolerances_load_as_named_limits():
    assert parse_tolerances(["theta=0.12", "phi=1e-1", "pme=10"]) == {"theta": 0.12, "phi": 0.1, "pme": 10.0}
    assert parse_tolerances(None) == {}


@pytest.mark.parametrize(
    "item, message",
    [
        (
            "bogus=1",
            "--tol: unknown field 'bogus'; allowed: ['heading_rate', 'omega_d', 'pendulum_pitch', 'phi', 'pme', 'theta']",
        ),
        (
            "theta=abc",
            "--tol: field 'theta' = 'abc': Input should be a valid number; allowed: NAME=LIMIT with LIMIT a "
            "finite number > 0",
        ),
        ("phi", "--tol: field 'phi' = '': Input should be a valid number; allowed: NAME=LIMIT"),
        ("phi=0", "--tol: field 'phi' = 0.0: Input should be greater than 0; allowed: NAME=LIMIT"),
        ("pme=-5", "--tol: field 'pme' = -5.0: Input should be greater than 0; allowed: NAME=LIMIT"),
        ("omega_d=inf", "--tol: field 'omega_d' = inf: not a finite number; allowed: NAME=LIMIT"),
    ],
)
def test_bad_tolerance_is_refused_by_name(item, message):
    with pytest.raises(ValueError) as err:
        parse_tolerances(["phi=1", item])
    assert str(err.value).startswith(message), err.value
