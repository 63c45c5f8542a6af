"""k_d matching records the plant step it ran at (the calibration's fitted_time_step_s); ``kd-step``
refits k_d at another step into the calibration (k_d_by_time_step)."""

import logging

import pytest
import yaml

from sphere_env.calibration.__main__ import main
from sphere_env.calibration.sensitivity import decay_case, match_dissipation
from sphere_env.models.calibration_files import DEFAULT_CALIBRATION
from sphere_env.models.shell import ShellCalibration


@pytest.mark.slow
def test_match_dissipation_reports_the_step_it_ran_at(caplog):
    cal = ShellCalibration.load()
    p0 = cal.nominal_pressure_kpa
    with caplog.at_level(logging.WARNING):
        m = match_dissipation(None, p0, duration_s=3.0, xtol=0.05, time_step_s=0.004)
    assert m["time_step_s"] == 0.004
    assert m["zeta_sim"] == pytest.approx(m["target_zeta"], rel=0.05)
    # The twin warned that the 4 ms step differs from the calibration's: the decays really ran at 4 ms.
    assert cal.fitted_time_step_s == 0.005
    assert any("time_step_s=0.004 s differs" in r.getMessage() for r in caplog.records)


def test_kd_step_refuses_a_bad_step_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "cal.yaml"
    with pytest.raises(SystemExit) as refused:  # argparse's one-line error, exit status 2
        main(["kd-step", "--time-step-s", "0", "--out", str(out)])
    assert refused.value.code == 2
    assert (
        "argument --time-step-s: '0': Input should be greater than or equal to 0.0001; allowed: [0.0001, 0.05] s"
        in capsys.readouterr().err
    )
    assert not out.exists()


@pytest.mark.slow
def test_kd_step_writes_a_calibration_whose_k_d_at_that_step_keeps_the_damping(tmp_path):
    """The written calibration holds the refit for the new step, and a twin built at that step
    uses it: its locked-steer ζ at the nominal pressure is within 3% of the 5 ms one."""
    src = yaml.safe_load(DEFAULT_CALIBRATION.read_text())
    src["hydroelastic"].pop("k_d_by_time_step", None)
    base = tmp_path / "base.yaml"
    base.write_text(yaml.safe_dump(src))
    out = tmp_path / "refit.yaml"
    assert main(["kd-step", "--calibration", str(base), "--time-step-s", "0.008", "--out", str(out)]) == 0
    cal = ShellCalibration.load(out)
    ((step, k_d),) = cal.k_d_by_time_step
    assert step == 0.008 and k_d < cal.k_d  # coarser step: more numerical damping, less k_d
    job = {
        "calibration": str(out),
        "pressure_kpa": cal.nominal_pressure_kpa,
        "modulus_scale": 1.0,
        "dissipation_scale": 1.0,
        "case": "check",
    }
    zeta = {dt: decay_case(dict(job, time_step_s=dt))["zeta"] for dt in (0.005, 0.008)}
    assert zeta[0.008] == pytest.approx(zeta[0.005], rel=0.03)


def test_kd_pressure_refuses_pressures_not_spanning_the_range_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "cal.yaml"
    assert main(["kd-pressure", "--time-step-s", "0.01", "--pressure-kpa", "3", "20", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--pressure-kpa = 20.0: " in err and "; allowed: [3.0, 14.0] kPa, the calibrated range" in err
    for bad in (["5", "5"], ["3", "10"]):  # one pressure; 10-14 kPa would be extrapolated
        assert main(["kd-pressure", "--time-step-s", "0.01", "--pressure-kpa", *bad, "--out", str(out)]) == 2
        assert "must hold at least 2 pressures spanning the calibrated range [3.0, 14.0] kPa" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.slow
def test_kd_pressure_writes_a_table_whose_decays_follow_zeta_curve(tmp_path):
    """``kd-pressure`` at 8 ms fits k_d at 3 and 14 kPa into the step's k_d_by_time_step entry; a twin
    built at 8 ms uses the table, and its locked-steer ζ at both pressures is ζ(p) within 2%."""
    src = yaml.safe_load(DEFAULT_CALIBRATION.read_text())
    src["hydroelastic"].pop("k_d_by_time_step", None)
    base = tmp_path / "base.yaml"
    base.write_text(yaml.safe_dump(src))
    out = tmp_path / "table.yaml"
    assert (
        main(
            [
                "kd-pressure",
                "--calibration",
                str(base),
                "--time-step-s",
                "0.008",
                "--pressure-kpa",
                "3",
                "14",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    cal = ShellCalibration.load(out)
    ((step, k_d),) = cal.k_d_by_time_step
    ((table_step, table),) = cal.k_d_by_pressure_at_steps
    assert step == table_step == 0.008 and [q for q, _ in table] == [3.0, 14.0]
    assert k_d == pytest.approx(cal.for_time_step(0.008).k_d_at(cal.nominal_pressure_kpa), rel=1e-4)
    assert table[1][1] > table[0][1]  # more k_d at high pressure: one k_d lets ζ fall too fast
    for p in (3.0, 14.0):
        job = {
            "calibration": str(out),
            "pressure_kpa": p,
            "modulus_scale": 1.0,
            "dissipation_scale": 1.0,
            "time_step_s": 0.008,
            "case": "check",
        }
        row = decay_case(job)
        assert row["zeta"] == pytest.approx(row["zeta_curve"], rel=0.02), p


@pytest.mark.slow
def test_kd_pressure_at_the_fitted_step_replaces_k_d_and_drops_its_refits(tmp_path, capsys):
    """At the calibration's own fitted step the table goes to the top of the hydroelastic section and
    the single k_d becomes its value at the nominal pressure; the k_d refits at other steps matched
    the replaced k_d, so they are dropped (and the command says so)."""
    out = tmp_path / "table.yaml"
    assert main(["kd-pressure", "--time-step-s", "0.005", "--pressure-kpa", "3", "14", "--out", str(out)]) == 0
    assert "dropped hydroelastic.k_d_by_time_step" in capsys.readouterr().out
    cal = ShellCalibration.load(out)
    assert cal.fitted_time_step_s == 0.005 and cal.k_d_by_time_step == ()
    assert [q for q, _ in cal.k_d_by_pressure] == [3.0, 14.0]
    assert cal.k_d == pytest.approx(cal.k_d_at(cal.nominal_pressure_kpa), rel=1e-4)
