"""The learning study's summary: ``summary.json``, ``README.md`` and the learning-curve plot of
``evaluation/results/learning/``, generated from the per-run result files and ``baselines.json``.

Aggregates over training seeds are rliable's (Agarwal et al., 2021): the interquartile mean (IQM)
and the mean with 95 % stratified-bootstrap intervals, the runs' scores being their success rates
on the three shell models (the tasks of the bootstrap's strata).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from sphere_env.evaluation.experiments.intervals import BOOTSTRAP_REPS, SHELLS, interval_estimates, pct
from sphere_env.evaluation.experiments.learning import PD_MARGIN
from sphere_env.evaluation.experiments.study_summary import (
    CONDITION_ORDER,
    MIN_STUDY_RUNS,
    STUDY_RECIPES,
    condition_scores,
    study_markdown,
    study_rows,
    study_task_markdown,
    study_task_rows,
)
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


def shell_scores(runs: Sequence[Mapping[str, Any]]) -> np.ndarray:
    """(runs × shells) success rates."""
    return np.array([[r["per_shell"][m] for m in SHELLS] for r in runs], dtype=float)


def recipe_rows(runs_by_recipe: Mapping[str, list[dict[str, Any]]], pd: Mapping[str, Any]) -> list[dict[str, Any]]:
    from sphere_env.evaluation.experiments.learning import load_recipes

    ests = interval_estimates({k: shell_scores(v) for k, v in runs_by_recipe.items()})
    notes = {k: v.get("note", "") for k, v in load_recipes().items()}
    rows = []
    for name, runs in runs_by_recipe.items():
        succ = np.array([r["success_rate"] for r in runs])
        steps = [r["env_steps_to_pd_level"] for r in runs]
        walls = [r["wall_clock_to_pd_level_s"] for r in runs]
        reached = [s for s in steps if s is not None]
        rows.append(
            {
                "recipe": name,
                "seeds": len(runs),
                "env_steps": int(np.median([r["env_steps"] for r in runs])),
                "mean_success": float(succ.mean()),
                "worst_seed_success": float(succ.min()),
                "per_shell_mean": {m: float(np.mean([r["per_shell"][m] for r in runs])) for m in SHELLS},
                "mean_tracking_rmse_rad_s": float(np.nanmean([r["tracking_rmse_rad_s"] for r in runs])),
                "reached_pd_level": f"{len(reached)}/{len(runs)}",
                "env_steps_to_pd_level_mean": float(np.mean(reached)) if len(reached) == len(runs) else None,
                "env_steps_to_pd_level_range": [min(reached), max(reached)] if reached else None,
                "wall_clock_to_pd_level_s_mean": float(np.mean([w for w in walls if w is not None]))
                if len(reached) == len(runs)
                else None,
                "wall_clock_to_pd_level_s_range": [
                    min(w for w in walls if w is not None),
                    max(w for w in walls if w is not None),
                ]
                if any(w is not None for w in walls)
                else None,
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
                "note": "" if "@" in name else (notes.get(name) or runs[0]["recipe"].get("note", "")),
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


def plot_curves(runs_by_recipe: Mapping[str, list[dict[str, Any]]], pd: Mapping[str, Any], path: Path) -> Path:
    """Grid success against env steps: per recipe the IQM over seeds with its 95 % stratified-
    bootstrap band (rliable), the PD's success and the PD level."""
    from sphere_env.plotting import pyplot

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    for i, (name, runs) in enumerate(runs_by_recipe.items()):
        steps = sorted(set.intersection(*[{c["env_steps"] for c in r["curve"]} for r in runs]))
        if not steps:
            continue
        scores = {}
        for n in steps:
            scores[n] = np.array(
                [[next(c for c in r["curve"] if c["env_steps"] == n)["per_shell"][m] for m in SHELLS] for r in runs]
            )
        est = interval_estimates({str(n): s for n, s in scores.items()})
        y = np.array([est[str(n)]["iqm"] for n in steps])
        lo = np.array([est[str(n)]["iqm_ci"][0] for n in steps])
        hi = np.array([est[str(n)]["iqm_ci"][1] for n in steps])
        ax.plot(steps, y, marker="o", ms=3, color=f"C{i}", label=f"{name} ({len(runs)} seeds)")
        ax.fill_between(steps, lo, hi, color=f"C{i}", alpha=0.2)
    ax.axhline(pd["success_rate"], color="k", lw=1, label="PD")
    ax.axhline(pd["success_rate"] - PD_MARGIN, color="k", lw=1, ls="--", label="PD level (PD − 3 points)")
    ax.set_xlabel("environment steps")
    ax.set_ylabel("grid success (IQM over seeds, 95 % CI)")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
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


