"""The shell law against the real logs: hydroelastic rocks back the right way after a sideways tilt."""

from pathlib import Path

import numpy as np
import pytest
import yaml

from sphere_env.calibration.log_csv import load_log
from sphere_env.calibration.logs import LogError
from sphere_env.calibration.manifest import load_manifest
from sphere_env.calibration.shell_fit import fixture_twin, window
from sphere_env.calibration.simulate import simulate_log

MANIFEST = Path(__file__).resolve().parents[2] / "assets" / "logs" / "roboball.yaml"
pytestmark = pytest.mark.realdata


def first_swing(t, phi, horizon_s=1.0) -> float:
    """The largest excursion of φ from its start within ``horizon_s`` [rad], with its sign."""
    d = np.asarray(phi)[np.asarray(t) <= horizon_s] - phi[0]
    return float(d[np.argmax(np.abs(d))])


def free_release(roboball_dir, seconds=1.0):
    """The free_robot release (manifest entry ``free_release`` when present, else found in the CSV)."""
    man = load_manifest(MANIFEST, data_root=roboball_dir)
    try:
        log = man.by_name("free_release").load(required=("phi", "theta"))
    except LogError:
        full = load_log(roboball_dir / "free_robot" / "data2-conv.csv", required=("phi", "theta"), name="free_release")
        full.fixture = "free"
        moving = np.flatnonzero((full.t_s > 32.0) & (np.abs(full["theta_dot"]) > 0.05))
        start = float(full.t_s[moving[0] - 1])
        log = window(full, start, start + 3.0, "free_release")
    return window(log, 0.0, seconds, log.name)


def test_hydroelastic_first_swing_after_a_sideways_tilt_goes_the_way_of_the_log(roboball_dir):
    """Released at φ ≈ −0.40 rad the real robot swings to positive φ; so must the hydroelastic twin
    (before the steer couple, hydroelastic and point contact swung the wrong way on most pushes)."""
    log = free_release(roboball_dir)
    twin = fixture_twin("free", "hydroelastic")
    tr = simulate_log(twin, log)
    real, sim = first_swing(log.t_s, log["phi"]), first_swing(tr.t_s, tr["phi"])
    print(f"first swing of phi: log {real:+.3f} rad, hydroelastic {sim:+.3f} rad")
    assert abs(real) > 0.3 and np.sign(sim) == np.sign(real)
    assert abs(sim) > 0.6 * abs(real)  # the calibration without the couple reached 0.45 of the log


def test_hydroelastic_first_swing_on_steer_free_goes_the_way_of_the_log(roboball_dir):
    man = load_manifest(MANIFEST, data_root=roboball_dir)
    twin = fixture_twin("steer_plane", "hydroelastic")
    for spec in man.group("steer_free"):
        log = window(spec.load(required=("phi", "theta")), 0.0, 1.5, spec.name)
        tr = simulate_log(twin, log)
        real, sim = first_swing(log.t_s, log["phi"], 1.5), first_swing(tr.t_s, tr["phi"], 1.5)
        assert np.sign(sim) == np.sign(real) and abs(sim) > 0.6 * abs(real), (spec.name, real, sim)


FREE_ROBOT = Path(__file__).resolve().parents[2] / "assets" / "calibration" / "free_robot.yaml"
DEFAULT = Path(__file__).resolve().parents[2] / "assets" / "calibration" / "default.yaml"


def _rmse(tr, log) -> dict[str, float]:
    return {c: float(np.sqrt(np.mean((tr[c] - log[c]) ** 2))) for c in ("phi", "theta")}


@pytest.mark.parametrize("model", ["injected", pytest.param("hydroelastic", marks=pytest.mark.slow)])
def test_shipped_free_robot_calibration_reproduces_every_free_window(roboball_dir, model):
    """assets/calibration/free_robot.yaml was fitted on the four free-robot windows at once (a fit, not a
    test): every window within φ ≤ 0.06 and θ ≤ 0.08 rad, the pushes both ways and the release."""
    man = load_manifest(MANIFEST, data_root=roboball_dir)
    twin = fixture_twin("free", model, calibration=FREE_ROBOT)
    errs = {}
    for spec in man.group("free_robot"):
        log = spec.load(required=("phi", "theta"))
        errs[spec.name] = _rmse(simulate_log(twin, log), log)
    print(model, errs)
    assert set(errs) == {"free_release", "push_1", "push_2", "push_3"}
    assert all(e["phi"] <= 0.06 and e["theta"] <= 0.08 for e in errs.values()), errs


