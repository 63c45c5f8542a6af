"""The randomization study's statistics: which runs make up each training condition, rliable's
intervals per condition and per pair of conditions on the nominal and the fault grid, the
difference of mean success per shell and per fault, and what each difference's interval lets the
study say (:func:`verdict`)."""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from sphere_env.evaluation.experiments.intervals import BOOTSTRAP_REPS, SHELLS, interval_estimates, pct
from sphere_env.reporting import markdown_table

#: The randomization study's recipes, one per training condition (``recipes.yml``):
#: curriculum_scheduled is the pressure condition; study_faults_4m, the fourth arm, is study_faults's
#: runs continued to twice the budget. Other recipes (variants, and continuations of recipes outside
#: the study) are not runs of a condition and stay out of the study.
STUDY_RECIPES = ("study_nominal", "curriculum_scheduled", "study_faults", "study_faults_4m")


#: The study's conditions from the most randomized (and, for the fourth arm, the most trained) to the
#: least: each pair is written first minus second, so a positive difference is what the added
#: randomization or budget bought.
CONDITION_ORDER = ("pressure_faults_4m", "pressure_faults", "pressure", "nominal")
#: Runs a condition needs before the study compares it: a training claim rests on 5 seeds or more,
#: and a bootstrap over 2 or 3 runs has too few distinct resamples for an interval.
MIN_STUDY_RUNS = 5


def condition_order(names) -> list[str]:
    """``names`` in :data:`CONDITION_ORDER`, other names after them in alphabetical order."""
    return sorted(names, key=lambda c: (CONDITION_ORDER.index(c) if c in CONDITION_ORDER else len(CONDITION_ORDER), c))


def compared(scores: Mapping[str, Mapping[str, np.ndarray]], grid: str):
    """The conditions of ``scores`` the study compares on ``grid`` (those with
    :data:`MIN_STUDY_RUNS` or more runs) and their pairs, more randomized first."""
    have = {c: d[grid] for c, d in scores.items() if len(d[grid]) >= MIN_STUDY_RUNS}
    names = condition_order(have)
    return have, [(a, b) for i, a in enumerate(names) for b in names[i + 1 :]]


def chose_budget_end(run: Mapping[str, Any]) -> bool:
    """Whether a run's validation chose a checkpoint at the end of its budget (its last checkpoint
    or its final model, within 1 % of the last candidate's steps): the run was not past its best
    when training stopped, so more steps may still have helped (a tie at full success also counts)."""
    sel = run.get("selected") or {}
    if not sel.get("candidates"):
        return False
    last = max(sel["candidates"])
    return last - sel["checkpoint_steps"] <= 0.01 * last


def condition_scores(runs_by_recipe: Mapping[str, list[dict[str, Any]]]) -> dict[str, dict[str, np.ndarray]]:
    """Per training condition (the ``condition`` of the runs of :data:`STUDY_RECIPES`): the nominal
    grid's scores (runs × shells) and the fault grid's (runs × faults), each run by its
    validation-chosen checkpoint when it has one. Runs without fault figures count for the nominal
    grid only."""
    from sphere_env.evaluation.faults import FAULTS

    out: dict[str, dict[str, list]] = {}
    for name, runs in runs_by_recipe.items():
        if name not in STUDY_RECIPES:
            continue
        for r in runs:
            sel = r.get("selected") or r
            d = out.setdefault(r.get("condition", "pressure"), {"nominal": [], "faults": []})
            d["nominal"].append([sel["per_shell"][m] for m in SHELLS])
            if all(f in (r.get("faults") or {}) for f in FAULTS):
                d["faults"].append([r["faults"][f]["success_rate"] for f in FAULTS])
    return {c: {k: np.array(v, dtype=float) for k, v in d.items()} for c, d in out.items()}


#: The four things a difference's 95 % interval (first condition minus second) lets the study say.
VERDICTS = ("higher", "lower", "within 10 points", "undecided")


def verdict(ci: Sequence[float]) -> str:
    """What the 95 % interval ``ci`` of a difference of mean success (first condition minus
    second, as fractions) lets the study say: ``higher`` or ``lower`` where it excludes 0; where it
    holds 0, ``within 10 points`` when it lies inside ±10 points (neither condition leads by 10
    points), else ``undecided``: it rules out neither no difference nor a 10-point lead."""
    lo, hi = ci
    if lo > 0.0:
        return "higher"
    if hi < 0.0:
        return "lower"
    return "within 10 points" if lo > -0.10 and hi < 0.10 else "undecided"


