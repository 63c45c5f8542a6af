"""Steer-plane shell fit and the hydroelastic sweep, on the twin's own synthetic logs."""

import pytest

from sphere_env.calibration.manifest import load_manifest
from sphere_env.calibration.sensitivity import sweep
from sphere_env.calibration.shell_fit import calibration_at, fit_shell, pressure_for_modulus
from sphere_env.calibration.shell_params import law_params
from sphere_env.models.rigid_body import RobotParameters
from sphere_env.models.shell import ShellCalibration
from sphere_env.physics import InitialState

from .conftest import SYNTH_CAL, steer_twin, synth_log, write_calibration, write_manifest


def test_injected_fit_recovers_omega_and_zeta(tmp_path):
    cal_path = write_calibration(tmp_path / "truth.yaml")
    truth = ShellCalibration.load(cal_path)
    p = 6.0
    twin = steer_twin(cal_path, p)
    synth_log(
        tmp_path / "a.csv", twin, InitialState(theta=0.38, roll=-0.37), 5.0, channels=("theta", "phi"), noise_rad=2e-3
    )
    man = write_manifest(tmp_path / "m.yaml", [{"name": "a", "file": "a.csv", "fixture": "steer_plane"}])
    logs = [t.load() for t in load_manifest(man).trials]
    start = ShellCalibration.from_dict(calibration_at(truth, p, omega_n=2.6, zeta=0.1))  # a wrong start
    fit = fit_shell(logs, "injected", p, steer_friction="majd_steer", base=start)
    assert fit.params["omega_n"] == pytest.approx(float(truth.omega_n(p)), rel=0.05)
    assert fit.params["zeta"] == pytest.approx(float(truth.zeta(p)), rel=0.05)
    assert fit.rmse["a"]["phi"] < 6e-3  # noise 2 mrad + a noisy initial-rate estimate


def test_calibration_at_expresses_modulus_and_dissipation():
    base = ShellCalibration.from_dict(SYNTH_CAL)
    r = RobotParameters.from_urdf()
    raw = calibration_at(base, 5.0, omega_n=3.0, zeta=0.07, modulus_pa=1.2e5, dissipation_s_per_m=0.4)
    cal = ShellCalibration.from_dict(raw)
    m, d = cal.bind(r).hydroelastic(5.0)
    assert m == pytest.approx(1.2e5, rel=1e-6) and d == pytest.approx(0.4, rel=1e-6)
    assert float(cal.omega_n(5.0)) == pytest.approx(3.0) and cal.omega_n_slope == base.omega_n_slope
    assert float(cal.zeta(5.0)) == pytest.approx(0.07) and cal.zeta_rate == base.zeta_rate
    assert 4.0 < pressure_for_modulus(1.55e5) < 4.7


@pytest.mark.slow
def test_hydroelastic_sweep_direction_parallel():
    rows = sweep(
        [6.0],
        workers=2,
        duration_s=4.0,
        cases=(("control", 1.0, 1.0), ("dissipation -50%", 1.0, 0.5), ("dissipation +50%", 1.0, 1.5)),
    )
    z = {r["case"]: r["zeta"] for r in rows}
    assert z["dissipation -50%"] < z["control"] < z["dissipation +50%"]  # paper Fig. 11 direction
    assert all(abs(r["zeta_error_vs_curve_pct"]) < 1e3 for r in rows)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (
            {"model": "point"},
            "fit_shell: field 'model' = 'point': Input should be 'injected' or 'hydroelastic'; "
            "allowed: ['injected', 'hydroelastic']",
        ),
        (
            {"form": "cubic"},
            "fit_shell: field 'form' = 'cubic': Input should be 'linear', 'saturating' or 'quadratic'; "
            "allowed: ['linear', 'saturating', 'quadratic']",
        ),
        (
            {"params": ["omega_n", "stiffness"]},
            "fit_shell: field 'params[1]' = 'stiffness': Input should be 'omega_n', ",
        ),
    ],
)
def test_bad_model_form_or_parameter_is_refused_before_any_fit(kwargs, message):
    with pytest.raises(ValueError) as err:
        fit_shell([], **{"model": "injected", "pressure_kpa": 6.0, **kwargs})
    assert str(err.value).startswith(message), err.value
    if "params" in kwargs:
        assert "; allowed: names from ['amplitude_scale_rad', " in str(err.value)


def test_law_params_refuses_an_unknown_form():
    assert law_params("linear") == ("omega_n", "zeta", "rest_angle_rad")
    with pytest.raises(
        ValueError, match=r"^field 'form' = 'cubic': .*; allowed: \['linear', 'saturating', 'quadratic'\]"
    ):
        law_params("cubic")
