"""Held parameters: a parameter the data do not pin down is held instead of fitted, and candidate
holds are chosen by held-out error as forms are (``steer-fit --hold``)."""

import math
import re

import pytest

from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.shell_fit import fit_shell
from sphere_env.calibration.shell_params import check_hold
from sphere_env.calibration.steer_fit import choose_variant, steer_fit, variant_label
from sphere_env.models.shell import ShellCalibration
from sphere_env.physics import InitialState

from .conftest import SYNTH_CAL, record, steer_twin, write_calibration

P = 6.0
PHI_A = 0.08
TRUTH = dict(
    SYNTH_CAL,
    steer_law={
        "form": "saturating",
        "rest_angle_rad": 0.02,
        "amplitude_stiffness_nm_per_rad": 100.0,
        "amplitude_scale_rad": PHI_A,
    },
)


def _log(tmp_path, name: str, theta0: float, duration_s: float = 2.0) -> RobotLog:
    twin = steer_twin(write_calibration(tmp_path / f"{name}.yaml", TRUTH), P)
    t, data = record(twin, InitialState(theta=theta0, roll=-0.37), duration_s, channels=("theta", "phi"))
    return RobotLog(name, f"<{name}>", t, data, fixture="steer_plane")


def test_check_hold_names_the_parameter_the_value_and_what_is_allowed():
    assert check_hold({"amplitude_scale_rad": 0.07}) == {"amplitude_scale_rad": 0.07}
    with pytest.raises(ValueError, match=r"unknown parameter 'amplitude_scale'.*allowed: \[.*'amplitude_scale_rad'"):
        check_hold({"amplitude_scale": 0.07})
    with pytest.raises(ValueError, match=r"amplitude_scale_rad = 5.0 is outside its search range \[0.03, 1.5\]"):
        check_hold({"amplitude_scale_rad": 5.0})
    with pytest.raises(ValueError, match="zeta = nan"):
        check_hold({"zeta": math.nan})


def test_a_held_parameter_is_not_fitted_and_the_others_are(tmp_path):
    """Held at its true value, φ_a stays exactly there and the amplitude stiffness is recovered;
    held at twice its value, the same fit cannot follow the log as well: the hold takes effect.
    The fitted parameters are the form's own without the held one (no ``params`` given)."""
    log = _log(tmp_path, "a", 0.38)
    base = ShellCalibration.from_dict(TRUTH)
    start = {"amplitude_stiffness_nm_per_rad": 60.0, "zeta": 0.2, "rest_angle_rad": 0.0}

    def fit_with(phi_a: float):
        hold = {"amplitude_scale_rad": phi_a}
        return fit_shell([log], "injected", P, base=base, form="saturating", start=start, hold=hold, max_nfev=30)

    right = fit_with(PHI_A)
    assert right.held == {"amplitude_scale_rad": PHI_A}
    assert set(right.ci95) == {"omega_n", "zeta", "rest_angle_rad", "amplitude_stiffness_nm_per_rad"}
    assert right.calibration["steer_law"]["amplitude_scale_rad"] == PHI_A
    assert right.params["amplitude_stiffness_nm_per_rad"] == pytest.approx(100.0, rel=0.05)
    assert right.as_dict()["held"] == {"amplitude_scale_rad": PHI_A}
    wrong = fit_with(2 * PHI_A)
    assert wrong.calibration["steer_law"]["amplitude_scale_rad"] == 2 * PHI_A
    assert wrong.rmse["a"]["phi"] > 3 * right.rmse["a"]["phi"]


