"""Free-motion segments: initial state from a log, round trip, and the shell-law fit on `free` windows."""

import math

import numpy as np
import pytest
import yaml

from sphere_env.analysis.metrics import rmse
from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.shell_fit import FitError, calibration_with, fit_shell, window
from sphere_env.calibration.simulate import initial_state_from_log, simulate_log
from sphere_env.models.shell import ShellCalibration
from sphere_env.physics import InitialState, Twin, TwinConfig

from .conftest import SYNTH_CAL

FREE_CHANNELS = ("theta", "theta_dot", "phi", "phi_dot", "drive_angle", "drive_rate", "heading", "heading_rate")
TRUTH = dict(SYNTH_CAL, steer_law={"form": "linear", "rest_angle_rad": 0.03})
P = 6.0


def free_twin(cal, model="injected"):
    return Twin(
        TwinConfig(
            fixture="free",
            shell_model=model,
            steer_friction="majd_steer",
            drive_friction="majd_drive",
            calibration=cal,
            pressure_kpa=P,
        )
    )


def record_free(twin, initial, duration_s, dt_s=0.01, torque_until_s=0.0, torque=(0.0, 0.0), name="synth"):
    """A `free` log made by the twin: contract channel names, pendulum pitch included."""
    twin.reset(initial)
    n = int(round(duration_s / dt_s))
    t = np.arange(n + 1) * dt_s
    channels = FREE_CHANNELS + ("pendulum_pitch", "pendulum_pitch_rate")
    data = {c: np.empty(n + 1) for c in channels}
    for i in range(n + 1):
        if i:
            tau = torque if t[i] <= torque_until_s + 1e-9 else (0.0, 0.0)
            twin.advance(max(t[i] - twin.time_s - 1e-9, 0.0), tau)
        s = twin.state()
        for c in channels:
            data[c][i] = getattr(s, c)
    return RobotLog(name, f"<{name}>", t, data, fixture="free")


@pytest.fixture(scope="module")
def truth_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("cal") / "truth.yaml"
    path.write_text(yaml.safe_dump(TRUTH))
    return path


def test_initial_state_from_a_free_window_reproduces_the_twin_state(truth_path):
    """Round trip: a window that starts mid-motion (rocking, rolling, pendulum pitched) replays exactly."""
    twin = free_twin(truth_path)
    log = record_free(twin, InitialState(theta=0.6, roll=-0.25), 2.0, torque_until_s=0.5, torque=(0.0, 3.0))
    win = window(log, 0.6, 1.8, "mid")
    assert abs(win["pendulum_pitch"][0]) > 0.01 and abs(win["pendulum_pitch_rate"][0]) > 0.02  # a real test of α
    assert abs(win["drive_rate"][0]) > 0.1 and abs(win["phi_dot"][0]) > 0.1
    init = initial_state_from_log(win, radius_m=twin.robot.radius_m)
    s0 = twin.reset(init)
    assert s0.phi == pytest.approx(win["phi"][0], abs=1e-9)
    assert s0.phi_dot == pytest.approx(win["phi_dot"][0], abs=1e-6)
    assert s0.pendulum_pitch == pytest.approx(win["pendulum_pitch"][0], abs=1e-9)
    assert s0.pendulum_pitch_rate == pytest.approx(win["pendulum_pitch_rate"][0], abs=1e-6)
    assert s0.drive_rate == pytest.approx(win["drive_rate"][0], abs=1e-9)
    assert s0.omega_d == pytest.approx(win["omega_d"][0] if win.has("omega_d") else s0.omega_d)
    tr = simulate_log(twin, win)
    for ch in ("phi", "theta", "pendulum_pitch"):
        assert rmse(tr[ch], win[ch]) < 2e-3, ch


def test_steer_plane_initial_state_is_unchanged():
    log = RobotLog(
        "sp",
        "<sp>",
        np.arange(0, 1, 0.02),
        {"theta": np.full(50, 0.3), "phi": np.linspace(-0.3, -0.2, 50)},
        fixture="steer_plane",
    )
    init = initial_state_from_log(log, radius_m=0.3)
    assert init.roll == pytest.approx(-0.3) and init.angular_velocity_rad_s[0] == pytest.approx(0.1 / 0.98, rel=1e-3)
    assert init.velocity_m_s[1] == pytest.approx(-0.3 * init.angular_velocity_rad_s[0])


@pytest.mark.slow
def test_fit_recovers_the_stiffness_from_a_free_window(truth_path):
    truth = ShellCalibration.load(truth_path)
    twin = free_twin(truth_path)
    log = record_free(twin, InitialState(theta=0.7, roll=-0.3), 2.5, dt_s=0.02)
    log.channels["phi"] = log["phi"] + np.random.default_rng(0).normal(0, 2e-3, len(log.t_s))
    start = ShellCalibration.from_dict(
        calibration_with(truth, P, {"omega_n": 2.6, "zeta": 0.25, "rest_angle_rad": 0.0}, form="linear")
    )
    fit = fit_shell([log], "injected", P, base=start, form="linear", twin=twin)
    K_true, _ = truth.bind(twin.robot).injected_gains(P)
    assert fit.params["omega_n"] == pytest.approx(float(truth.omega_n(P)), rel=0.05)
    assert fit.params["K_inject"] == pytest.approx(K_true, rel=0.05)
    assert fit.params["rest_angle_rad"] == pytest.approx(0.03, abs=0.005)
    lo, hi = fit.ci95["omega_n"]
    assert lo < fit.params["omega_n"] < hi
    # the fitted calibration is a file the twin loads
    Twin(TwinConfig(fixture="free", calibration=None)).set_calibration(ShellCalibration.from_dict(fit.calibration), P)


