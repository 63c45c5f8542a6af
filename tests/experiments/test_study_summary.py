"""The randomization study's statistics: a run is one sample, its score on a grid the mean over its
episodes; every interval resamples whole runs, paired by seed where both conditions ran the same
seeds, and a difference per shell or fault uses the same resampled runs as the whole grid's."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("rliable")

from sphere_env.evaluation.experiments.study_summary import (
    GridScores,
    chose_budget_end,
    compared,
    condition_scores,
    study_tables,
    study_task_markdown,
)

NO_FAULTS = GridScores((), np.zeros((0, 9)), np.ones(9))
NO_CALIBRATIONS = GridScores((), np.zeros((0, 2)), np.ones(2))


def _grid(tasks, seeds=None, episodes=None) -> GridScores:
    tasks = np.asarray(tasks, dtype=float)
    return GridScores(
        tuple(range(len(tasks)) if seeds is None else seeds),
        tasks,
        np.ones(tasks.shape[1]) if episodes is None else np.asarray(episodes, dtype=float),
    )


def _study(**nominal) -> dict:
    return {c: {"nominal": g, "faults": NO_FAULTS, "calibrations": NO_CALIBRATIONS} for c, g in nominal.items()}


def _pairs(rows):
    return {r["pair"]: r for r in rows if "mean_diff" in r}


def test_a_run_scores_the_mean_over_its_episodes():
    g = _grid([[1.0, 0.0], [0.5, 0.5]], episodes=[3, 1])
    assert g.runs == pytest.approx([0.75, 0.5])


def test_conditions_apart_and_alike_are_told_by_whole_run_intervals():
    """Runs 30 points apart: the probability of improvement excludes 0.5 and the difference's
    interval holds the 30 points (lower for the second first); runs drawn alike: 0.5 and 0 held."""
    rng = np.random.default_rng(0)
    high = _grid(np.clip(0.8 + 0.05 * rng.standard_normal((10, 3)), 0, 1))
    low = _grid(np.clip(0.5 + 0.05 * rng.standard_normal((10, 3)), 0, 1))
    same = _grid(np.clip(0.5 + 0.05 * rng.standard_normal((10, 3)), 0, 1))
    rows, _ = study_tables(_study(a=high, b=low, c=same))
    pairs = _pairs(rows)
    assert pairs["a − b"]["poi_ci"][0] > 0.5 and pairs["a − b"]["verdict"] == "higher"
    lo, hi = pairs["a − b"]["mean_diff_ci"]
    assert 0.2 < lo < pairs["a − b"]["mean_diff"] < hi < 0.4
    assert pairs["b − c"]["poi_ci"][0] < 0.5 < pairs["b − c"]["poi_ci"][1]
    assert pairs["b − c"]["mean_diff_ci"][0] < 0.0 < pairs["b − c"]["mean_diff_ci"][1]
    assert pairs["b − c"]["verdict"] == "within 10 points" and pairs["a − b"]["paired_by_seed"]
    assert {r["condition"] for r in rows if "iqm" in r} == {"a", "b", "c"}


def test_paired_seeds_cancel_what_a_seed_does_to_both_conditions():
    """Each seed's run of the first condition is its run of the second plus 10 points: paired by
    seed the difference's interval is the 10 points exactly; with other seeds on one side the runs
    are resampled on their own and the seeds' spread widens it past 0."""
    base = np.linspace(0.1, 0.8, 10)[:, None] * np.ones((1, 3))
    a, b = _grid(base + 0.1), _grid(base)
    pairs = _pairs(study_tables(_study(a=a, b=b))[0])
    assert pairs["a − b"]["paired_by_seed"] and pairs["a − b"]["mean_diff_ci"] == pytest.approx([0.1, 0.1])
    unpaired = _pairs(study_tables(_study(a=a, b=b._replace(seeds=tuple(range(10, 20)))))[0])["a − b"]
    assert not unpaired["paired_by_seed"] and unpaired["mean_diff_ci"][0] < 0.0 < unpaired["mean_diff_ci"][1]


def test_every_shell_is_resampled_with_the_same_runs():
    """Scores that move together over the shells (one policy scored on each) get the same interval
    on every shell: each resample draws whole runs, never one run's point score with another's
    injected score."""
    rng = np.random.default_rng(2)
    a = rng.uniform(size=(10, 1)) * np.ones((1, 3))
    b = rng.uniform(size=(10, 1)) * np.ones((1, 3))
    rows, tasks = study_tables(_study(a=_grid(a), b=_grid(b)))
    cis = [r["mean_diff_ci"] for r in tasks]
    assert len(cis) == 3 and cis[0] == cis[1] == cis[2] == _pairs(rows)["a − b"]["mean_diff_ci"]


