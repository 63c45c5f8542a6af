"""The learning study's summary: rliable's IQM and stratified-bootstrap intervals over seeds, the
aims checked against the PD, and the files written from the per-run results."""

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


def _run(seed, per_shell, rmse=0.3, steps_to_pd=None):
    return {
        "method": "r",
        "condition": "pressure",
        "from_scratch": True,
        "seed": seed,
        "success_rate": float(np.mean(list(per_shell.values()))),
        "tracking_rmse_rad_s": rmse,
        "per_shell": dict(per_shell),
        "env_steps_to_pd_level": steps_to_pd,
        "wall_clock_to_pd_level_s": None if steps_to_pd is None else steps_to_pd / 500,
        "wall_clock_s": 100.0,
        "env_steps": 1000,
        "commit": "x",
        "recipe": {"note": ""},
        "curve": [
            {"env_steps": 500, "per_shell": dict(per_shell), "success_rate": 0.0},
            {"env_steps": 1000, "per_shell": dict(per_shell), "success_rate": 0.0},
        ],
    }


def test_identical_seeds_give_a_point_interval_at_their_score():
    scores = {"a": np.full((5, 3), 0.8)}
    est = interval_estimates(scores)["a"]
    assert est["iqm"] == pytest.approx(0.8) and est["iqm_ci"] == pytest.approx([0.8, 0.8])


def test_the_interval_covers_the_mean_and_is_wider_with_spread_scores():
    rng = np.random.default_rng(0)
    tight = np.clip(0.7 + 0.02 * rng.standard_normal((10, 3)), 0, 1)
    wide = np.clip(0.7 + 0.25 * rng.standard_normal((10, 3)), 0, 1)
    est = interval_estimates({"tight": tight, "wide": wide})
    for k, x in (("tight", tight), ("wide", wide)):
        lo, hi = est[k]["mean_ci"]
        assert lo <= x.mean() <= hi
    width = {k: est[k]["iqm_ci"][1] - est[k]["iqm_ci"][0] for k in est}
    assert width["wide"] > 3 * width["tight"]


def test_aims_are_judged_against_the_pd():
    good = [_run(s, {"point": 1.0, "injected": 1.0, "hydroelastic": 8 / 9}, 0.25, 800_000) for s in range(5)]
    weak_point = [_run(s, {"point": 2 / 9, "injected": 1.0, "hydroelastic": 1.0}, 0.5) for s in range(5)]
    rows = {r["recipe"]: r for r in recipe_rows({"good": good, "weak": weak_point}, PD)}
    assert all(rows["good"]["aims"].values())
    assert rows["good"]["env_steps_to_pd_level_mean"] == 800_000 and rows["good"]["reached_pd_level"] == "5/5"
    weak = rows["weak"]["aims"]
    assert not weak["every_shell_ge_80"] and not weak["rmse_le_pd"] and not weak["mean_success_ge_pd_minus_3"]
    assert rows["weak"]["env_steps_to_pd_level_range"] is None


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


def test_the_randomization_study_tells_conditions_apart_only_when_they_differ():
    """Two conditions whose runs differ by 30 points on every shell: the probability of improvement's
    interval excludes 0.5 and the mean difference's interval holds 30 points; two conditions drawn
    alike: the first includes 0.5, the second 0. With 10 runs of this spread both intervals are
    narrow enough to show a 10-point difference; with 5 widely spread runs they are not, and a
    condition with fewer than 5 runs is not compared."""
    from sphere_env.evaluation.experiments.study_summary import study_rows

    rng = np.random.default_rng(0)
    low = np.clip(0.5 + 0.05 * rng.standard_normal((10, 3)), 0, 1)
    high = np.clip(0.8 + 0.05 * rng.standard_normal((10, 3)), 0, 1)
    same = np.clip(0.5 + 0.05 * rng.standard_normal((10, 3)), 0, 1)
    rows = study_rows(
        {
            "a": {"nominal": high, "faults": np.zeros((0, 9))},
            "b": {"nominal": low, "faults": np.zeros((0, 9))},
            "c": {"nominal": same, "faults": np.zeros((0, 9))},
        }
    )
    poi = {r["condition"]: r for r in rows if "poi" in r}
    assert poi["P(a > b)"]["poi_ci"][0] > 0.5 and poi["P(a > b)"]["pair"] == "a − b"
    assert poi["P(b > c)"]["poi_ci"][0] < 0.5 < poi["P(b > c)"]["poi_ci"][1]
    lo, hi = poi["P(a > b)"]["mean_diff_ci"]
    assert 0.2 < lo < poi["P(a > b)"]["mean_diff"] < hi < 0.4  # the 30-point gap, resolved
    assert poi["P(a > b)"]["resolves_10_points"] and poi["P(b > c)"]["resolves_10_points"]
    lo, hi = poi["P(b > c)"]["mean_diff_ci"]
    assert lo < 0.0 < hi
    assert {r["condition"] for r in rows if "iqm" in r} == {"a", "b", "c"}
    wide = study_rows(
        {
            "a": {
                "nominal": np.array([[0.2] * 3, [0.9] * 3, [0.5] * 3, [0.0] * 3, [1.0] * 3]),
                "faults": np.zeros((0, 9)),
            },
            "b": {
                "nominal": np.array([[0.1] * 3, [0.8] * 3, [0.6] * 3, [1.0] * 3, [0.0] * 3]),
                "faults": np.zeros((0, 9)),
            },
        }
    )
    assert not next(r for r in wide if "poi" in r)["resolves_10_points"]
    few = study_rows(
        {"a": {"nominal": high[:4], "faults": np.zeros((0, 9))}, "b": {"nominal": low, "faults": np.zeros((0, 9))}}
    )
    assert {r["condition"] for r in few} == {"b"}


