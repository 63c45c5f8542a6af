"""The pressure of a recording, estimated with a fixed calibration: recovered from the twin's own motion."""

import pytest

from sphere_env.calibration.__main__ import main as calibrate
from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.pressure_fit import by_recording, fit_pressure
from sphere_env.calibration.shell_fit import FitError
from sphere_env.models.shell import ShellCalibration
from sphere_env.physics import InitialState

from .conftest import SYNTH_CAL, record, steer_twin, synth_log, write_calibration, write_manifest


def _steer_log(
    tmp_path, name: str, pressure_kpa: float, theta0: float, path: str | None = None, cal: dict = SYNTH_CAL
) -> RobotLog:
    """A steer_plane recording made by the twin at ``pressure_kpa`` with calibration ``cal``."""
    twin = steer_twin(write_calibration(tmp_path / f"{name}_cal.yaml", cal), pressure_kpa)
    t, data = record(twin, InitialState(theta=theta0, roll=-0.3), 2.5, channels=("theta", "phi"))
    return RobotLog(name, path or f"<{name}>", t, data, fixture="steer_plane")


def test_the_pressure_a_recording_was_made_at_is_recovered(tmp_path):
    """Two windows of one recording at 9.5 kPa (ω_n rises 0.08 rad/s per kPa): one pressure for both,
    recovered within 0.3 kPa, the windows replayed at the estimate to within 5 mrad."""
    logs = [
        _steer_log(tmp_path, "a", 9.5, 0.38, path="rec.csv"),
        _steer_log(tmp_path, "b", 9.5, -0.3, path="rec.csv"),
    ]
    fit = fit_pressure(logs, "injected", ShellCalibration.from_dict(SYNTH_CAL), drive_friction="none")
    assert fit.pressure_kpa == pytest.approx(9.5, abs=0.3)
    assert fit.logs == ["a", "b"] and not fit.unidentified and not fit.at_bound
    assert all(r["phi"] < 0.005 and r["theta"] < 0.005 for r in fit.rmse_rad.values())
    lo, hi = fit.near_best_kpa
    assert lo <= fit.pressure_kpa <= hi
    # the profile is worse at both ends of the range than at the estimate
    assert fit.profile[0][1] > fit.pooled_rmse_rad and fit.profile[-1][1] > fit.pooled_rmse_rad


def test_an_estimate_on_the_range_bound_says_so(tmp_path):
    """A recording stiffer than the calibration allows at any pressure in its range (made at 14 kPa with
    ω_n 0.6 rad/s higher): the estimate sits on the upper bound and the note says so."""
    stiff = dict(SYNTH_CAL, omega_n={"model": "linear", "intercept_rad_s": 3.1, "slope_rad_s_per_kpa": 0.08})
    log = _steer_log(tmp_path, "stiff", 14.0, 0.38, cal=stiff)
    fit = fit_pressure([log], "injected", ShellCalibration.from_dict(SYNTH_CAL), drive_friction="none")
    assert fit.at_bound and fit.pressure_kpa > 13.5
    assert any("bound" in n for n in fit.notes)


def test_windows_are_grouped_by_recording(tmp_path):
    logs = [RobotLog(n, p, [0.0, 0.1], {}, fixture="free") for n, p in (("a", "x"), ("b", "y"), ("c", "x"))]
    assert [[log.name for log in g] for g in by_recording(logs)] == [["a", "c"], ["b"]]


def test_point_contact_has_no_pressure_to_estimate(tmp_path):
    log = _steer_log(tmp_path, "a", 6.0, 0.38)
    with pytest.raises(FitError, match="model: 'point' has no pressure to estimate"):
        fit_pressure([log], "point", ShellCalibration.from_dict(SYNTH_CAL))


def test_cli_refuses_an_unknown_trial_before_simulating(tmp_path, capsys):
    code = calibrate(["pressure-fit", "--trial", "no_such_trial", "--json", str(tmp_path / "out.json")])
    assert code == 2
    assert "no_such_trial" in capsys.readouterr().err
    assert not (tmp_path / "out.json").exists()


def test_pressure_study_without_the_logs_writes_nothing(tmp_path, capsys):
    out = tmp_path / "pressure_per_log.json"
    code = calibrate(["pressure-study", "--data-root", str(tmp_path / "no_logs"), "--out", str(out)])
    assert code == 2
    assert "real logs not found" in capsys.readouterr().err
    assert not out.exists()


def test_cli_refuses_a_window_of_another_fixture_before_fitting_anything(tmp_path, capsys):
    """A selection that mixes a stand window (φ and θ logged, but the shell held) into free-motion
    windows is refused whole, before the first recording is fitted: nothing is written."""
    twin = steer_twin(write_calibration(tmp_path / "cal.yaml"), 6.0)
    for name in ("a", "b"):
        synth_log(tmp_path / f"{name}.csv", twin, InitialState(theta=0.38, roll=-0.3), 1.0, channels=("theta", "phi"))
    man = write_manifest(
        tmp_path / "m.yaml",
        [
            {"name": "a", "group": "g", "file": "a.csv", "fixture": "steer_plane"},
            {"name": "b", "group": "g", "file": "b.csv", "fixture": "stand"},
        ],
    )
    out = tmp_path / "out.json"
    code = calibrate(["pressure-fit", "--manifest", str(man), "--group", "g", "--json", str(out)])
    said = capsys.readouterr()
    assert code == 2
    assert "b (stand)" in said.err
    assert said.out == ""  # no recording was fitted (each prints its estimate)
    assert not out.exists()