@pytest.mark.slow
def test_free_robot_law_fitted_on_the_pushes_predicts_the_release(roboball_dir, tmp_path):
    """Held out: the saturating law fitted on the three pushes (from the steer_free calibration, which saw
    no free-robot data) replays the release it never saw within φ ≤ 0.06 and θ ≤ 0.08 rad, although the
    release swings φ to 0.41 rad and the pushes at most to 0.37 rad."""
    from sphere_env.calibration.steer_fit import steer_fit
    from sphere_env.models.shell import ShellCalibration

    man = load_manifest(MANIFEST, data_root=roboball_dir)
    pushes = [man.by_name(f"push_{i}").load(required=("phi", "theta")) for i in (1, 2, 3)]
    base = ShellCalibration.load(DEFAULT)
    raw, _ = steer_fit(
        pushes, ["injected"], base.nominal_pressure_kpa, base, forms=("saturating",), hold_out_windows=False
    )
    cal = tmp_path / "pushes.yaml"
    cal.write_text(yaml.safe_dump(dict(raw)))
    release = man.by_name("free_release").load(required=("phi", "theta"))
    err = _rmse(simulate_log(fixture_twin("free", "injected", calibration=cal), release), release)
    print("held-out free_release:", err)
    assert err["phi"] <= 0.06 and err["theta"] <= 0.08, err


@pytest.mark.parametrize("model", ["injected", pytest.param("hydroelastic", marks=pytest.mark.slow)])
def test_shipped_calibration_on_steer_free(roboball_dir, model):
    """The shipped calibration was fitted on both steer_free trials: φ ≤ 0.04 and θ ≤ 0.06 rad on each
    (the linear law about φ = 0 it replaces reached φ 0.063 / 0.093 rad with injected)."""
    man = load_manifest(MANIFEST, data_root=roboball_dir)
    twin = fixture_twin("steer_plane", model)
    for spec in man.group("steer_free"):
        log = spec.load(required=("phi", "theta"))
        tr = simulate_log(twin, log)
        phi = float(np.sqrt(np.mean((tr["phi"] - log["phi"]) ** 2)))
        theta = float(np.sqrt(np.mean((tr["theta"] - log["theta"]) ** 2)))
        print(f"{model} {spec.name}: phi {phi:.4f} theta {theta:.4f} rad")
        assert phi <= 0.04 and theta <= 0.06, (spec.name, phi, theta)


@pytest.mark.parametrize("calibration", ["default", "free_robot"])
def test_steer_free_replays_on_the_free_fixture_match_the_steer_plane_fixture(roboball_dir, calibration):
    """The steer_free trials run on ``steer_plane`` (shell confined to the steer plane, drive welded),
    the free robot on ``free``. A sideways rock from rest with no drive torque stays in the steer plane
    by symmetry, so the two fixtures must replay a trial alike: the gap between the two setups'
    calibrations is then in the shell law, not in the fixture."""
    import dataclasses

    man = load_manifest(MANIFEST, data_root=roboball_dir)
    plane = fixture_twin("steer_plane", "injected", calibration=calibration)
    free = fixture_twin("free", "injected", calibration=calibration)
    for spec in man.group("steer_free"):
        log = spec.load(required=("phi", "theta"))
        a = simulate_log(plane, log)
        b = simulate_log(free, dataclasses.replace(log, fixture="free"))
        assert np.ptp(a["phi"]) > 0.3  # the trial swings
        for ch in ("phi", "theta"):
            np.testing.assert_allclose(b[ch], a[ch], atol=5e-3, err_msg=f"{spec.name} {ch} ({calibration})")
