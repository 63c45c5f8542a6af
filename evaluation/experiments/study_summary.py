"""The randomization study's statistics: which runs make up each training condition, rliable's
intervals per condition and, per pair of conditions, the difference of mean success on the
development grid, on the fault grid and on the calibration grid, over the whole grid and per shell,
fault and calibration, with what each difference's interval lets the study say (:func:`verdict`). A
run counts as one sample: its score on a grid is the mean over its episodes, and every interval
resamples whole runs (:mod:`~sphere_env.evaluation.experiments.intervals`), paired by seed where
both conditions ran the same seeds."""

from __future__ import annotations

from typing import Any, Mapping, NamedTuple, Sequence

import numpy as np

from sphere_env.evaluation.experiments.intervals import SHELLS, bootstrap_runs, interval_estimates, pct, run_scores
from sphere_env.reporting import markdown_table

#: The randomization study's recipes, one per training condition (``recipes.yml``):
#: curriculum_scheduled is the pressure condition; study_calibration the calibration-aware one;
#: study_faults_4m, an arm beside them, is study_faults's runs continued to twice the budget. Other
#: recipes (variants, and continuations of recipes outside the study) are not runs of a condition
#: and stay out of the study.
STUDY_RECIPES = ("study_nominal", "curriculum_scheduled", "study_faults", "study_calibration", "study_faults_4m")


#: The study's conditions from the most randomized (and, for the 4 M arm, the most trained) to the
#: least: each pair is written first minus second, so a positive difference is what the added
#: randomization or budget bought. The calibration-aware condition draws what the calibrations leave
#: unknown over the pressure condition's range, and no sensing or actuation fault.
CONDITION_ORDER = ("pressure_faults_4m", "calibration", "pressure_faults", "pressure", "nominal")
#: Runs a condition needs before the study compares it: a training claim rests on 5 seeds or more,
#: and a bootstrap over 2 or 3 runs has too few distinct resamples for an interval.
MIN_STUDY_RUNS = 5
#: The grids a run is scored on: the development grid (``nominal``), the fault grid (``faults``, the
#: development grid under each fault) and the calibration grid (``calibrations``, the development
#: grid in the twin of each other shipped calibration), with the words the tables use.
GRIDS = {"nominal": "development grid", "faults": "fault grid", "calibrations": "calibration grid"}


def grid_tasks(grid: str) -> tuple[str, ...]:
    """A grid's tasks: the shells, the faults or the other shipped calibrations."""
    from sphere_env.evaluation.demo import CALIBRATIONS
    from sphere_env.evaluation.faults import FAULTS

    return {"nominal": tuple(SHELLS), "faults": tuple(FAULTS), "calibrations": tuple(CALIBRATIONS)}[grid]


class GridScores(NamedTuple):
    """A condition's runs on one grid: their training seeds, their success per task (runs × tasks:
    the shells, or the faults) and each task's number of episodes."""

    seeds: tuple[int, ...]
    tasks: np.ndarray
    episodes: np.ndarray

    @property
    def runs(self) -> np.ndarray:
        """Each run's score: the mean over its episodes."""
        return run_scores(self.tasks, self.episodes)


def condition_order(names) -> list[str]:
    """``names`` in :data:`CONDITION_ORDER`, other names after them in alphabetical order."""
    return sorted(names, key=lambda c: (CONDITION_ORDER.index(c) if c in CONDITION_ORDER else len(CONDITION_ORDER), c))


def compared(scores: Mapping[str, Mapping[str, GridScores]], grid: str, retired: Sequence[str] = ()):
    """The conditions of ``scores`` the study compares on ``grid`` (not ``retired``, with
    :data:`MIN_STUDY_RUNS` or more runs) and their pairs, more randomized first."""
    have = {c: d[grid] for c, d in scores.items() if c not in retired and len(d[grid].seeds) >= MIN_STUDY_RUNS}
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


def retired_conditions(recipes: Mapping[str, Mapping[str, Any]]) -> dict[str, str]:
    """condition -> why it was retired, for the study's recipes that ``recipes.yml`` marks
    ``retired``: their runs stay listed, and no interval or verdict is drawn from them."""
    return {
        r.get("condition", "pressure"): str(r["retired"])
        for name, r in recipes.items()
        if name in STUDY_RECIPES and r.get("retired")
    }


