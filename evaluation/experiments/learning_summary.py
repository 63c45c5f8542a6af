"""The learning study's summary: ``summary.json``, ``README.md`` and the learning-curve plot of
``evaluation/results/learning/``, generated from the per-run result files, ``baselines.json`` (the
PD and zero torque on the development grid) and ``baselines_validation.json`` (the PD on the
validation grid). Nothing is simulated here, so the files rebuild byte for byte from those.

A run's score on a grid is one number, its success over the grid's episodes, and aggregates over
training seeds are rliable's (Agarwal et al., 2021) with whole runs resampled
(:mod:`~sphere_env.evaluation.experiments.intervals`). What a result file records of how its run
was made (from scratch or not) is derived anew from its recipe
(:mod:`~sphere_env.evaluation.experiments.run_provenance`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from sphere_env.evaluation.experiments.intervals import BOOTSTRAP_REPS, SHELLS, interval_estimates, pct
from sphere_env.evaluation.experiments.learning import PD_MARGIN
from sphere_env.evaluation.experiments.run_provenance import (
    from_scratch,
    recipe_of,
    resumed_at,
    wall_clock_markdown,
    wall_clock_rows,
)
from sphere_env.evaluation.experiments.study_summary import (
    CONDITION_ORDER,
    MIN_STUDY_RUNS,
    STUDY_RECIPES,
    condition_scores,
    retired_conditions,
    study_markdown,
    study_tables,
    study_task_markdown,
)
from sphere_env.evaluation.experiments.validation_baselines import FILE as VALIDATION_BASELINES
from sphere_env.files import write_text_atomic
from sphere_env.reporting import markdown_table


def load_runs(results: Path) -> dict[str, list[dict[str, Any]]]:
    """Result files by recipe name, seeds in order."""
    out: dict[str, list[dict[str, Any]]] = {}
    for f in sorted((results / "runs").glob("*/seed*.json")):
        r = json.loads(f.read_text())
        out.setdefault(f.parent.name, []).append(r)
    for v in out.values():
        v.sort(key=lambda r: r["seed"])
    return out


def _validation_success(run: Mapping[str, Any]) -> float | None:
    """The success on the validation grid of a run's validation-chosen checkpoint: the best of its
    checkpoints from half its budget on (None for a run without a validation choice)."""
    return ((run.get("selected") or {}).get("validation") or {}).get("success_rate")


def recipe_rows(
    runs_by_recipe: Mapping[str, list[dict[str, Any]]],
    pd: Mapping[str, Any],
    pd_validation: Mapping[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """Per recipe: its runs' figures on the development grid (final models, or ``<recipe>@selected``
    the validation-chosen checkpoints), rliable's IQM over whole runs, the aims judged against the
    PD's development-grid figures ``pd``, and how many runs reached PD level on the validation grid:
    whose validation-chosen checkpoint won at least the PD's validation success (``pd_validation``)
    less :data:`PD_MARGIN` (None where the PD's or a run's validation figures are missing)."""
    from sphere_env.evaluation.experiments.learning import load_recipes

    ests = interval_estimates({k: np.array([r["success_rate"] for r in v]) for k, v in runs_by_recipe.items()})
    recipes = load_recipes()
    level = None if pd_validation is None else pd_validation["success_rate"] - PD_MARGIN
    rows = []
    for name, runs in runs_by_recipe.items():
        succ = np.array([r["success_rate"] for r in runs])
        val = [_validation_success(r) for r in runs]
        rows.append(
            {
                "recipe": name,
                "seeds": len(runs),
                "runs_from_scratch": sum(from_scratch(recipe_of(r, recipes), r["seed"]) for r in runs),
                "env_steps": int(np.median([r["env_steps"] for r in runs])),
                "mean_success": float(succ.mean()),
                "worst_seed_success": float(succ.min()),
                "per_shell_mean": {m: float(np.mean([r["per_shell"][m] for r in runs])) for m in SHELLS},
                "mean_tracking_rmse_rad_s": float(np.nanmean([r["tracking_rmse_rad_s"] for r in runs])),
                "validation_reached_pd_level": None
                if level is None or None in val
                else f"{sum(v >= level - 1e-9 for v in val)}/{len(runs)}",
                **{f"rliable_{k}": v for k, v in ests[name].items()},
                "aims": {
                    "mean_success_ge_pd_minus_3": bool(succ.mean() >= pd["success_rate"] - PD_MARGIN - 1e-9),
                    "worst_seed_ge_85": bool(succ.min() >= 0.85 - 1e-9),
                    "every_shell_ge_80": all(np.mean([r["per_shell"][m] for r in runs]) >= 0.8 - 1e-9 for m in SHELLS),
                    "rmse_le_pd": bool(
                        np.nanmean([r["tracking_rmse_rad_s"] for r in runs]) <= pd["tracking_rmse_rad_s"]
                    ),
                },
                # the recipe's note as recipes.yml has it now (what was found is added to it after the
                # runs), else as the runs recorded it
                "note": "" if "@" in name else (recipes.get(name, {}).get("note") or runs[0]["recipe"].get("note", "")),
            }
        )
    return rows


def selected_runs(runs_by_recipe: Mapping[str, list[dict[str, Any]]]) -> dict[str, list[dict[str, Any]]]:
    """Each recipe's runs with their validation-chosen checkpoint's figures as the run's figures
    (``<recipe>@selected``; recipes whose runs all have one)."""
    out = {}
    for name, runs in runs_by_recipe.items():
        if runs and all("selected" in r for r in runs):
            out[f"{name}@selected"] = [
                {**r, **{k: r["selected"][k] for k in ("success_rate", "tracking_rmse_rad_s", "per_shell")}}
                for r in runs
            ]
    return out


def fault_table(base: Mapping[str, Any], runs_by_recipe: Mapping[str, list[dict[str, Any]]]) -> str:
    """Success per fault: zero torque, the PD, the pretrained policy and each recipe's runs (their
    validation-chosen checkpoints: mean and worst seed)."""

    cols = {name: base[name]["faults"] for name in ("zero", "pd", "pretrained") if "faults" in base.get(name, {})}
    faults = list(next(iter(cols.values())).keys()) if cols else []
    from sphere_env.evaluation.faults import FAULTS

    rows = []
    for f in faults:
        row = {
            "fault": f"{f}: {FAULTS[f].title}" if f in FAULTS else f,
            **{c: pct(v[f]["success_rate"]) for c, v in cols.items()},
        }
        for name, runs in runs_by_recipe.items():
            got = [r["faults"][f]["success_rate"] for r in runs if f in (r.get("faults") or {})]
            if got:
                row[f"{name} ({len(got)} seeds): mean, worst"] = f"{pct(float(np.mean(got)))}, {pct(min(got))}"
        rows.append(row)
    if not rows:
        return ""
    why = "\n".join(f"- **{f}**: {FAULTS[f].why}." for f in faults if f in FAULTS)
    return _md(rows) + "\n\nWhere each range comes from:\n\n" + why


#: The learning-curve figure's colours: each panel's recipe, the shipped policy's recipe drawn in
#: every other panel for reference, and the PD (its success, and PD level dashed).
CURVE_COLOURS = {"recipe": "tab:blue", "shipped": "0.55", "pd": "black"}
PANEL_COLUMNS = 4


def _iqm_curve(runs: Sequence[Mapping[str, Any]]) -> tuple[list[int], np.ndarray, np.ndarray, np.ndarray]:
    """(env steps every run was evaluated at, the IQM over the runs there, its 95 % interval's low
    and high ends)."""
    steps = sorted(set.intersection(*[{c["env_steps"] for c in r["curve"]} for r in runs]))
    if not steps:
        return [], np.array([]), np.array([]), np.array([])
    scores = {
        str(n): np.array([next(c for c in r["curve"] if c["env_steps"] == n)["success_rate"] for r in runs])
        for n in steps
    }
    by_step = interval_estimates(scores)
    est = [by_step[str(n)] for n in steps]
    return steps, np.array([e["iqm"] for e in est]), *(np.array([e["iqm_ci"][i] for e in est]) for i in (0, 1))


def shipped_recipe() -> str:
    """The recipe the shipped policy was trained with (its card's)."""
    from sphere_env.resources import shipped_policy_path

    return json.loads((shipped_policy_path("pretrained") / "card.json").read_text())["recipe"]


def plot_curves(
    runs_by_recipe: Mapping[str, list[dict[str, Any]]], pd: Mapping[str, Any], path: Path, shipped: str | None = None
) -> Path:
    """Development-grid success against env steps, one panel per recipe (:data:`CURVE_COLOURS`): the
    recipe's IQM over its seeds with its 95 % bootstrap band over whole runs (rliable), the
    ``shipped`` recipe's IQM in every other panel for reference, the PD's success and PD level."""
    from sphere_env.plotting import pyplot

    curves = {name: _iqm_curve(runs) for name, runs in runs_by_recipe.items()}
    curves = {name: c for name, c in curves.items() if c[0]}
    plt = pyplot()
    rows = max(1, -(-len(curves) // PANEL_COLUMNS))
    fig, axes = plt.subplots(
        rows, PANEL_COLUMNS, figsize=(11, 2.2 * rows + 0.9), sharex=True, sharey=True, squeeze=False
    )
    reference = curves.get(shipped) if shipped else None
    for ax, (name, (steps, y, lo, hi)) in zip(axes.flat, curves.items()):
        if reference is not None and name != shipped:
            ax.plot(reference[0], reference[1], color=CURVE_COLOURS["shipped"], lw=1)
        ax.fill_between(steps, lo, hi, color=CURVE_COLOURS["recipe"], alpha=0.25, lw=0)
        ax.plot(steps, y, color=CURVE_COLOURS["recipe"], marker="o", ms=2, lw=1.2)
        ax.axhline(pd["success_rate"], color=CURVE_COLOURS["pd"], lw=0.8)
        ax.axhline(pd["success_rate"] - PD_MARGIN, color=CURVE_COLOURS["pd"], lw=0.8, ls="--")
        ax.set_title(f"{name} ({len(runs_by_recipe[name])} seeds)", fontsize=8)
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
        ax.xaxis.get_offset_text().set_fontsize(7)
    for ax in list(axes.flat)[len(curves) :]:
        ax.set_visible(False)
    for ax in axes[:, 0]:
        ax.set_ylabel("success", fontsize=8)
    for column in axes.T:  # the lowest panel of each column carries the steps axis
        for lowest in [ax for ax in column if ax.get_visible()][-1:]:
            lowest.xaxis.set_tick_params(labelbottom=True)
            lowest.set_xlabel("environment steps", fontsize=8)
    handles = [
        plt.Line2D(
            [], [], color=CURVE_COLOURS["recipe"], marker="o", ms=2, label="the panel's recipe: IQM over seeds, 95 % CI"
        ),
        plt.Line2D([], [], color=CURVE_COLOURS["pd"], label="PD"),
        plt.Line2D([], [], color=CURVE_COLOURS["pd"], ls="--", label="PD level (PD − 3 points)"),
    ]
    if reference is not None:
        handles.insert(
            1, plt.Line2D([], [], color=CURVE_COLOURS["shipped"], label=f"{shipped} (the shipped policy's recipe)")
        )
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=7, frameon=False)
    fig.suptitle("Development-grid success against environment steps, one panel per recipe", fontsize=10)
    fig.tight_layout(rect=(0, 0.04, 1, 0.97))
    tmp = path.with_name(path.stem + ".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(path)
    return path


def _md(rows: Sequence[Mapping[str, Any]]) -> str:
    """Rows of one mapping each as a Markdown table, one column per key (in the rows' order, first
    seen first): the project's one table helper, :func:`sphere_env.reporting.markdown_table`."""
    keys = list(dict.fromkeys(k for r in rows for k in r))
    return markdown_table(rows, [(k, k, "") for k in keys])


def _grid_text(base: Mapping[str, Any], pd_validation: Mapping[str, Any] | None) -> str:
    """The sets of episodes the figures are on, the PD's figures on each and what PD level means."""
    g, pd = base["grid"], base["pd"]
    val = (
        f"Validation grid: the same shells and pressures at evaluation seeds "
        f"{pd_validation['grid']['seeds']}, on which each run's checkpoint is chosen and nothing is reported "
        f"but PD level; the PD wins {pct(pd_validation['pd']['success_rate'])} there (point / injected / hydro "
        f"{' / '.join(pct(pd_validation['pd']['per_shell'][m]) for m in SHELLS)}; `{VALIDATION_BASELINES}`). "
        if pd_validation
        else "Validation grid: the same shells and pressures at evaluation seeds 100-102; the PD's figures on it "
        f"are not in `{VALIDATION_BASELINES}`, so PD level on it is not reported. "
    )
    return (
        f"Development grid (every figure below unless its column or section names another): {g['episodes']} "
        f"episodes = shells {', '.join(g['shells'])} × {g['pressures_kpa']} kPa × evaluation seeds {g['seeds']} "
        "(each seed draws the two commands), deterministic actions, randomization off; the recipes were designed "
        f"against its failures. PD: {pct(pd['success_rate'])} success (point / injected / hydro "
        f"{' / '.join(pct(pd['per_shell'][m]) for m in SHELLS)}), tracking RMSE {pd['tracking_rmse_rad_s']:.2f} "
        f"rad/s; zero torque {pct(base['zero']['success_rate'])}. " + val + "PD level = the PD's success on the "
        "same grid − 3 points. IQM and its interval: rliable over whole runs, each run's development-grid success "
        f"one sample ({BOOTSTRAP_REPS} resamples). Runs at PD level: on the validation grid, those whose "
        "validation-chosen checkpoint (the best on the validation grid from half the budget on) reached it. The "
        "run files hold that checkpoint's validation figures only, so when a run first reached PD level on the "
        "validation grid is not known and is not reported."
    )


def markdown(
    rows: Sequence[Mapping[str, Any]],
    base: Mapping[str, Any],
    faults: str = "",
    study: Sequence[Mapping[str, Any]] = (),
    study_tasks: Sequence[Mapping[str, Any]] = (),
    pd_validation: Mapping[str, Any] | None = None,
    wall_clock: str = "",
) -> str:
    table = _md(
        [
            {
                "recipe": r["recipe"],
                "seeds": r["seeds"],
                "from scratch": f"{r['runs_from_scratch']}/{r['seeds']}",
                "env steps": r["env_steps"],
                "mean success": pct(r["mean_success"]),
                "worst seed": pct(r["worst_seed_success"]),
                "IQM [95% CI]": f"{pct(r['rliable_iqm'])} [{pct(r['rliable_iqm_ci'][0])}, {pct(r['rliable_iqm_ci'][1])}]",
                "point / injected / hydro": " / ".join(pct(r["per_shell_mean"][m]) for m in SHELLS),
                "RMSE rad/s": f"{r['mean_tracking_rmse_rad_s']:.2f}",
                "runs at PD level on the validation grid": r["validation_reached_pd_level"] or "not recorded",
            }
            for r in rows
        ]
    )
    notes = "\n".join(f"- **{r['recipe']}**: {r['note']}" for r in rows if r["note"])
    from sphere_env.evaluation.experiments.learning import load_recipes

    finished = {r["recipe"].split("@")[0] for r in rows}
    stopped = "\n".join(
        f"- **{name}**: {rec.get('note', '')}" for name, rec in load_recipes().items() if name not in finished
    )
    retired = [r for r in study if "retired" in r]
    return (
        "# Learning study\n\n"
        "Generated by `python -m evaluation.experiments.learning summary` from `runs/*/seed*.json`, "
        f"`baselines.json` and `{VALIDATION_BASELINES}` (do not edit by hand).\n\n"
        + _grid_text(base, pd_validation)
        + "\n\n"
        + table
        + "\n\n"
        "`<recipe>@selected`: each run reported by its checkpoint with the highest success on the validation "
        "grid, from half its budget on: the model an rl-zoo3 user keeps as best_model. The plain rows report "
        "each run's final model. From scratch: runs that did not continue another run's checkpoint (derived "
        "from the recipe).\n\n" + notes + "\n\n![learning curves](learning_curves.png)\n\n"
        "Learning curves, one panel per recipe, development-grid success against env steps: the panel's recipe "
        "as the IQM over its seeds (blue) with its 95 % bootstrap band over whole runs, the shipped policy's "
        "recipe in grey in every other panel for reference, the PD's success (black) and PD level (black, "
        "dashed).\n"
        + (
            "\n## Fault grid\n\nThe development grid under one fault at a time (`evaluation/faults.py`: what "
            "each fault is and where its range comes from), deterministic actions; runs by their "
            "validation-chosen checkpoint.\n\n" + faults + "\n"
            if faults
            else ""
        )
        + (
            "\n## Randomization study\n\nTraining conditions (each run's `condition`: "
            + ", ".join(CONDITION_ORDER[::-1])
            + "; the runs of the recipes "
            + ", ".join(f"`{r}`" for r in STUDY_RECIPES)
            + ": nominal, pressure and pressure_faults differ in their training randomization only; "
            "calibration draws what the twin does not know and trains under TAMSI contact, evaluated under SAP "
            "like the others; pressure_faults_4m, an arm beside them, is the pressure_faults runs continued to "
            "twice their budget), every run by "
            "its validation-chosen checkpoint, on the development grid and the fault grid. A run's score on a "
            "grid is one number, its success over the grid's episodes, and every interval is a 95 % bootstrap "
            "over whole runs: rliable's IQM per condition, and for each pair one bootstrap, paired by seed where "
            "both conditions ran the same seeds, for the probability that a run of the first condition beats "
            "one of the second (0.5: no difference), the difference of their mean success (the study can tell a "
            "10-point difference where that interval's half-width is under 10 points) and the differences per "
            "shell and per fault. Conditions with fewer than "
            + str(MIN_STUDY_RUNS)
            + " runs are left out (a bootstrap over fewer runs draws too few distinct samples for its interval "
            "to mean much), and a retired condition is listed with its runs and no interval or verdict"
            + "".join(f" ({r['condition']}: {r['retired']})" for r in retired[:1])
            + ".\n\n"
            + (
                study_markdown(study)
                + (
                    "\n\nWhere they differ: the difference of mean success, in points, per shell of the "
                    "development grid and per fault of the fault grid, with its 95 % interval and what that "
                    "interval says of the first condition: higher or lower (in bold) where it excludes 0; within "
                    "10 points where it holds 0 and lies inside ±10 points, so neither condition leads by 10 "
                    "points; undecided where it holds 0 and reaches past ±10 points, so it rules out neither no "
                    "difference nor a 10-point one.\n\n" + study_task_markdown(study_tasks)
                    if study_tasks
                    else ""
                )
                if study
                else "No condition has "
                + str(MIN_STUDY_RUNS)
                + " finished runs yet; `python -m evaluation.experiments.learning run --recipe "
                + " ".join(STUDY_RECIPES)
                + " --seeds 0 1 2 3 4 5 6 7 8 9 --jobs 2 --complete` runs the study."
            )
            + "\n"
        )
        + (
            "\n## Wall-clock per run\n\nTraining wall-clock: each run's env steps at the training rate of its "
            "last session, on the 2-core machine with other runs beside it (a resumed run's earlier sessions "
            "were not timed, so its figure takes its last session's rate for the whole run; a continuation "
            "counts its first phase at the first run's rate). Job wall time: the job that wrote the result "
            "file (the training it still had to do, and the evaluation of every checkpoint). The 1-min load "
            "average at the job's start and end is recorded by runs from this version of the runner on. Runs "
            "resumed part-way from their own checkpoint are a row of their own.\n\n" + wall_clock + "\n"
            if wall_clock
            else ""
        )
        + (
            "\n## Recipes tried without a finished run\n\nFrom `evaluation/experiments/recipes.yml`; stopped "
            "early for the reason in their note, or not run yet.\n\n" + stopped + "\n"
            if stopped
            else ""
        )
    )


def _run_entry(r: Mapping[str, Any], recipes: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """A run as ``summary.json`` lists it: its figures, how it was made (derived from its recipe)
    and its wall-clock with the load it ran under (None where not recorded)."""
    recipe = recipe_of(r, recipes)
    return {
        **{
            k: r[k]
            for k in ("method", "condition", "seed", "success_rate", "tracking_rmse_rad_s", "per_shell", "env_steps")
        },
        "from_scratch": from_scratch(recipe, r["seed"]),
        "resumed_at_env_steps": resumed_at(recipe, r["seed"]),
        **{k: r.get(k) for k in ("wall_clock_s", "steps_per_s", "job_wall_s", "load_avg_1min", "commit")},
        "faults": r.get("faults", {}),
        "calibrations": r.get("calibrations", {}),
        "selected": {k: v for k, v in r.get("selected", {}).items() if k != "faults"},
    }


def write_summary(results: Path, plot: bool = True) -> Path:
    """``summary.json`` and ``README.md`` of ``results`` from its run files and baselines, and
    (``plot``) the learning-curve plot."""
    from sphere_env.evaluation.experiments.learning import load_recipes

    base = json.loads((results / "baselines.json").read_text())
    val_path = results / VALIDATION_BASELINES
    pd_validation = json.loads(val_path.read_text()) if val_path.exists() else None
    recipes = load_recipes()
    runs_by_recipe = load_runs(results)
    rows = (
        recipe_rows(
            {**runs_by_recipe, **selected_runs(runs_by_recipe)},
            base["pd"],
            None if pd_validation is None else pd_validation["pd"],
        )
        if runs_by_recipe
        else []
    )
    scores = condition_scores(runs_by_recipe) if runs_by_recipe else {}
    study, study_tasks = study_tables(scores, retired_conditions(recipes)) if scores else ([], [])
    walls = wall_clock_rows(runs_by_recipe, recipes)
    summary = {
        "commit": base.get("commit"),
        "cores": 2,
        "grid": base["grid"],
        "validation_grid": None if pd_validation is None else pd_validation["grid"],
        "pd": base["pd"],
        "pd_validation": None if pd_validation is None else pd_validation["pd"],
        "zero": base["zero"],
        "randomization_study": study,
        "randomization_study_by_task": study_tasks,
        "pretrained": base.get("pretrained"),
        "recipes": rows,
        "wall_clock": walls,
        "runs": [_run_entry(r, recipes) for runs in runs_by_recipe.values() for r in runs],
    }
    write_text_atomic(results / "summary.json", json.dumps(summary, indent=1) + "\n")
    if runs_by_recipe and plot:
        plot_curves(runs_by_recipe, base["pd"], results / "learning_curves.png", shipped_recipe())
    write_text_atomic(
        results / "README.md",
        markdown(
            rows,
            base,
            fault_table(base, runs_by_recipe),
            study,
            study_tasks,
            pd_validation,
            wall_clock_markdown(walls) if walls else "",
        ),
    )
    return results / "summary.json"