def test_choose_variant_picks_the_hold_with_the_least_held_out_error():
    rows = [
        {"form": "saturating", "held": {"amplitude_scale_rad": 0.04}, "rmse_phi_rad": 0.05},
        {"form": "saturating", "held": {"amplitude_scale_rad": 0.04}, "rmse_phi_rad": 0.07},
        {"form": "saturating", "held": {"amplitude_scale_rad": 0.07}, "rmse_phi_rad": 0.02},
        {"form": "saturating", "held": {"amplitude_scale_rad": 0.07}, "rmse_phi_rad": 0.04},
        {"form": "linear", "held": {}, "rmse_phi_rad": 0.04},
        {"form": "linear", "held": {}, "rmse_phi_rad": 0.05},
    ]
    form, held, mean = choose_variant(rows)
    assert (form, held) == ("saturating", {"amplitude_scale_rad": 0.07})
    assert mean == {
        "saturating [amplitude_scale_rad=0.04]": pytest.approx(0.06),
        "saturating [amplitude_scale_rad=0.07]": pytest.approx(0.03),
        "linear": pytest.approx(0.045),
    }
    # within 0.1 mrad the form with fewer parameters wins, then the candidate listed first
    tie = [
        {"form": "saturating", "held": {"amplitude_scale_rad": 0.1}, "rmse_phi_rad": 0.04},
        {"form": "saturating", "held": {"amplitude_scale_rad": 0.2}, "rmse_phi_rad": 0.03996},
    ]
    assert choose_variant(tie)[1] == {"amplitude_scale_rad": 0.1}
    assert variant_label("linear", {}) == "linear"


@pytest.mark.slow
def test_steer_fit_chooses_a_held_value_by_held_out_error_and_records_it(tmp_path):
    """Two windows of one saturating shell; φ_a held at the truth or at four times it: the truth is
    chosen on held-out error, recorded under ``held``, and the held-out rows carry it."""
    logs = [_log(tmp_path, "a", 0.38), _log(tmp_path, "b", -0.3)]
    base = ShellCalibration.from_dict(TRUTH)
    raw, rec = steer_fit(
        logs,
        ["injected"],
        P,
        base,
        forms=("saturating",),
        max_nfev=20,
        holds=({"amplitude_scale_rad": 4 * PHI_A}, {"amplitude_scale_rad": PHI_A}),
    )
    assert rec["held"] == {"amplitude_scale_rad": PHI_A}
    assert raw["steer_law"]["amplitude_scale_rad"] == PHI_A
    assert rec["models"]["injected"]["held"] == {"amplitude_scale_rad": PHI_A}
    assert "amplitude_scale_rad" not in rec["models"]["injected"]["ci95_over_windows"]
    held_out = rec["leave_one_window_out"]
    assert {r["test"] for r in held_out} == {"a", "b"}
    assert all(r["held"] == {"amplitude_scale_rad": PHI_A} for r in held_out)
    labels = {variant_label(r["form"], r.get("held")) for r in rec["form_cross_validation"]}
    assert labels == {"saturating [amplitude_scale_rad=0.32]", "saturating [amplitude_scale_rad=0.08]"}


@pytest.mark.parametrize(
    "hold, message",
    [
        (["amplitude_scale=0.07"], "unknown parameter 'amplitude_scale'"),
        (["amplitude_scale_rad=5"], r"amplitude_scale_rad = 5.0 is outside its search range \[0.03, 1.5\]"),
        (["amplitude_scale_rad"], "expected NAME=VALUE"),
        (["amplitude_scale_rad=0.07,x"], "could not convert"),
        (["zeta=0.2", "zeta=0.3"], "named twice"),
        (["couple_damping_factor=0.2,0.4", "--models", "hydroelastic"], "2 candidates are chosen on the injected"),
    ],
)
def test_steer_fit_refuses_a_bad_hold_before_anything_runs(tmp_path, capsys, hold, message):
    from sphere_env.calibration.__main__ import main

    out = tmp_path / "cal.yaml"
    argv = ["steer-fit", "--manifest", str(tmp_path / "missing.yaml"), "--hold", *hold, "--out", str(out)]
    try:
        rc = main(argv)
    except SystemExit as stop:  # argparse's own refusal of a malformed item
        rc = stop.code
    assert rc == 2 and not out.exists()
    err = capsys.readouterr().err
    assert "--hold" in err and re.search(message, err), err