def condition_scores(runs_by_recipe: Mapping[str, list[dict[str, Any]]]) -> dict[str, dict[str, GridScores]]:
    """Per training condition (the ``condition`` of the runs of :data:`STUDY_RECIPES`): the
    development grid's scores per shell, the fault grid's per fault and the calibration grid's per
    calibration (:class:`GridScores`), each run by its validation-chosen checkpoint when it has one,
    in the order of the seeds. A run without a grid's figures counts for the other grids only."""
    out: dict[str, dict[str, list]] = {}
    for name, runs in runs_by_recipe.items():
        if name not in STUDY_RECIPES:
            continue
        for r in sorted(runs, key=lambda r: r["seed"]):
            sel = r.get("selected") or r
            d = out.setdefault(r.get("condition", "pressure"), {g: [] for g in GRIDS})
            # every shell has the same episodes (pressures × evaluation seeds): equal weights
            d["nominal"].append((r["seed"], [sel["per_shell"][m] for m in SHELLS], [1.0] * len(SHELLS)))
            for g in ("faults", "calibrations"):
                figs, tasks = r.get(g) or {}, grid_tasks(g)
                if all(t in figs for t in tasks):
                    d[g].append(
                        (
                            r["seed"],
                            [figs[t]["success_rate"] for t in tasks],
                            [figs[t].get("episodes", 1) for t in tasks],
                        )
                    )
    width = {g: len(grid_tasks(g)) for g in GRIDS}
    out_scores: dict[str, dict[str, GridScores]] = {}
    for c, d in out.items():
        for g, v in d.items():
            episodes = {tuple(e) for _, _, e in v}
            if len(episodes) > 1:
                raise ValueError(
                    f"condition {c!r}, {GRIDS[g]}: episodes per task differ between runs: {sorted(episodes)}"
                )
            out_scores.setdefault(c, {})[g] = GridScores(
                tuple(s for s, _, _ in v),
                np.array([t for _, t, _ in v], dtype=float).reshape(len(v), width[g]),
                np.array(v[0][2] if v else [1.0] * width[g], dtype=float),
            )
    return out_scores


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