def test_the_study_tells_per_task_where_conditions_differ_and_where_not():
    """Two conditions with the same runs' scores (in another order) on two shells and 40 points
    apart on the third: that shell's difference interval excludes 0 and holds the 40 points
    (higher); the two alike shells' intervals hold 0 inside ±10 points (within 10 points). With
    five widely spread runs alike in the mean, the interval holds 0 and reaches past ±10 points
    (undecided)."""
    from sphere_env.evaluation.experiments.study_summary import study_task_markdown, study_task_rows

    rng = np.random.default_rng(1)
    a = np.clip(0.5 + 0.05 * rng.standard_normal((10, 3)), 0, 1)
    b = a[::-1].copy()
    a[:, 2] += 0.4
    rows = study_task_rows(
        {"a": {"nominal": a, "faults": np.zeros((0, 9))}, "b": {"nominal": b, "faults": np.zeros((0, 9))}}
    )
    by_task = {r["task"]: r for r in rows}
    assert [r["pair"] for r in rows] == ["a − b"] * 3  # no fault rows: neither condition has fault scores
    assert by_task["point"]["verdict"] == by_task["injected"]["verdict"] == "within 10 points"
    lo, hi = by_task["hydroelastic"]["mean_diff_ci"]
    assert by_task["hydroelastic"]["verdict"] == "higher" and 0.3 < lo < by_task["hydroelastic"]["mean_diff"] < hi < 0.5
    reversed_rows = study_task_rows(
        {"a": {"nominal": b, "faults": np.zeros((0, 9))}, "b": {"nominal": a, "faults": np.zeros((0, 9))}}
    )
    assert next(r for r in reversed_rows if r["task"] == "hydroelastic")["verdict"] == "lower"
    table = study_task_markdown(rows)
    assert table.count("**") == 2 and "a − b (10 vs 10 runs)" in table and "within 10 points" in table
    spread = np.array([[0.2] * 3, [0.9] * 3, [0.5] * 3, [0.0] * 3, [1.0] * 3])
    wide = study_task_rows(
        {
            "a": {"nominal": spread, "faults": np.zeros((0, 9))},
            "b": {"nominal": spread[::-1], "faults": np.zeros((0, 9))},
        }
    )
    assert all(r["verdict"] == "undecided" and r["mean_diff_ci"][0] < -0.1 for r in wide)


def test_a_recipes_interval_does_not_move_when_another_recipe_gains_runs():
    rng = np.random.default_rng(0)
    a, b = rng.uniform(size=(5, 3)), rng.uniform(size=(5, 3))
    alone = interval_estimates({"a": a})
    with_b = interval_estimates({"b": b, "a": a})
    with_more_b = interval_estimates({"b": np.vstack([b, b[:2]]), "a": a})
    assert alone["a"] == with_b["a"] == with_more_b["a"]
    assert with_b["b"] != with_more_b["b"]


def test_a_run_chose_its_budget_end_only_when_its_last_checkpoint_or_final_model_was_chosen():
    """The last checkpoint, or the final model a few steps past it, is the budget's end; an earlier
    checkpoint is not, and a run without candidates (no validation) never counts."""
    from sphere_env.evaluation.experiments.study_summary import chose_budget_end

    cands = [1_800_000, 1_900_000, 2_000_000, 2_015_232]
    assert chose_budget_end({"selected": {"checkpoint_steps": 2_015_232, "candidates": cands}})
    assert chose_budget_end({"selected": {"checkpoint_steps": 2_000_000, "candidates": cands}})
    assert not chose_budget_end({"selected": {"checkpoint_steps": 1_900_000, "candidates": cands}})
    assert not chose_budget_end({"success_rate": 0.5})


def test_each_pair_puts_the_more_randomized_or_longer_trained_condition_first():
    """A positive difference reads as what the added randomization (or, for the fourth arm, the
    doubled budget) bought: the pairs run from pressure_faults_4m to nominal whatever order the
    conditions arrive in, a condition this order does not know comes last, and one with fewer than
    5 runs is left out."""
    from sphere_env.evaluation.experiments.study_summary import compared

    five = {"nominal": np.full((5, 3), 0.5), "faults": np.zeros((0, 9))}
    four = {"nominal": np.full((4, 3), 0.5), "faults": np.zeros((0, 9))}
    scores = {c: five for c in ("nominal", "other", "pressure", "pressure_faults_4m", "pressure_faults")}
    have, pairs = compared({**scores, "few": four}, "nominal")
    assert "few" not in have
    assert pairs[:4] == [
        ("pressure_faults_4m", "pressure_faults"),
        ("pressure_faults_4m", "pressure"),
        ("pressure_faults_4m", "nominal"),
        ("pressure_faults_4m", "other"),
    ]
    assert pairs[-1] == ("nominal", "other") and len(pairs) == 10