def markdown(
    rows: Sequence[Mapping[str, Any]],
    base: Mapping[str, Any],
    faults: str = "",
    study: Sequence[Mapping[str, Any]] = (),
    study_tasks: Sequence[Mapping[str, Any]] = (),
) -> str:

    pd = base["pd"]
    table = _md(
        [
            {
                "recipe": r["recipe"],
                "seeds": r["seeds"],
                "env steps": r["env_steps"],
                "mean success": pct(r["mean_success"]),
                "worst seed": pct(r["worst_seed_success"]),
                "IQM [95% CI]": f"{pct(r['rliable_iqm'])} [{pct(r['rliable_iqm_ci'][0])}, {pct(r['rliable_iqm_ci'][1])}]",
                "point / injected / hydro": " / ".join(pct(r["per_shell_mean"][m]) for m in SHELLS),
                "RMSE rad/s": f"{r['mean_tracking_rmse_rad_s']:.2f}",
                "runs at PD level": r["reached_pd_level"],
                "steps to PD level (mean, range)": "–"
                if r["env_steps_to_pd_level_range"] is None
                else (
                    (f"{r['env_steps_to_pd_level_mean'] / 1e3:.0f} k, " if r["env_steps_to_pd_level_mean"] else "")
                    + f"{r['env_steps_to_pd_level_range'][0] / 1e3:.0f}–{r['env_steps_to_pd_level_range'][1] / 1e3:.0f} k"
                ),
                "wall-clock to PD level (mean, range)": "–"
                if r.get("wall_clock_to_pd_level_s_range") is None
                else (
                    (
                        f"{r['wall_clock_to_pd_level_s_mean'] / 60:.0f} min, "
                        if r["wall_clock_to_pd_level_s_mean"]
                        else ""
                    )
                    + f"{r['wall_clock_to_pd_level_s_range'][0] / 60:.0f}–{r['wall_clock_to_pd_level_s_range'][1] / 60:.0f} min"
                ),
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
    g = base["grid"]
    return (
        "# Learning study\n\n"
        "Generated by `python -m evaluation.experiments.learning summary` from `runs/*/seed*.json` and "
        "`baselines.json` (do not edit by hand).\n\n"
        f"Grid: {g['episodes']} episodes = shells {', '.join(g['shells'])} × {g['pressures_kpa']} kPa × "
        f"evaluation seeds {g['seeds']} (each seed draws the two commands), deterministic actions, "
        f"randomization off. PD: {pct(pd['success_rate'])} success (point / injected / hydro "
        f"{' / '.join(pct(pd['per_shell'][m]) for m in SHELLS)}), tracking RMSE "
        f"{pd['tracking_rmse_rad_s']:.2f} rad/s; zero torque {pct(base['zero']['success_rate'])}. "
        "PD level = PD − 3 points. IQM and its interval: rliable, stratified bootstrap over training seeds "
        f"with the three shells as tasks ({BOOTSTRAP_REPS} resamples). Steps and wall-clock to PD level: at "
        "the first checkpoint (every 100 k steps) whose grid success reaches it, the wall-clock at the run's "
        "training rate on the 2-core machine, which the seeds of a recipe shared; a mean only when "
        "every run got there.\n\n" + table + "\n\n"
        "`<recipe>@selected`: each run reported by its checkpoint with the highest success on the validation "
        "grid (evaluation seeds 100-102, never the reported grid), from half its budget on: the model an "
        "rl-zoo3 user keeps as best_model. The plain rows report each run's final model.\n\n"
        + notes
        + "\n\n![learning curves](learning_curves.png)\n"
        + (
            "\n## Fault grid\n\nThe nominal grid under one fault at a time (`evaluation/faults.py`: what each "
            "fault is and where its range comes from), deterministic actions; runs by their validation-chosen "
            "checkpoint.\n\n" + faults + "\n"
            if faults
            else ""
        )
        + (
            "\n## Randomization study\n\nTraining conditions (each run's `condition`: "
            + ", ".join(CONDITION_ORDER[::-1])
            + "; the runs of the recipes "
            + ", ".join(f"`{r}`" for r in STUDY_RECIPES)
            + ": the first three differ in their training randomization only, and the fourth arm, "
            "pressure_faults_4m, is the pressure_faults runs continued to twice their budget), every run by "
            "its validation-chosen checkpoint, on the nominal grid (scores per shell) "
            "and the fault grid (scores per fault): rliable's IQM with 95 % stratified-bootstrap intervals, and for "
            "each pair the probability that a run of the first condition beats one of the second (0.5: no "
            "difference; an interval that excludes 0.5 tells them apart) with the difference of their mean success "
            "and its interval (the study can tell a 10-point difference where that interval's half-width is under 10 "
            "points). Conditions with fewer than "
            + str(MIN_STUDY_RUNS)
            + " runs are left out (a bootstrap over fewer runs draws too few distinct samples for its interval to mean much).\n\n"
            + (
                study_markdown(study)
                + (
                    "\n\nWhere they differ: the difference of mean success, in points, per shell of the nominal "
                    "grid and per fault of the fault grid, with its 95 % bootstrap interval over runs and what "
                    "that interval says of the first condition: higher or lower (in bold) where it excludes 0; "
                    "within 10 points where it holds 0 and lies inside ±10 points, so neither condition leads "
                    "by 10 points; undecided where it holds 0 and reaches past ±10 points, so it rules out "
                    "neither no difference nor a 10-point one.\n\n" + study_task_markdown(study_tasks)
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
            "\n## Recipes tried without a finished run\n\nFrom `evaluation/experiments/recipes.yml`; stopped "
            "early for the reason in their note, or not run yet.\n\n" + stopped + "\n"
            if stopped
            else ""
        )
    )


def write_summary(results: Path) -> Path:
    base = json.loads((results / "baselines.json").read_text())
    runs_by_recipe = load_runs(results)
    rows = recipe_rows({**runs_by_recipe, **selected_runs(runs_by_recipe)}, base["pd"]) if runs_by_recipe else []
    scores = condition_scores(runs_by_recipe) if runs_by_recipe else {}
    study = study_rows(scores) if scores else []
    study_tasks = study_task_rows(scores) if scores else []
    summary = {
        "commit": base.get("commit"),
        "cores": 2,
        "grid": base["grid"],
        "pd": base["pd"],
        "zero": base["zero"],
        "randomization_study": study,
        "randomization_study_by_task": study_tasks,
        "pretrained": base.get("pretrained"),
        "recipes": rows,
        "runs": [
            {
                k: r[k]
                for k in (
                    "method",
                    "condition",
                    "from_scratch",
                    "seed",
                    "success_rate",
                    "tracking_rmse_rad_s",
                    "per_shell",
                    "env_steps_to_pd_level",
                    "wall_clock_to_pd_level_s",
                    "wall_clock_s",
                    "env_steps",
                    "commit",
                )
            }
            | {
                "faults": r.get("faults", {}),
                "selected": {k: v for k, v in r.get("selected", {}).items() if k != "faults"},
            }
            for runs in runs_by_recipe.values()
            for r in runs
        ],
    }
    write_text_atomic(results / "summary.json", json.dumps(summary, indent=1) + "\n")
    if runs_by_recipe:
        plot_curves(runs_by_recipe, base["pd"], results / "learning_curves.png")
    write_text_atomic(
        results / "README.md", markdown(rows, base, fault_table(base, runs_by_recipe), study, study_tasks)
    )
    return results / "summary.json"
