"""Cross-validation tables: fit on one segment, validate on the others (real Drake, short fits)."""

import math

import pytest

from sphere_env.calibration.crossval import cross_validate, crossval_table, fit_calibration, held_out_summary
from sphere_env.calibration.manifest import load_manifest
from sphere_env.physics import InitialState, Twin, TwinConfig

from .conftest import synth_log, write_manifest


@pytest.fixture(scope="module")
def group(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("xv")
    twin = Twin(
        TwinConfig(fixture="steer_plane", shell_model="injected", steer_friction="majd_steer", drive_friction="none")
    )
    synth_log(tmp / "a.csv", twin, InitialState(theta=0.38, roll=-0.37), 1.5)
    synth_log(tmp / "b.csv", twin, InitialState(theta=0.30, roll=-0.30), 1.5)
    man = write_manifest(
        tmp / "m.yaml", [{"name": n, "file": f"{n}.csv", "fixture": "steer_plane", "group": "g"} for n in ("a", "b")]
    )
    return [t.load() for t in load_manifest(man).trials]


def test_fit_on_one_validate_on_the_other(group):
    res = cross_validate(
        {"g": group},
        ("point", "injected"),
        steer_friction="majd_steer",
        drive_friction="none",
        fit=lambda tr, m, p, b, sf: fit_calibration(tr, m, p, b, sf, max_nfev=3, forms=(b.steer_law.form,)),
    )
    # point: one baseline run; injected: one fit per segment, each validated on both.
    assert [(x["model"], x["fit_on"]) for x in res] == [("point", None), ("injected", "a"), ("injected", "b")]
    for x in res[1:]:
        roles = {r["trial"]: r["role"] for r in x["records"]}
        assert roles[x["fit_on"]] == "fit" and list(roles.values()).count("held out") == 1
        assert "omega_n" in x["params"]
        # The logs were made by the twin at the shipped calibration: the fit stays near it, on both.
        assert max(r["rmse_phi_rad"] for r in x["records"]) < 0.02
    assert min(r["rmse_phi_rad"] for r in res[0]["records"]) > 0.05  # rigid contact is visibly off
    table = crossval_table(res)
    assert table.count("\n") == 2 + 2 + 4 - 1 and "held out" in table and "baseline" in table
    summ = held_out_summary(res)
    assert summ[("g", "injected")]["worst_held_out_phi_rad"] < 0.02
    assert math.isnan(summ[("g", "point")]["worst_fit_phi_rad"])


def test_a_failing_fit_is_reported_not_fatal(group):
    def refuse(*_):
        raise ValueError("fit did not converge")

    res = cross_validate(
        {"g": group[:1]}, ("injected",), steer_friction="majd_steer", drive_friction="none", fit=refuse
    )
    assert res[0]["error"] == "fit did not converge" and res[0]["records"] == []
    assert "fit failed: fit did not converge" in crossval_table(res)
