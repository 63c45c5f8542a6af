"""The driven replay and the drive-direction fit: bad input refused by name, and the committed held-out
figures reproduced on the real log (skipped without it)."""

import json
from pathlib import Path

import numpy as np
import pytest

from sphere_env.calibration.drive_fit import DriveTwin, fit_drive
from sphere_env.calibration.drive_study import AIMS_RAD_S
from sphere_env.calibration.driven import check_driven, driven_rmse
from sphere_env.calibration.logs import LogError, RobotLog
from sphere_env.calibration.manifest import load_manifest
from sphere_env.calibration.shell_fit import FitError
from sphere_env.models.shell import ShellCalibration

REPO = Path(__file__).resolve().parents[2]
MANIFEST = REPO / "assets" / "logs" / "roboball.yaml"
RESULTS = REPO / "evaluation" / "results" / "validation" / "drive_fit.json"
#: How far a replay on another machine may drift from the committed figure [rad/s].
REPRODUCE_TOL_RAD_S = 0.01


def test_driven_window_without_pitch_is_refused_by_name():
    t = np.linspace(0.0, 1.0, 11)
    log = RobotLog("d", "x.csv", t, {"theta": t, "phi": t, "omega_d": t, "heading_rate": t}, fixture="free")
    with pytest.raises(LogError, match="pendulum_pitch"):
        check_driven(log)
    log.channels["pendulum_pitch"] = t
    log.fixture = "steer_plane"
    with pytest.raises(LogError, match="fixture 'steer_plane'"):
        check_driven(log)


def test_drive_fit_refuses_unknown_model_and_no_windows():
    cal = ShellCalibration.load()
    with pytest.raises(FitError, match="unknown"):
        fit_drive([], "rigid", cal)
    with pytest.raises(FitError, match="no driven windows"):
        fit_drive([], "injected", cal)


def test_drive_law_is_opt_in_and_checked():
    raw = {k: v for k, v in ShellCalibration.load("free_robot").raw.items() if k not in ("drive_law", "drive_fit")}
    assert ShellCalibration.from_dict(raw).spin_damping_nms_per_rad == 0.0
    with pytest.raises(ValueError, match="spin_damping_nms_per_rad"):
        ShellCalibration.from_dict(dict(raw, drive_law={"spin_damping_nms_per_rad": -1.0}))


@pytest.mark.realdata
def test_held_out_part_meets_the_aims_or_the_measured_figure(roboball_dir):
    """Each soft shell's fit, replayed on the part it never saw: within the aims where the committed
    results meet them; where they do not (the aim is reported as blocked in docs/calibration.md), within
    the measured figure. Both directions, both soft shells."""
    results = json.loads(RESULTS.read_text())
    man = load_manifest(MANIFEST, data_root=roboball_dir)
    twins = {}
    for row in results["fits"]:
        if row["model"] == "point":
            continue
        log = man.by_name(row["test"]).load()
        key = (row["model"], row["base_calibration"])
        dt = twins.get(key) or twins.setdefault(key, DriveTwin(row["model"], ShellCalibration.load(key[1])))
        held = driven_rmse(dt.replay(log, row["fit"]["params"]), log)
        for ch, aim in AIMS_RAD_S.items():
            measured = row["held_out_rmse"][ch]
            assert held[ch] == pytest.approx(measured, abs=REPRODUCE_TOL_RAD_S), (row["model"], row["test"], ch)
            if row["aims_met"][ch]:
                assert held[ch] <= aim + 1e-9
            else:  # BLOCKED: the aim is not met; the measured figure is what is checked
                assert held[ch] <= measured + REPRODUCE_TOL_RAD_S


@pytest.mark.realdata
def test_drive_fit_refuses_free_motion_windows_by_name(roboball_dir, capsys, tmp_path):
    from sphere_env.calibration.__main__ import main

    out = tmp_path / "d.json"
    argv = ["drive-fit", "--data-root", str(roboball_dir), "--fit-on", "push_1", "push_2", "--json", str(out)]
    assert main(argv) == 2 and not out.exists()
    assert "'push_1' is not a driven window" in capsys.readouterr().err


@pytest.mark.realdata
def test_validate_replays_a_driven_window_and_records_the_torques(roboball_dir, tmp_path):
    from sphere_env.calibration.__main__ import main

    out = tmp_path / "v.json"
    argv = ["validate", "--data-root", str(roboball_dir), "--trial", "drive_forward", "--models", "injected"]
    assert main([*argv, "--calibration", "free_robot", "--json", str(out), "--tol", "heading_rate=5"]) == 0
    (rec,) = json.loads(out.read_text())
    assert rec["kind"] == "driven" and rec["window_s"] == [10.0, 16.0]
    assert rec["rmse_heading_rate_rad_s"] > 0 and rec["rmse_omega_d_rad_s"] > 0
    drive = rec["torques"]["drive"]
    assert drive["limit_nm"] == 22.0 and 0 < drive["peak_nm"] <= drive["limit_nm"]