def test_the_study_tells_per_task_where_conditions_differ_and_where_not():
    """Alike on two shells and 40 points apart on the third: that shell's interval excludes 0
    (higher), the two alike shells' hold 0 inside ±10 points; five widely spread runs: undecided."""
    rng = np.random.default_rng(1)
    a = np.clip(0.5 + 0.02 * rng.standard_normal((10, 3)), 0, 1)
    b = a.copy()
    a[:, 2] += 0.4
    _, rows = study_tables(_study(a=_grid(a), b=_grid(b)))
    by_task = {r["task"]: r for r in rows}
    assert [r["pair"] for r in rows] == ["a − b"] * 3  # no fault rows: neither condition has fault scores
    assert by_task["point"]["verdict"] == by_task["injected"]["verdict"] == "within 10 points"
    lo, hi = by_task["hydroelastic"]["mean_diff_ci"]
    assert by_task["hydroelastic"]["verdict"] == "higher" and 0.3 < lo < by_task["hydroelastic"]["mean_diff"] < hi < 0.5
    assert (
        next(r for r in study_tables(_study(a=_grid(b), b=_grid(a)))[1] if r["task"] == "hydroelastic")["verdict"]
        == "lower"
    )
    table = study_task_markdown(rows)
    assert table.count("**") == 2 and "a − b (10 vs 10 runs, paired by seed)" in table
    spread = np.array([[0.2] * 3, [0.9] * 3, [0.5] * 3, [0.0] * 3, [1.0] * 3])
    _, wide = study_tables(_study(a=_grid(spread), b=_grid(spread[::-1])))
    assert all(r["verdict"] == "undecided" and r["mean_diff_ci"][0] < -0.1 for r in wide)


def test_few_runs_and_retired_conditions_draw_no_verdict():
    """A condition with fewer than 5 runs is left out; a retired one stays listed with its runs and
    mean and the reason, with no interval and in no pair."""
    rng = np.random.default_rng(3)
    five = _grid(rng.uniform(size=(5, 3)))
    rows, tasks = study_tables(_study(a=five, b=five, few=_grid(rng.uniform(size=(4, 3)))))
    assert {r["condition"] for r in rows if "iqm" in r} == {"a", "b"} and "few" not in str(tasks)
    rows, tasks = study_tables(_study(a=five, b=five, old=five), retired={"old": "too few seeds"})
    old = [r for r in rows if r["condition"] == "old"]
    assert old == [
        {
            "grid": "nominal",
            "condition": "old",
            "runs": 5,
            "mean": pytest.approx(five.runs.mean()),
            "retired": "too few seeds",
        }
    ]
    assert all("old" not in r["pair"] for r in rows + tasks if "pair" in r)


def test_condition_scores_take_each_runs_validation_choice_in_seed_order():
    """Each grid in seed order; a run without a grid's figures (seed 2: no calibrations) counts for
    the other grids only."""
    from sphere_env.evaluation.demo import CALIBRATIONS
    from sphere_env.evaluation.faults import FAULTS

    def run(seed, point, calibrated=True):
        out = {
            "seed": seed,
            "condition": "nominal",
            "per_shell": {"point": 0.0, "injected": 0.0, "hydroelastic": 0.0},
            "selected": {"per_shell": {"point": point, "injected": 1.0, "hydroelastic": 1.0}},
            "faults": {f: {"success_rate": 0.5, "episodes": 27} for f in FAULTS},
        }
        if calibrated:
            out["calibrations"] = {
                c: {"success_rate": 0.25 * (seed + k), "episodes": 27} for k, c in enumerate(CALIBRATIONS)
            }
        return out

    scores = condition_scores(
        {"study_nominal": [run(1, 0.0), run(2, 0.0, calibrated=False), run(0, 1.0)], "other": [run(0, 0.5)]}
    )
    g = scores["nominal"]["nominal"]
    assert set(scores) == {"nominal"} and g.seeds == (0, 1, 2) and g.runs == pytest.approx([1.0, 2 / 3, 2 / 3])
    assert scores["nominal"]["faults"].runs == pytest.approx([0.5, 0.5, 0.5])
    cal = scores["nominal"]["calibrations"]
    assert cal.seeds == (0, 1) and cal.tasks.tolist() == [[0.0, 0.25], [0.25, 0.5]]


def test_a_run_chose_its_budget_end_only_when_its_last_checkpoint_or_final_model_was_chosen():
    """The last checkpoint, or the final model a few steps past it, is the budget's end; an earlier
    checkpoint is not, and a run without candidates (no validation) never counts."""
    cands = [1_800_000, 1_900_000, 2_000_000, 2_015_232]
    assert chose_budget_end({"selected": {"checkpoint_steps": 2_015_232, "candidates": cands}})
    assert chose_budget_end({"selected": {"checkpoint_steps": 2_000_000, "candidates": cands}})
    assert not chose_budget_end({"selected": {"checkpoint_steps": 1_900_000, "candidates": cands}})
    assert not chose_budget_end({"success_rate": 0.5})


def test_each_pair_puts_the_more_randomized_or_longer_trained_condition_first():
    """A positive difference reads as what the added randomization (or, for the 4 M arm, the
    doubled budget) bought: the pairs run from pressure_faults_4m to nominal whatever order the
    conditions arrive in, a condition this order does not know comes last, and one with fewer than
    5 runs is left out."""
    five = {"nominal": _grid(np.full((5, 3), 0.5)), "faults": NO_FAULTS, "calibrations": NO_CALIBRATIONS}
    four = {"nominal": _grid(np.full((4, 3), 0.5)), "faults": NO_FAULTS, "calibrations": NO_CALIBRATIONS}
    conditions = ("nominal", "other", "pressure", "calibration", "pressure_faults_4m", "pressure_faults")
    scores = {c: five for c in conditions}
    have, pairs = compared({**scores, "few": four}, "nominal")
    assert "few" not in have
    assert pairs[:5] == [
        ("pressure_faults_4m", "calibration"),
        ("pressure_faults_4m", "pressure_faults"),
        ("pressure_faults_4m", "pressure"),
        ("pressure_faults_4m", "nominal"),
        ("pressure_faults_4m", "other"),
    ]
    assert ("calibration", "pressure") in pairs and ("calibration", "nominal") in pairs
    assert pairs[-1] == ("nominal", "other") and len(pairs) == 15
