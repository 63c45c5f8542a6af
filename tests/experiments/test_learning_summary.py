"""The learning study's summary: rliable's IQM with intervals over whole runs, the aims checked
against the PD, PD level on the validation grid, and the files written from the per-run results."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("rliable")

from sphere_env.evaluation.experiments.intervals import interval_estimates
from sphere_env.evaluation.experiments.learning_summary import recipe_rows, write_summary

SHELLS = ("point", "injected", "hydroelastic")
PD = {
    "success_rate": 26 / 27,
    "tracking_rmse_rad_s": 0.31,
    "per_shell": {"point": 1.0, "injected": 8 / 9, "hydroelastic": 1.0},
    "episodes": 27,
}


def _run(seed, per_shell, rmse=0.3):
    return {
        "method": "r",
        "condition": "pressure",
        "from_scratch": True,
        "seed": seed,
        "success_rate": float(np.mean(list(per_shell.values()))),
        "tracking_rmse_rad_s": rmse,
        "per_shell": dict(per_shell),
        "wall_clock_s": 100.0,
        "steps_per_s": 10.0,
        "job_wall_s": 120.0,
        "env_steps": 1000,
        "commit": "x",
        "recipe": {"note": ""},
        "curve": [
            {"env_steps": 500, "per_shell": dict(per_shell), "success_rate": 0.0},
            {"env_steps": 1000, "per_shell": dict(per_shell), "success_rate": 0.0},
        ],
    }


def test_identical_runs_give_a_point_interval_at_their_score():
    est = interval_estimates({"a": np.full(5, 0.8)})["a"]
    assert est["iqm"] == pytest.approx(0.8) and est["iqm_ci"] == pytest.approx([0.8, 0.8])


def test_the_interval_covers_the_mean_and_is_wider_with_spread_runs():
    rng = np.random.default_rng(0)
    tight = np.clip(0.7 + 0.02 * rng.standard_normal(10), 0, 1)
    wide = np.clip(0.7 + 0.25 * rng.standard_normal(10), 0, 1)
    est = interval_estimates({"tight": tight, "wide": wide})
    for k, x in (("tight", tight), ("wide", wide)):
        lo, hi = est[k]["mean_ci"]
        assert lo <= x.mean() <= hi
    width = {k: est[k]["iqm_ci"][1] - est[k]["iqm_ci"][0] for k in est}
    assert width["wide"] > 3 * width["tight"]


def test_scores_other_than_one_per_run_are_refused_by_name():
    with pytest.raises(ValueError, match=r"scores\['a'\]: shape \(5, 3\).*one score per run"):
        interval_estimates({"a": np.full((5, 3), 0.8)})


def test_aims_are_judged_against_the_pd_and_pd_level_on_the_validation_grid():
    """The aims hold the development-grid figures against the PD's on that grid; PD level is
    judged on the validation grid, each run's validation-chosen checkpoint against the PD's
    validation success less 3 points, and is not recorded where either is missing."""
    good = [_run(s, {"point": 1.0, "injected": 1.0, "hydroelastic": 8 / 9}, 0.25) for s in range(5)]
    weak_point = [_run(s, {"point": 2 / 9, "injected": 1.0, "hydroelastic": 1.0}, 0.5) for s in range(5)]
    for k, r in enumerate(good):
        r["selected"] = {"validation": {"success_rate": 0.70 if k == 0 else 0.75}}
    pd_val = {**PD, "success_rate": 20 / 27}  # level 20/27 - 0.03 = 0.71
    rows = {r["recipe"]: r for r in recipe_rows({"good": good, "weak": weak_point}, PD, pd_val)}
    assert all(rows["good"]["aims"].values())
    assert rows["good"]["validation_reached_pd_level"] == "4/5"
    weak = rows["weak"]["aims"]
    assert not weak["every_shell_ge_80"] and not weak["rmse_le_pd"] and not weak["mean_success_ge_pd_minus_3"]
    assert rows["weak"]["validation_reached_pd_level"] is None  # no validation figures
    assert recipe_rows({"good": good}, PD)[0]["validation_reached_pd_level"] is None  # no PD on validation


def test_write_summary_gives_the_documented_shape(tmp_path):
    base = {
        "pd": PD,
        "zero": {**PD, "success_rate": 1 / 27},
        "grid": {"shells": list(SHELLS), "pressures_kpa": [3.0, 8.5, 14.0], "seeds": [0, 1, 2], "episodes": 27},
        "commit": "abc",
    }
    (tmp_path / "baselines.json").write_text(json.dumps(base))
    folder = tmp_path / "runs" / "recipe_a"
    folder.mkdir(parents=True)
    for s in range(3):
        (folder / f"seed{s}.json").write_text(
            json.dumps(_run(s, {"point": 0.5 + 0.1 * s, "injected": 1.0, "hydroelastic": 0.9}))
        )
    summary = json.loads(write_summary(tmp_path).read_text())
    assert summary["grid"]["episodes"] == 27 and summary["pd"]["success_rate"] == pytest.approx(26 / 27)
    assert [r["seed"] for r in summary["runs"]] == [0, 1, 2]
    assert set(summary["runs"][0]["per_shell"]) == set(SHELLS) and summary["runs"][0]["from_scratch"] is True
    assert (tmp_path / "learning_curves.png").stat().st_size > 0
    assert "recipe_a" in (tmp_path / "README.md").read_text()


def test_selected_checkpoints_and_faults_reach_the_summary(tmp_path):
    """Runs with a validation-chosen checkpoint get a ``<recipe>@selected`` row judged on that
    checkpoint's figures; the fault table lists every controller's success per fault and why each
    fault's range is what it is."""
    from sphere_env.evaluation.faults import FAULTS

    faults = {f: {"success_rate": 0.5} for f in FAULTS}
    base = {
        "pd": {**PD, "faults": faults},
        "zero": {**PD, "success_rate": 1 / 27, "faults": faults},
        "grid": {"shells": list(SHELLS), "pressures_kpa": [3.0, 8.5, 14.0], "seeds": [0, 1, 2], "episodes": 27},
    }
    (tmp_path / "baselines.json").write_text(json.dumps(base))
    folder = tmp_path / "runs" / "recipe_a"
    folder.mkdir(parents=True)
    good = {"point": 1.0, "injected": 1.0, "hydroelastic": 1.0}
    for s in range(2):
        run = _run(s, {"point": 0.0, "injected": 1.0, "hydroelastic": 1.0})
        run["selected"] = {
            "checkpoint_steps": 500,
            "success_rate": 1.0,
            "tracking_rmse_rad_s": 0.2,
            "per_shell": good,
            "validation": {"success_rate": 1.0},
        }
        run["faults"] = {f: {"success_rate": 0.25 * (s + 1)} for f in FAULTS}
        (folder / f"seed{s}.json").write_text(json.dumps(run))
    summary = json.loads(write_summary(tmp_path).read_text())
    rows = {r["recipe"]: r for r in summary["recipes"]}
    assert rows["recipe_a"]["mean_success"] == pytest.approx(2 / 3)
    assert rows["recipe_a@selected"]["mean_success"] == 1.0 and rows["recipe_a@selected"]["aims"]["every_shell_ge_80"]
    assert summary["runs"][0]["selected"]["checkpoint_steps"] == 500
    readme = (tmp_path / "README.md").read_text()
    assert "## Fault grid" in readme and "recipe_a (2 seeds): mean, worst" in readme
    assert "38%, 25%" in readme  # the runs' mean and worst under each fault
    assert all(f"**{f}**" in readme for f in FAULTS)


def test_a_recipes_interval_does_not_move_when_another_recipe_gains_runs():
    rng = np.random.default_rng(0)
    a, b = rng.uniform(size=5), rng.uniform(size=5)
    alone = interval_estimates({"a": a})
    with_b = interval_estimates({"b": b, "a": a})
    with_more_b = interval_estimates({"b": np.concatenate([b, b[:2]]), "a": a})
    assert alone["a"] == with_b["a"] == with_more_b["a"]
    assert with_b["b"] != with_more_b["b"]
