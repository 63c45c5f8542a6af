"""Pooled fits on several windows: length weighting, leave-one-window-out, unidentified parameters."""

import math

import pytest

from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.shell_fit import calibration_at, fit_shell, unidentified
from sphere_env.calibration.steer_fit import steer_fit
from sphere_env.models.shell import ShellCalibration
from sphere_env.physics import InitialState

from .conftest import SYNTH_CAL, record, steer_twin, write_calibration

P = 6.0


def _steer_log(tmp_path, name: str, cal: ShellCalibration, duration_s: float, theta0: float = 0.38) -> RobotLog:
    """A steer_plane log of ``duration_s`` made by the twin with calibration ``cal``."""
    twin = steer_twin(write_calibration(tmp_path / f"{name}.yaml", dict(cal.raw)), P)
    t, data = record(twin, InitialState(theta=theta0, roll=-0.37), duration_s, channels=("theta", "phi"))
    return RobotLog(name, f"<{name}>", t, data, fixture="steer_plane")


def test_unidentified_names_wide_intervals_and_bounds():
    bounds = {"a": (0.0, 10.0), "b": (0.03, 1.5), "c": (-1.0, 1.0), "d": (0.0, 5.0)}
    values = {"a": 2.0, "b": 0.03, "c": 0.1, "d": 1.0}
    ci = {"a": (1.8, 2.2), "b": (0.02, 0.04), "c": (-0.5, 0.7), "d": (math.nan, math.nan)}
    out = unidentified(values, ci, bounds)
    assert set(out) == {"b", "c", "d"}
    assert "lower bound 0.03" in out["b"] and "wider than |value| 0.1" in out["c"] and "not computable" in out["d"]


def test_each_window_weighs_by_its_length(tmp_path):
    """Two windows of different stiffness: the pooled ω_n lies nearer the long window's (4 s against 1 s;
    weighted equally per window it would sit near the middle)."""
    base = ShellCalibration.from_dict(SYNTH_CAL)
    soft = ShellCalibration.from_dict(calibration_at(base, P, omega_n=2.8))
    stiff = ShellCalibration.from_dict(calibration_at(base, P, omega_n=3.6))
    logs = [_steer_log(tmp_path, "long_soft", soft, 4.0), _steer_log(tmp_path, "short_stiff", stiff, 1.0)]
    fit = fit_shell(logs, "injected", P, base=base, form="linear", params=["omega_n"], max_nfev=30)
    w = fit.params["omega_n"]
    assert 2.8 < w < 3.2, w  # the long window has 4/5 of the samples


@pytest.mark.slow
def test_steer_fit_records_every_window_held_out(tmp_path):
    truth = ShellCalibration.from_dict(SYNTH_CAL)
    logs = [_steer_log(tmp_path, "a", truth, 2.0), _steer_log(tmp_path, "b", truth, 2.0, theta0=-0.3)]
    lines = []
    _, rec = steer_fit(logs, ["injected"], P, truth, forms=("linear",), max_nfev=20, log_to=lines.append)
    rows = rec["leave_one_window_out"]
    assert [(r["model"], r["fit_on"], r["test"]) for r in rows] == [("injected", ["b"], "a"), ("injected", ["a"], "b")]
    held = rec["models"]["injected"]["held_out_rmse_rad"]
    assert set(held) == {"a", "b"} and all(v["phi"] < 0.01 and v["theta"] < 0.01 for v in held.values())
    assert "unidentified" in rec["models"]["injected"]
    assert set(rec["models"]["injected"]["ci95_over_windows"]) == set(rec["models"]["injected"]["ci95"])
    assert any(line.startswith("leave-one-window-out") for line in lines)
    # one window: nothing to leave out
    _, rec1 = steer_fit(logs[:1], ["injected"], P, truth, forms=("linear",), max_nfev=20)
    assert "leave_one_window_out" not in rec1


def test_jackknife_over_windows_matches_its_formula_and_widens_with_disagreement():
    from scipy.stats import t as student_t

    from sphere_env.calibration.steer_fit import jackknife_ci95

    folds = [{"a": 1.0, "b": 2.0}, {"a": 1.2, "b": 2.0}, {"a": 0.8, "b": 2.0}, {"a": 1.0, "b": 2.0}]
    ci = jackknife_ci95({"a": 1.0, "b": 2.0}, folds)
    # Σ (θ_i − θ̄)² = 0.08, variance 3/4 · 0.08 = 0.06, half-width t(0.975, 3) · √0.06
    half = student_t.ppf(0.975, 3) * math.sqrt(0.06)
    assert ci["a"] == pytest.approx((1.0 - half, 1.0 + half))
    assert ci["b"] == (2.0, 2.0)  # the windows agree: no spread
    wide = jackknife_ci95({"a": 1.0}, [{"a": 0.0}, {"a": 2.0}, {"a": 1.0}, {"a": 1.0}])
    assert wide["a"][1] - wide["a"][0] > ci["a"][1] - ci["a"][0]