def study_rows(scores: Mapping[str, Mapping[str, np.ndarray]]) -> list[dict[str, Any]]:
    """The randomization study: per condition and grid, the number of runs and rliable's IQM and
    mean with 95 % stratified-bootstrap intervals; per pair of conditions, rliable's probability
    of improvement of the first over the second with its interval (0.5: no difference), and the
    difference of their mean success with its interval: the study can tell a 10-point difference
    when that interval's half-width is under 10 points (``resolves_10_points``)."""
    from rliable import library as rly
    from rliable import metrics

    rows = []
    for grid in ("nominal", "faults"):
        have, pairs = compared(scores, grid)
        est = interval_estimates(have) if have else {}
        for c, x in have.items():
            rows.append({"grid": grid, "condition": c, "runs": len(x), **est[c]})
        for a, b in pairs:
            np.random.seed(0)
            point, ci = rly.get_interval_estimates(
                {f"{a},{b}": (have[a], have[b])},
                lambda x, y: np.array(
                    [
                        metrics.probability_of_improvement(x, y),
                        metrics.aggregate_mean(x) - metrics.aggregate_mean(y),
                    ]
                ),
                reps=BOOTSTRAP_REPS,
            )
            key = f"{a},{b}"
            diff_ci = [float(ci[key][0, 1]), float(ci[key][1, 1])]
            rows.append(
                {
                    "grid": grid,
                    "condition": f"P({a} > {b})",
                    "pair": f"{a} − {b}",
                    "runs": f"{len(have[a])} vs {len(have[b])}",
                    "poi": float(point[key][0]),
                    "poi_ci": [float(ci[key][0, 0]), float(ci[key][1, 0])],
                    "mean_diff": float(point[key][1]),
                    "mean_diff_ci": diff_ci,
                    "resolves_10_points": bool((diff_ci[1] - diff_ci[0]) / 2 < 0.10),
                    "verdict": verdict(diff_ci),
                }
            )
    return rows


def study_task_rows(scores: Mapping[str, Mapping[str, np.ndarray]]) -> list[dict[str, Any]]:
    """Where the conditions differ: per grid, per task (each shell of the nominal grid, each fault
    of the fault grid) and per pair of conditions with :data:`MIN_STUDY_RUNS` or more runs, the difference of their mean
    success on that task with its 95 % bootstrap interval over runs (rliable's, one task)."""
    from rliable import library as rly
    from rliable import metrics

    from sphere_env.evaluation.faults import FAULTS

    rows = []
    for grid, tasks in (("nominal", SHELLS), ("faults", tuple(FAULTS))):
        have, pairs = compared(scores, grid)
        for j, task in enumerate(tasks):
            for a, b in pairs:
                np.random.seed(0)
                point, ci = rly.get_interval_estimates(
                    {"d": (have[a][:, [j]], have[b][:, [j]])},
                    lambda x, y: metrics.aggregate_mean(x) - metrics.aggregate_mean(y),
                    reps=BOOTSTRAP_REPS,
                )
                lo, hi = (float(v) for v in np.ravel(ci["d"]))
                rows.append(
                    {
                        "grid": grid,
                        "task": task,
                        "pair": f"{a} − {b}",
                        "runs": f"{len(have[a])} vs {len(have[b])}",
                        "mean_diff": float(np.ravel(point["d"])[0]),
                        "mean_diff_ci": [lo, hi],
                        "verdict": verdict((lo, hi)),
                    }
                )
    return rows


def study_task_markdown(rows: Sequence[Mapping[str, Any]]) -> str:
    """:func:`study_task_rows` as one table: a row per grid and task, a column per pair of
    conditions, each cell the mean difference in points [95 % CI] and its :func:`verdict`, in bold
    where the interval excludes 0."""
    if not rows:
        return ""
    pairs = list(dict.fromkeys(r["pair"] for r in rows))
    table: dict[tuple[str, str], dict[str, str]] = {}
    for r in rows:
        lo, hi = r["mean_diff_ci"]
        cell = f"{100 * r['mean_diff']:+.0f} [{100 * lo:+.0f}, {100 * hi:+.0f}] {r['verdict']}"
        table.setdefault((r["grid"], r["task"]), {})[r["pair"]] = (
            f"**{cell}**" if r["verdict"] in ("higher", "lower") else cell
        )
    runs = {r["pair"]: r["runs"] for r in rows}
    return markdown_table(
        [[grid, task, *(cells.get(p, "") for p in pairs)] for (grid, task), cells in table.items()],
        ["grid", "shell / fault", *(f"{p} ({runs[p]} runs)" for p in pairs)],
    )


def study_markdown(study: Sequence[Mapping[str, Any]]) -> str:
    """The randomization study's table (:func:`study_rows`)."""
    if not study:
        return ""

    def value(r: Mapping[str, Any]) -> str:
        if "poi" in r:
            return f"{r['poi']:.2f} [{r['poi_ci'][0]:.2f}, {r['poi_ci'][1]:.2f}]"
        return f"{pct(r['iqm'])} [{pct(r['iqm_ci'][0])}, {pct(r['iqm_ci'][1])}]"

    def diff(r: Mapping[str, Any]) -> str:
        if "mean_diff" not in r:
            return ""
        lo, hi = r["mean_diff_ci"]
        return f"{100 * r['mean_diff']:+.0f} [{100 * lo:+.0f}, {100 * hi:+.0f}] ({'yes' if r['resolves_10_points'] else 'no'})"

    return markdown_table(
        [[r["grid"], r["condition"], r["runs"], value(r), diff(r), r.get("verdict", "")] for r in study],
        [
            "grid",
            "condition",
            "runs",
            "IQM [95% CI] / P(improvement) [95% CI]",
            "mean difference, points [95% CI] (a 10-point difference would show)",
            "first condition's mean success",
        ],
    )
