"""validate --json records, --workers, and exit codes when a tolerance compared nothing."""

import json
import math

import numpy as np
import pytest

from sphere_env.calibration.__main__ import main
from sphere_env.calibration.manifest import load_manifest
from sphere_env.calibration.validate import ValidationRow, validate
from sphere_env.physics import InitialState, Twin, TwinConfig

from .conftest import synth_log, write_manifest


@pytest.fixture(scope="module")
def logs_dir(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("vj")
    twin = Twin(
        TwinConfig(fixture="steer_plane", shell_model="injected", steer_friction="majd_steer", drive_friction="none")
    )
    synth_log(tmp / "sf.csv", twin, InitialState(theta=0.38, roll=-0.37), 2.0)
    synth_log(tmp / "phi_only.csv", twin, InitialState(theta=0.3, roll=-0.3), 2.0, channels=("phi",))
    (tmp / "one.csv").write_text("timestamp,ball_roll.position,roll_joint.position\n0,-0.3,0.3\n")
    return tmp


def _manifest(d, names):
    return write_manifest(
        d / f"m_{'_'.join(names)}.yaml",
        [{"name": n, "file": f"{n}.csv", "fixture": "steer_plane", "group": "g"} for n in names],
    )


def test_json_records_have_the_named_fields_and_no_pme_on_flat_ground(logs_dir, tmp_path):
    man = _manifest(logs_dir, ["sf"])
    out = tmp_path / "sub" / "v.json"
    assert (
        main(
            [
                "validate",
                "--manifest",
                str(man),
                "--models",
                "point",
                "injected",
                "--drive-friction",
                "none",
                "--json",
                str(out),
            ]
        )
        == 0
    )
    recs = json.loads(out.read_text())
    assert [(r["trial"], r["model"]) for r in recs] == [("sf", "point"), ("sf", "injected")]
    for r in recs:
        assert {"trial", "model", "rmse_phi_rad", "rmse_theta_rad"} <= set(r)
        assert "pme_percent" not in r and "rmse_omega_d_rad_s" not in r  # flat ground, ω_d not logged
    inj = recs[1]
    assert inj["rmse_phi_rad"] < 1e-6 and inj["rmse_theta_rad"] < 1e-6  # the twin against its own log
    assert recs[0]["rmse_phi_rad"] > 0.05
    assert [p.name for p in out.parent.iterdir()] == ["v.json"]  # no temp file left


@pytest.mark.slow
def test_workers_give_the_same_rows_as_one_process(logs_dir):
    logs = [t.load() for t in load_manifest(_manifest(logs_dir, ["sf", "phi_only"])).trials]
    one = validate(logs, ["point", "injected"], steer_friction="majd_steer", drive_friction="none", workers=1)
    two = validate(logs, ["point", "injected"], steer_friction="majd_steer", drive_friction="none", workers=2)
    assert [r.record() for r in one] == [r.record() for r in two]


def test_tolerance_on_a_missing_channel_or_a_one_sample_log_fails(logs_dir, tmp_path, capsys):
    base = ["--models", "injected", "--drive-friction", "none"]
    man = _manifest(logs_dir, ["phi_only"])
    assert main(["validate", "--manifest", str(man), *base, "--tol", "phi=1.0"]) == 0
    assert main(["validate", "--manifest", str(man), *base, "--tol", "theta=1.0"]) == 1
    assert "phi_only / injected: theta not compared" in capsys.readouterr().err
    one = _manifest(logs_dir, ["one"])
    out = tmp_path / "one.json"
    assert main(["validate", "--manifest", str(one), *base, "--tol", "phi=1.0", "--json", str(out)]) == 1
    assert "phi not compared" in capsys.readouterr().err
    assert json.loads(out.read_text())[0]["rmse_phi_rad"] is None
    # PME asked of a flat-ground trial: not checked, said so.
    assert main(["validate", "--manifest", str(_manifest(logs_dir, ["sf"])), *base, "--tol", "pme=10"]) == 1
    assert "ramp trials only" in capsys.readouterr().err
    # A --tol-models that matches no model compares nothing.
    assert main(["validate", "--manifest", str(man), *base, "--tol", "phi=1.0", "--tol-models", "point"]) == 1
    assert "nothing compared" in capsys.readouterr().err
    with pytest.raises(SystemExit) as refused:  # argparse's one-line error, exit status 2
        main(["validate", "--manifest", str(man), *base, "--workers", "0"])
    assert refused.value.code == 2
    assert "argument --workers: '0'" in capsys.readouterr().err


def test_record_keeps_optional_metrics_only_where_computed():
    nan = math.nan
    flat = ValidationRow("a", "injected", "steer_plane", {"phi": 0.1, "theta": 0.2, "omega_d": nan}, nan)
    assert set(flat.record()) == {"trial", "model", "fixture", "rmse_phi_rad", "rmse_theta_rad"}
    free = ValidationRow(
        "b",
        "hydroelastic",
        "free",
        {"phi": 0.1, "theta": 0.2, "omega_d": 0.3, "pendulum_pitch": 0.01},
        nan,
        derived={"omega_d": "pendulum_pitch_rate - drive_rate"},
        window_s=(32.81, 35.81),
    )
    r = free.record()
    assert r["rmse_pendulum_pitch_rad"] == 0.01 and r["rmse_omega_d_rad_s"] == 0.3 and "pme_percent" not in r
    assert r["omega_d_derived_from"] == "pendulum_pitch_rate - drive_rate" and r["window_s"] == [32.81, 35.81]
    ramp = ValidationRow("c", "point", "free", {"phi": 0.1, "theta": 0.2, "omega_d": 0.3}, 12.5)
    assert ramp.record()["pme_percent"] == 12.5
    json.dumps([flat.record(), r, ramp.record()])  # plain JSON
    assert np.isfinite(r["rmse_phi_rad"])


@pytest.mark.realdata
def test_free_release_window_validates_to_records(roboball_dir, tmp_path):
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    out = tmp_path / "free.json"
    assert (
        main(
            [
                "validate",
                "--manifest",
                str(repo / "assets" / "logs" / "roboball.yaml"),
                "--data-root",
                str(roboball_dir),
                "--trial",
                "free_release",
                "--models",
                "injected",
                "--json",
                str(out),
            ]
        )
        == 0
    )
    (rec,) = json.loads(out.read_text())
    assert rec["trial"] == "free_release" and rec["fixture"] == "free" and rec["window_s"] == [33.46, 37.21]
    assert "pme_percent" not in rec  # flat ground
    assert rec["omega_d_derived_from"] == "pendulum_pitch_rate - drive_rate"
    assert 0.0 < rec["rmse_phi_rad"] < 1.0 and 0.0 < rec["rmse_theta_rad"] < 2.0


@pytest.mark.parametrize(
    "calibration, fit_on", [("free_robot", ["free_release", "push_1", "push_2", "push_3"]), ("default", None)]
)
def test_json_records_say_how_the_calibration_was_fitted_and_which_trials_it_saw(
    logs_dir, tmp_path, calibration, fit_on
):
    """Each fitted model's record carries the calibration's fit (windows, intervals, held-out errors)
    and whether its trial was held out of that fit; point contact has nothing fitted."""
    from sphere_env.models.shell import ShellCalibration

    raw = ShellCalibration.load(calibration).raw
    fit_on = fit_on or raw["provenance"]["injected_fit"]["fit_on"]
    man = write_manifest(
        logs_dir / f"m_fit_{calibration}.yaml",
        [
            {"name": fit_on[0], "file": "sf.csv", "fixture": "steer_plane", "group": "g"},
            {"name": "unseen", "file": "sf.csv", "fixture": "steer_plane", "group": "g"},
        ],
    )
    out = tmp_path / "v.json"
    argv = ["validate", "--manifest", str(man), "--models", "point", "injected", "hydroelastic"]
    assert main([*argv, "--calibration", calibration, "--drive-friction", "none", "--json", str(out)]) == 0
    recs = {(r["trial"], r["model"]): r for r in json.loads(out.read_text())}
    assert "fit" not in recs[(fit_on[0], "point")] and "held_out" not in recs[(fit_on[0], "point")]
    for model in ("injected", "hydroelastic"):
        seen, unseen = recs[(fit_on[0], model)], recs[("unseen", model)]
        assert seen["held_out"] is False and unseen["held_out"] is True
        assert seen["fit"]["fit_on"] == fit_on and seen["fit"]["ci95"]
    if "steer_fit" in raw:
        rec = raw["steer_fit"]["models"]["injected"]
        fit = recs[("unseen", "injected")]["fit"]
        assert fit["ci95_over_windows"] == rec["ci95_over_windows"]
        assert fit["unidentified"] == rec["unidentified"] and fit["held_out_rmse_rad"] == rec["held_out_rmse_rad"]
    else:
        assert recs[("unseen", "injected")]["fit"]["cross_validation"]["held_out_phi_rad"]
