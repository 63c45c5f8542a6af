"""Evaluation sweeps: CSV, report, non-empty plots, an HTML replay that headless Chromium renders
with the robot in view, a user callable, bad grids refused, and Ray == process pool."""

from __future__ import annotations

import csv
import os
import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image

from sphere_env.evaluation.evaluate import SweepSpec, evaluate

CI = os.environ.get("CI", "").lower() in ("1", "true", "yes")


def half_brake(obs, info=None):
    """A user controller: drive torque against the speed error."""
    return np.array([0.0, np.clip(0.3 * (obs[11] - obs[6]), -1, 1)], np.float32)


def _need(what: str, ok: bool):
    if not ok:
        if CI:
            pytest.fail(f"{what} missing (make installs it)")
        pytest.skip(f"{what} missing")


def chromium_screenshot(html, png, size=(800, 600)):
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:  # a system package: `make chromium` installs it (as root); `make test` never does
        pytest.skip("chromium not found: the replay screenshot needs a browser (`make chromium` installs it, as root)")
    profile = png.parent / "chromium-profile"
    cmd = [
        exe,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={profile}",
        f"--window-size={size[0]},{size[1]}",
        "--virtual-time-budget=4000",
        f"--screenshot={png}",
        html.resolve().as_uri(),
    ]
    subprocess.run(cmd, capture_output=True, timeout=120, check=False)
    assert png.exists(), "chromium wrote no screenshot"
    return np.asarray(Image.open(png).convert("RGB")).astype(int)


@pytest.mark.slow
def test_sweep_writes_csv_report_plots_and_replay(tmp_path):
    spec = SweepSpec(
        controllers=["zero", "pd", "user=tests.evaluation.test_sweep:half_brake"],
        pressures_kpa=[3.0, 14.0],
        shell_models=["point", "injected"],
        seeds=[0],
    )
    res = evaluate(spec, tmp_path, workers=2, replays=["pd,injected,14"])
    with open(tmp_path / "episodes.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 3 * 2 * 2
    assert {r["controller"] for r in rows} == {"zero", "pd", "user"}
    for col in ("is_success", "tracking_rmse_rad_s", "lateral_drift_m", "energy_j", "peak_torque_nm"):
        assert all(r[col] != "" for r in rows), col
    zero = [r for r in rows if r["controller"] == "zero"]
    assert all(float(r["energy_j"]) == 0.0 and float(r["peak_torque_nm"]) == 0.0 for r in zero)
    report = (tmp_path / "report.md").read_text()
    assert "Summary per controller" in report and "Point Mean Error" in report
    assert any(r["reference"] == "point" and r["simulation"] == "injected" for r in res["pme"])
    for name in ("drive_velocity", "error_bars", "success_tracking", "pme"):
        img = np.asarray(Image.open(tmp_path / "plots" / f"{name}.png").convert("L"))
        assert img.shape[0] > 100 and img.shape[1] > 100 and img.std() > 5, name

    html = tmp_path / "replay_pd_injected_14kPa_s0.html"
    assert html.exists() and html.stat().st_size > 10_000
    shot = chromium_screenshot(html, tmp_path / "replay.png")
    assert shot.std() > 10, "blank screenshot"
    r, g, b = shot[..., 0], shot[..., 1], shot[..., 2]
    green = (g > r + 40) & (g > b - 10)  # the shell is drawn green (URDF material "shell")
    assert green.sum() > 100, f"robot not visible ({green.sum()} shell pixels)"


def test_bad_grids_refused():
    with pytest.raises(
        ValueError, match=r"^field 'pressures_kpa\[0\]' = 99\.0: .*; allowed: \[3\.0, 14\.0\] kPa, the calibrated range"
    ):
        SweepSpec(controllers=["zero"], pressures_kpa=[99.0]).check()
    with pytest.raises(ValueError, match=r"^field 'shell_models\[0\]' = 'jelly'"):
        SweepSpec(controllers=["zero"], shell_models=["jelly"]).check()
    with pytest.raises(ValueError, match="controller: cannot import 'nonexistent_module_xyz:f'"):
        SweepSpec(controllers=["nonexistent_module_xyz:f"]).check()
    with pytest.raises(ValueError, match=r"^field 'frictions\[0\]' = 'sticky'"):
        SweepSpec(controllers=["zero"], frictions=["sticky"]).check()


@pytest.mark.slow
def test_ray_sweep_equals_process_pool(tmp_path):
    try:
        import ray  # noqa: F401
    except ImportError:
        _need("ray", False)
    spec = SweepSpec(
        controllers=["zero", "pd"], pressures_kpa=[3.0, 14.0], shell_models=["point", "injected"], seeds=[0]
    )
    evaluate(spec, tmp_path / "pool", workers=2, replays=[], plots=False)
    evaluate(spec, tmp_path / "ray", workers=2, ray_address="local", replays=[], plots=False)
    a = (tmp_path / "pool" / "episodes.csv").read_text()
    b = (tmp_path / "ray" / "episodes.csv").read_text()
    assert a == b
    assert len(a.splitlines()) == 1 + 2 * 2 * 2