def pair_estimates(a: GridScores, b: GridScores) -> tuple[bool, np.ndarray, np.ndarray]:
    """(paired, point, 95 % interval) of condition ``a`` against ``b`` on one grid, from one
    bootstrap over whole runs (paired by seed where both ran the same seeds): the difference of the
    mean of the runs' scores, rliable's probability that a run of ``a`` beats one of ``b`` (0.5: no
    difference), then the difference of mean success on each task."""
    from rliable import metrics

    if a.tasks.shape[1] != b.tasks.shape[1]:
        raise ValueError(f"tasks: {a.tasks.shape[1]} against {b.tasks.shape[1]}; allowed: the same tasks on both sides")
    w = a.episodes / a.episodes.sum()

    def statistic(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        xr, yr = x @ w, y @ w
        poi = metrics.probability_of_improvement(xr[:, None], yr[:, None])
        return np.concatenate([[xr.mean() - yr.mean(), poi], x.mean(axis=0) - y.mean(axis=0)])

    paired = a.seeds == b.seeds
    point, ci = bootstrap_runs(a.tasks, b.tasks, statistic, paired)
    return paired, point, ci


def study_tables(
    scores: Mapping[str, Mapping[str, GridScores]], retired: Mapping[str, str] | None = None
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """The randomization study as two tables.

    The first: per grid and condition, the number of runs and rliable's IQM and mean over whole
    runs with 95 % intervals (a ``retired`` condition: its runs and their mean only, with the
    reason, and no interval or verdict); per pair of compared conditions, the probability of
    improvement of the first over the second and the difference of their mean success with their
    intervals, whether that interval's half-width is under 10 points (``resolves_10_points``) and
    its :func:`verdict`. The second: per grid, task (each shell, fault and calibration) and pair, the
    difference of mean success on that task with its interval and verdict, from the same resampled
    runs as the pair's row of the first."""
    retired = dict(retired or {})
    rows: list[dict[str, Any]] = []
    task_rows: list[dict[str, Any]] = []
    for grid in GRIDS:
        tasks = grid_tasks(grid)
        have, pairs = compared(scores, grid, retired)
        est = interval_estimates({c: x.runs for c, x in have.items()}) if have else {}
        for c, x in have.items():
            rows.append({"grid": grid, "condition": c, "runs": len(x.seeds), **est[c]})
        for c in condition_order(c for c in retired if c in scores and len(scores[c][grid].seeds)):
            x = scores[c][grid]
            rows.append(
                {
                    "grid": grid,
                    "condition": c,
                    "runs": len(x.seeds),
                    "mean": float(x.runs.mean()),
                    "retired": retired[c],
                }
            )
        for a, b in pairs:
            paired, point, ci = pair_estimates(have[a], have[b])
            runs = f"{len(have[a].seeds)} vs {len(have[b].seeds)}"
            diff_ci = [float(ci[0, 0]), float(ci[1, 0])]
            rows.append(
                {
                    "grid": grid,
                    "condition": f"P({a} > {b})",
                    "pair": f"{a} − {b}",
                    "runs": runs,
                    "paired_by_seed": paired,
                    "poi": float(point[1]),
                    "poi_ci": [float(ci[0, 1]), float(ci[1, 1])],
                    "mean_diff": float(point[0]),
                    "mean_diff_ci": diff_ci,
                    "resolves_10_points": bool((diff_ci[1] - diff_ci[0]) / 2 < 0.10),
                    "verdict": verdict(diff_ci),
                }
            )
            for j, task in enumerate(tasks):
                lo, hi = float(ci[0, 2 + j]), float(ci[1, 2 + j])
                task_rows.append(
                    {
                        "grid": grid,
                        "task": task,
                        "pair": f"{a} − {b}",
                        "runs": runs,
                        "paired_by_seed": paired,
                        "mean_diff": float(point[2 + j]),
                        "mean_diff_ci": [lo, hi],
                        "verdict": verdict((lo, hi)),
                    }
                )
    return rows, task_rows


def _runs_label(r: Mapping[str, Any], unit: str = "") -> str:
    return f"{r['runs']}{unit}{', paired by seed' if r.get('paired_by_seed') else ''}"


def study_task_markdown(rows: Sequence[Mapping[str, Any]]) -> str:
    """The second table of :func:`study_tables`: a row per grid and task, a column per pair of
    conditions, each cell the mean difference in points [95 % CI] and its :func:`verdict`, in bold
    where the interval excludes 0."""
    if not rows:
        return ""
    pairs = list(dict.fromkeys(r["pair"] for r in rows))
    table: dict[tuple[str, str], dict[str, str]] = {}
    for r in rows:
        lo, hi = r["mean_diff_ci"]
        cell = f"{100 * r['mean_diff']:+.0f} [{100 * lo:+.0f}, {100 * hi:+.0f}] {r['verdict']}"
        table.setdefault((GRIDS[r["grid"]], r["task"]), {})[r["pair"]] = (
            f"**{cell}**" if r["verdict"] in ("higher", "lower") else cell
        )
    runs = {r["pair"]: _runs_label(r, " runs") for r in rows}
    return markdown_table(
        [[grid, task, *(cells.get(p, "") for p in pairs)] for (grid, task), cells in table.items()],
        ["grid", "shell / fault / calibration", *(f"{p} ({runs[p]})" for p in pairs)],
    )


def study_markdown(study: Sequence[Mapping[str, Any]]) -> str:
    """The first table of :func:`study_tables`."""
    if not study:
        return ""

    def value(r: Mapping[str, Any]) -> str:
        if "poi" in r:
            return f"{r['poi']:.2f} [{r['poi_ci'][0]:.2f}, {r['poi_ci'][1]:.2f}]"
        if "retired" in r:
            return f"retired (mean {pct(r['mean'])}, no interval)"
        return f"{pct(r['iqm'])} [{pct(r['iqm_ci'][0])}, {pct(r['iqm_ci'][1])}]"

    def diff(r: Mapping[str, Any]) -> str:
        if "mean_diff" not in r:
            return ""
        lo, hi = r["mean_diff_ci"]
        return f"{100 * r['mean_diff']:+.0f} [{100 * lo:+.0f}, {100 * hi:+.0f}] ({'yes' if r['resolves_10_points'] else 'no'})"

    return markdown_table(
        [[GRIDS[r["grid"]], r["condition"], _runs_label(r), value(r), diff(r), r.get("verdict", "")] for r in study],
        [
            "grid",
            "condition",
            "runs",
            "IQM [95% CI] / P(improvement) [95% CI]",
            "mean difference, points [95% CI] (a 10-point difference would show)",
            "first condition's mean success",
        ],
    )
