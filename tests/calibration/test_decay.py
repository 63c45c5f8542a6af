"""Free-decay fits and pressure curves on logs synthesized by the twin (locked_steer, injected)."""

import math

import numpy as np
import pytest

from sphere_env.analysis.decay import damped_sinusoid, fit_free_decay
from sphere_env.calibration.__main__ import main
from sphere_env.calibration.decay import fit_pressure_curves
from sphere_env.models.shell import ShellCalibration
from sphere_env.physics import InitialState, Twin, TwinConfig

from .conftest import SYNTH_CAL, synth_log, write_calibration, write_manifest

PRESSURES = (3.0, 6.0, 10.0, 14.0)


def test_damped_sinusoid_fit_and_log_decrement():
    rng = np.random.default_rng(1)
    t = np.arange(0, 8, 0.02)
    y = damped_sinusoid(t, 0.2, 0.12, 2.7, 0.3, 0.01) + rng.normal(0, 0.002, t.size)
    fit = fit_free_decay(t, y)
    assert fit.zeta == pytest.approx(0.12, rel=0.03) and fit.omega_n == pytest.approx(2.7, rel=0.01)
    assert fit.zeta_ci[0] < 0.12 < fit.zeta_ci[1] and fit.omega_n_ci[0] < 2.7 < fit.omega_n_ci[1]
    assert fit.logdec_zeta == pytest.approx(0.12, rel=0.15)
    # A named transient is dropped: garbage in the first second does not matter.
    y2 = y.copy()
    y2[t < 1.0] = 0.5
    assert fit_free_decay(t, y2, transient_s=1.0).zeta == pytest.approx(0.12, rel=0.05)


@pytest.mark.slow
def test_shell_command_recovers_twin_parameters(tmp_path):
    cal_path = write_calibration(tmp_path / "truth.yaml")
    truth = ShellCalibration.load(cal_path)
    twin = Twin(
        TwinConfig(
            fixture="locked_steer",
            shell_model="injected",
            steer_friction="none",
            drive_friction="none",
            calibration=cal_path,
        )
    )
    trials = []
    for i, p in enumerate(PRESSURES):
        synth_log(
            tmp_path / f"p{p}.csv",
            twin,
            InitialState(roll=0.12),
            8.0,
            channels=("phi",),
            noise_rad=1e-3,
            seed=i,
            pressure_kpa=p,
        )
        trials.append(
            {"name": f"p{p}", "file": f"p{p}.csv", "fixture": "locked_steer", "group": "decay", "pressure_kpa": p}
        )
    man = write_manifest(tmp_path / "m.yaml", trials)
    out, plot = tmp_path / "fitted.yaml", tmp_path / "fig10.png"
    assert main(["shell", "--manifest", str(man), "--group", "decay", "--out", str(out), "--plot", str(plot)]) == 0
    fitted = ShellCalibration.load(out)  # the twin's own loader reads it directly
    assert plot.stat().st_size > 1000
    import yaml

    per_trial = yaml.safe_load(out.read_text())["trial_fits"]
    for p in PRESSURES:
        f = per_trial[f"p{p}"]
        assert f["zeta"] == pytest.approx(float(truth.zeta(p)), rel=0.05)
        assert f["omega_n"] == pytest.approx(float(truth.omega_n(p)), rel=0.05)
    assert fitted.omega_n_intercept == pytest.approx(SYNTH_CAL["omega_n"]["intercept_rad_s"], rel=0.10)
    assert fitted.omega_n_slope == pytest.approx(SYNTH_CAL["omega_n"]["slope_rad_s_per_kpa"], rel=0.10)
    assert fitted.zeta_scale == pytest.approx(SYNTH_CAL["zeta"]["scale"], rel=0.10)
    assert fitted.zeta_rate == pytest.approx(SYNTH_CAL["zeta"]["rate_per_kpa"], rel=0.10)


def test_pressure_curves_need_three_pressures():
    with pytest.raises(ValueError, match="3 distinct pressures"):
        fit_pressure_curves([4, 4, 8], [2, 2, 3], [0.2, 0.2, 0.1])
    fit = fit_pressure_curves(
        [3, 6, 9, 12], [2.5 + 0.1 * p for p in (3, 6, 9, 12)], [0.3 * math.exp(-0.05 * p) for p in (3, 6, 9, 12)]
    )
    assert fit.omega_n_slope == pytest.approx(0.1) and fit.zeta_rate == pytest.approx(-0.05)
