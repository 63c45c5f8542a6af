"""Logs that cannot be right are refused with file, line/column and what is allowed: a non-finite
last timestamp (which used to hang validate), angles in degrees, rates in deg/s against angles in
rad, µs timestamps read as ns, pressures in Pa; a constant signal has no decay to fit."""

from __future__ import annotations

import numpy as np
import pytest

from sphere_env.analysis.decay import fit_free_decay
from sphere_env.calibration.__main__ import main
from sphere_env.calibration.log_csv import load_log, write_log_csv
from sphere_env.calibration.logs import LogError
from sphere_env.calibration.manifest import load_manifest
from tests.calibration.conftest import write_manifest

T = np.arange(101) * 0.02  # 2 s at 50 Hz
THETA = 0.38 * np.exp(-0.4 * T) * np.cos(3.0 * T)  # a steer swing [rad]
THETA_DOT = np.gradient(THETA, T)


def _log(tmp_path, name, **channels):
    return write_log_csv(tmp_path / f"{name}.csv", T, channels)


def test_valid_synthetic_log_loads(tmp_path):
    log = load_log(_log(tmp_path, "ok", theta=THETA, theta_dot=THETA_DOT, phi=-THETA))
    assert log.t_s[-1] == pytest.approx(2.0)


def test_infinite_last_timestamp_refused_and_validate_exits(tmp_path, capsys):
    p = _log(tmp_path, "inf", theta=THETA, phi=-THETA)
    lines = p.read_text().splitlines()
    last = lines[-1].split(",")
    lines[-1] = ",".join(["inf", *last[1:]])
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogError, match=rf"line {len(lines)}, column 'timestamp': time inf is not finite"):
        load_log(p)
    man = write_manifest(tmp_path / "m.yaml", [{"name": "inf", "file": "inf.csv", "fixture": "steer_plane"}])
    assert main(["validate", "--manifest", str(man), "--models", "point", "--drive-friction", "none"]) == 2
    assert "not finite" in capsys.readouterr().err


def test_angles_in_degrees_refused(tmp_path):
    p = _log(tmp_path, "deg", theta=np.degrees(THETA))
    with pytest.raises(LogError, match=r"column 'roll_joint.position': theta spans .* allowed: at most 3 rad"):
        load_log(p)


def test_rates_in_deg_per_s_refused(tmp_path):
    small = 0.05 * THETA / 0.38  # a 0.05 rad swing: its rate in deg/s stays below the magnitude limit
    p = _log(tmp_path, "degs", theta=small, theta_dot=np.degrees(np.gradient(small, T)))
    with pytest.raises(LogError, match=r"columns 'roll_joint.velocity' and 'roll_joint.position': theta_dot is 57"):
        load_log(p)
    big = _log(tmp_path, "degs_big", theta=THETA, theta_dot=np.degrees(THETA_DOT))
    with pytest.raises(LogError, match=r"allowed \|theta_dot\| <= 30 rad/s"):
        load_log(big)


def test_microsecond_timestamps_read_as_ns_refused(tmp_path):
    p = tmp_path / "us.csv"
    p.write_text(
        "timestamp,roll_joint.position\n" + "".join(f"{i * 20000},{0.1 * np.sin(i / 5):.5f}\n" for i in range(50))
    )
    with pytest.raises(LogError, match=r"median sample period 2e-05 s with unit 'ns' is implausible"):
        load_log(p)


@pytest.mark.parametrize("pressure", [4000, 12000, 0.008, -3, True])
def test_manifest_pressure_outside_a_shell_gauge_range_refused(tmp_path, pressure):
    man = write_manifest(
        tmp_path / "m.yaml", [{"name": "a", "file": "a.csv", "fixture": "steer_plane", "pressure_kpa": pressure}]
    )
    with pytest.raises(LogError, match=r"field 'trials\[0\].pressure_kpa' = .* within \[0.5, 100.0\]"):
        load_manifest(man)


def test_constant_signal_has_no_decay_to_fit():
    with pytest.raises(ValueError, match="constant"):
        fit_free_decay(T, np.full_like(T, 0.2))
    with pytest.raises(ValueError, match="finite"):
        fit_free_decay(T, np.where(T > 1, np.nan, THETA))
    fit = fit_free_decay(T, THETA)  # a real decay still fits
    assert fit.omega_n == pytest.approx(np.hypot(3.0, 0.4), rel=0.02)
    assert fit.omega_n_ci[0] < fit.omega_n < fit.omega_n_ci[1]


def test_output_paths_checked_before_any_fit(tmp_path, capsys):
    f = tmp_path / "a_file"
    f.write_text("x")
    man = write_manifest(tmp_path / "m.yaml", [{"name": "ok", "file": "ok.csv", "fixture": "steer_plane"}])
    _log(tmp_path, "ok", theta=THETA, phi=-THETA)
    assert main(["validate", "--manifest", str(man), "--models", "point", "--json", str(f / "v.json")]) == 2
    assert "--json" in capsys.readouterr().err
    assert main(["shell", "--manifest", str(man), "--group", "", "--out", str(tmp_path)]) == 2
    assert "is a folder" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file", "m.yaml", "ok.csv"]


def test_every_shared_log_loads_as_recorded(roboball_dir):
    """The shared logs, unedited: the pushes cut's drive encoder reads ≈ -264 rad (a multi-turn count
    since the controller booted); multi-turn angles start from 0, as the twin's do."""
    files = sorted(roboball_dir.rglob("*.csv"))
    if not files:
        pytest.skip(f"no logs under {roboball_dir}")
    import pandas as pd

    for f in files:
        log = load_log(f)
        for chan in ("drive_angle", "heading"):
            if log.has(chan):
                assert log[chan][0] == 0.0
    pushes = roboball_dir / "free_robot" / "pushes_20s-37s.csv"
    if pushes.exists():
        raw = pd.read_csv(pushes)["drive_shaft.position"].to_numpy()
        assert abs(raw[0]) > 200  # as recorded
        log = load_log(pushes)
        np.testing.assert_allclose(log["drive_angle"], -(raw - raw[0]), atol=1e-12)


def test_a_gap_in_the_log_is_refused_with_its_time(tmp_path):
    t_ns = np.r_[np.arange(50) * 20_000_000, 3600e9 + np.arange(50) * 20_000_000]
    p = tmp_path / "gap.csv"
    p.write_text(
        "timestamp,roll_joint.position\n" + "".join(f"{int(t)},{0.1 * np.sin(i / 5):.5f}\n" for i, t in enumerate(t_ns))
    )
    with pytest.raises(LogError, match=r"line 52, column 'timestamp': a gap of 3599 s at t = 0.980 s"):
        load_log(p)


def test_a_multi_turn_encoder_in_degrees_is_refused_by_its_jumps(tmp_path):
    t = np.arange(100) * 0.01
    drive = 264.0 + 1.5 * t  # rolling at 1.5 rad/s, an offset multi-turn count: fine in rad
    p = tmp_path / "ok.csv"
    p.write_text("timestamp,drive_shaft.position\n" + "".join(f"{int(x * 1e9)},{d:.6f}\n" for x, d in zip(t, drive)))
    assert load_log(p)["drive_angle"][-1] == pytest.approx(-1.5 * t[-1])
    deg = tmp_path / "deg.csv"
    deg.write_text(
        "timestamp,drive_shaft.position\n" + "".join(f"{int(x * 1e9)},{np.degrees(d):.6f}\n" for x, d in zip(t, drive))
    )
    with pytest.raises(LogError, match=r"drive_angle jumps by .* allowed: at most 60 rad/s between samples"):
        load_log(deg)