def test_a_window_without_free_motion_is_refused():
    t = np.arange(0, 2, 0.02)
    log = RobotLog(
        "still", "still.csv", t, {"theta": np.full(len(t), 0.01), "phi": np.full(len(t), -0.002)}, fixture="free"
    )
    with pytest.raises(FitError, match=r"still.csv.*'still': no free motion"):
        fit_shell([log], "injected", P, base=ShellCalibration.from_dict(TRUTH))


def test_a_fit_that_does_not_converge_is_refused(truth_path):
    twin = free_twin(truth_path)
    log = record_free(twin, InitialState(theta=0.5, roll=-0.2), 1.0, dt_s=0.02)
    start = ShellCalibration.from_dict(calibration_with(ShellCalibration.from_dict(TRUTH), P, {"omega_n": 2.5}))
    with pytest.raises(FitError, match="did not converge after 2 evaluations"):
        fit_shell([log], "injected", P, base=start, form="linear", twin=twin, max_nfev=2)


@pytest.mark.slow
def test_steer_fit_cli_on_a_free_window_writes_a_calibration_the_twin_loads(tmp_path, truth_path):
    from sphere_env.calibration.__main__ import main
    from sphere_env.calibration.log_csv import write_log_csv

    twin = free_twin(truth_path)
    log = record_free(twin, InitialState(theta=0.7, roll=-0.3), 2.0, dt_s=0.02)
    write_log_csv(tmp_path / "push.csv", log.t_s, {k: log[k] for k in ("theta", "theta_dot", "phi", "phi_dot")})
    (tmp_path / "m.yaml").write_text(
        yaml.safe_dump(
            {"data_root": ".", "trials": [{"name": "push", "group": "pushes", "file": "push.csv", "fixture": "free"}]}
        )
    )
    out = tmp_path / "fitted.yaml"
    start = tmp_path / "start.yaml"
    start_raw = calibration_with(
        ShellCalibration.from_dict(TRUTH), P, {"omega_n": 2.7, "rest_angle_rad": 0.0}, form="linear"
    )
    # provenance of an earlier fit (must not be carried into the new file) and an assumption (kept)
    start_raw["provenance"] = {"injected_fit": {"fit_on": ["elsewhere"]}, "zeta_rate_per_kpa": {"status": "ASSUMED"}}
    start.write_text(yaml.safe_dump(start_raw))
    rc = main(
        [
            "steer-fit",
            "--manifest",
            str(tmp_path / "m.yaml"),
            "--group",
            "pushes",
            "--fit-on",
            "push",
            "--models",
            "injected",
            "--forms",
            "linear",
            "--pressure-kpa",
            str(P),
            "--base",
            str(start),
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    cal = ShellCalibration.load(out)
    assert float(cal.omega_n(P)) == pytest.approx(float(ShellCalibration.from_dict(TRUTH).omega_n(P)), rel=0.05)
    assert cal.steer_law.rest_angle_rad == pytest.approx(0.03, abs=0.005)
    lo, hi = cal.raw["steer_fit"]["models"]["injected"]["ci95"]["omega_n"]
    assert lo <= float(cal.omega_n(P)) <= hi
    prov = cal.raw["provenance"]
    assert "injected_fit" not in prov and prov["zeta_rate_per_kpa"] == {"status": "ASSUMED"}
    assert "steer_fit record" in prov["shell_fit"]
    # a refused fit writes nothing
    out2 = tmp_path / "refused.yaml"
    rc = main(
        [
            "steer-fit",
            "--manifest",
            str(tmp_path / "m.yaml"),
            "--group",
            "pushes",
            "--models",
            "injected",
            "--forms",
            "linear",
            "--pressure-kpa",
            str(P),
            "--base",
            str(start),
            "--max-nfev",
            "2",
            "--out",
            str(out2),
        ]
    )
    assert rc == 2 and not out2.exists()


def test_form_choice_uses_held_out_error_and_skips_refused_forms():
    from sphere_env.calibration.steer_fit import choose_form

    rows = [
        {"form": "linear", "rmse_phi_rad": 0.05},
        {"form": "linear", "rmse_phi_rad": 0.07},
        {"form": "saturating", "rmse_phi_rad": 0.04},
        {"form": "saturating", "rmse_phi_rad": 0.06},
        {"form": "quadratic", "rmse_phi_rad": 0.01},
        {"form": "quadratic", "rmse_phi_rad": math.inf, "refused": "cannot stand still"},
    ]
    form, mean = choose_form(rows)
    assert form == "saturating" and mean["linear"] == pytest.approx(0.06) and math.isinf(mean["quadratic"])
    # a tie at 0.1 mrad goes to the form with fewer parameters
    assert (
        choose_form([{"form": "linear", "rmse_phi_rad": 0.05}, {"form": "saturating", "rmse_phi_rad": 0.04996}])[0]
        == "linear"
    )
    with pytest.raises(FitError, match="no steer-law form could be fitted"):
        choose_form([{"form": "quadratic", "rmse_phi_rad": math.inf, "refused": "x"}])
