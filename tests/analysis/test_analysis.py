"""The analysis layer: pure numerics, checked against closed forms, without Drake."""

import math
import subprocess
import sys

import numpy as np
import pytest

from sphere_env.analysis import damped_sinusoid, fit_free_decay, log_decrement, pme_percent, rmse


def test_free_decay_fit_recovers_known_parameters_with_cis():
    rng = np.random.default_rng(3)
    t = np.arange(0, 6, 0.01)
    y = damped_sinusoid(t, -0.35, 0.2, 3.6, 0.1, -0.02) + rng.normal(0, 0.003, t.size)
    fit = fit_free_decay(t, y)
    assert fit.omega_n == pytest.approx(3.6, rel=0.01)
    assert fit.zeta == pytest.approx(0.2, rel=0.03)
    assert fit.offset == pytest.approx(-0.02, abs=0.002)
    assert fit.omega_n_ci[0] < 3.6 < fit.omega_n_ci[1] and fit.zeta_ci[0] < 0.2 < fit.zeta_ci[1]
    # 95 % intervals narrow with less noise.
    quiet = fit_free_decay(t, damped_sinusoid(t, -0.35, 0.2, 3.6, 0.1, -0.02) + rng.normal(0, 0.0003, t.size))
    assert quiet.omega_n_ci[1] - quiet.omega_n_ci[0] < 0.5 * (fit.omega_n_ci[1] - fit.omega_n_ci[0])


def test_log_decrement_matches_closed_form():
    zeta, wn = 0.08, 4.0
    t = np.arange(0, 10, 0.001)
    y = damped_sinusoid(t, 1.0, zeta, wn, 0.0, 0.0)
    z, wd = log_decrement(t, y, 0.0)
    assert z == pytest.approx(zeta, rel=0.02)
    assert wd == pytest.approx(wn * math.sqrt(1 - zeta**2), rel=0.01)
    assert all(math.isnan(v) for v in log_decrement(t[:50], np.linspace(0, 1, 50), 0.0))


def test_fit_refuses_too_few_samples():
    with pytest.raises(ValueError, match="need >= 8"):
        fit_free_decay(np.arange(5.0), np.zeros(5))


def test_rmse_and_pme():
    assert rmse([0.0, 0.0, 0.0, 0.0], [1.0, -1.0, 1.0, -1.0]) == pytest.approx(1.0)
    e = np.array([0.0, 2.0, 4.0, -2.0])
    s = np.array([5.0, 1.0, 3.0, -1.0])
    # ω_e = 0 is left out; (2−1)/2, (4−3)/4, (−2+1)/−2 → mean 41.67 %.
    assert pme_percent(e, s) == pytest.approx(100 * (0.5 + 0.25 + 0.5) / 3)
    assert pme_percent(e, s, mask=[True, True, False, False]) == pytest.approx(50.0)
    assert math.isnan(pme_percent(e, s, mask=[True, False, False, False]))


def test_analysis_layer_does_not_import_drake_or_calibration():
    code = (
        "import sys, sphere_env.analysis; "
        "bad = [m for m in sys.modules if m.startswith(('pydrake', 'sphere_env.calibration', 'sphere_env.physics'))]; "
        "print(bad); sys.exit(1 if bad else 0)"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr


def test_evaluation_does_not_import_calibration():
    from pathlib import Path

    root = Path(__file__).resolve().parents[2] / "evaluation"
    # the product's evaluation; its experiments (research apart from the product, such as the
    # contact solver study that replays the robot logs) may combine every layer
    files = [p for p in root.rglob("*.py") if "experiments" not in p.relative_to(root).parts]
    assert files, f"no evaluation code found under {root}"
    offenders = [str(p) for p in files if "sphere_env.calibration" in p.read_text()]
    assert not offenders
