"""Blocks of ``docs/results/learning.md``: the shipped policy's card, each recipe's figures over seeds
(``learning/summary.json`` and the per-seed ``learning/runs/<recipe>/seed<k>.json`` with their
learning curves) and the normalization swap (``learning/normalization_swap.json``)."""

from __future__ import annotations

import json

from sphere_env.evaluation.experiments.docs.base import DocsError, Results, percent, renders, slash, span, table
from sphere_env.evaluation.experiments.learning import PD_MARGIN, SECTION_RECIPE
from sphere_env.evaluation.experiments.study_summary import (
    GRIDS,
    MIN_STUDY_RUNS,
    STUDY_RECIPES,
    VERDICTS,
    chose_budget_end,
)
from sphere_env.resources import asset_path

CARD = ("policies", "ramp_descent_v3", "card.json")


def _summary(res: Results) -> dict:
    return res.json("learning/summary.json")


def _recipes(res: Results) -> dict[str, dict]:
    """recipe name (``<recipe>`` or ``<recipe>@selected``) -> its row of the summary."""
    return {r["recipe"]: r for r in _summary(res)["recipes"]}


def _curves(res: Results, recipe: str) -> list[list[dict]]:
    """The learning curve (grid success of every evaluated checkpoint) of each seed of ``recipe``."""
    seeds = sorted(r["seed"] for r in _summary(res)["runs"] if r["method"] == recipe)
    return [res.json(f"learning/runs/{recipe}/seed{k}.json")["curve"] for k in seeds]


def steps_k(n: float) -> str:
    """Env steps as the page writes them: ``900 k``, ``1.3 M``."""
    return f"{n / 1e6:.1f} M".replace(".0 M", " M") if n >= 1e6 else f"{n / 1e3:.0f} k"


@renders("learning_shipped_policy")
def learning_shipped_policy(res: Results) -> str:
    path = asset_path(*CARD)
    try:
        card = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise DocsError(f"cannot read policy card {path}: {e}") from e
    pd = _summary(res)["pd"]
    n = len(card["episodes"])
    text = (
        f"the recipe `{card['recipe']}`'s seed {card['seed']} at {steps_k(card.get('env_steps') or card['checkpoint_steps'])} env steps; it "
        f"wins {round(card['success_rate'] * n)} of {n} development-grid episodes (the PD {round(pd['success_rate'] * n)}) "
        f"at a tracking RMSE of {card['tracking_rmse_rad_s']:.2f} rad/s (the PD {pd['tracking_rmse_rad_s']:.2f})"
    )
    if "test" not in card:
        return text
    test, pd_test = card["test"], res.json("learning/held_out.json")["baselines"]["pd"]
    below = [k for k, v in test["faults"].items() if v["success_rate"] < pd_test["faults"][k] - 1e-9]
    below += [k for k, v in test["calibrations"].items() if v["success_rate"] < pd_test["calibrations"][k] - 1e-9]
    return (
        f"{text}; on the test set it wins {percent(test['nominal']['success_rate'])} (the PD "
        f"{percent(pd_test['success_rate'])}), and under the {len(test['faults'])} graded faults and "
        f"{len(test['calibrations'])} other calibrations it is at or above the PD "
        + (f"on all but {len(below)} ({', '.join(sorted(below))})" if below else "on every one")
    )


@renders("learning_recipe_table")
def learning_recipe_table(res: Results) -> str:
    rows = []
    recipes = _recipes(res)
    for name, r in recipes.items():
        if name.endswith("@selected"):
            continue
        sel = recipes.get(f"{name}@selected")
        peaks = [max(c, key=lambda x: (x["success_rate"], -x["env_steps"])) for c in _curves(res, name)]
        rows.append(
            [
                name,
                str(r["seeds"]),
                steps_k(r["env_steps"]),
                f"{percent(r['mean_success'])} ({percent(r['worst_seed_success'])})",
                f"{percent(sel['mean_success'])} ({percent(sel['worst_seed_success'])})" if sel else "–",
                slash(percent(p["success_rate"]) for p in peaks),
                slash(steps_k(p["env_steps"]) for p in peaks),
            ]
        )
    return table(
        [
            "recipe",
            "seeds",
            "budget",
            "final model: mean (worst)",
            "validation-chosen: mean (worst)",
            "best checkpoint of each seed (development grid)",
            "at env steps",
        ],
        rows,
    )


def _fall(res: Results, recipe: str) -> tuple[int, dict, dict]:
    """(seed, peak, last) of the seed of ``recipe`` whose grid success fell furthest after its peak."""
    falls = []
    for k, curve in enumerate(_curves(res, recipe)):
        peak = max(curve, key=lambda x: (x["success_rate"], -x["env_steps"]))
        falls.append((peak["success_rate"] - curve[-1]["success_rate"], k, peak, curve[-1]))
    _, k, peak, last = max(falls, key=lambda x: x[0])
    return k, peak, last


@renders("learning_batch_fall")
def learning_batch_fall(res: Results) -> str:
    k, peak, last = _fall(res, "stable_wide_batch")
    return (
        f"seed {k} from {percent(peak['success_rate'])} of the development grid at {steps_k(peak['env_steps'])} steps to "
        f"{percent(last['success_rate'])} at {steps_k(last['env_steps'])}"
    )


@renders("learning_batch_peaks")
def learning_batch_peaks(res: Results) -> str:
    peaks = sorted(max(c["success_rate"] for c in curve) for curve in _curves(res, "stable_wide_batch"))
    level = _summary(res)["pd"]["success_rate"] - PD_MARGIN
    high = [p for p in peaks if p >= level - 1e-9]
    return (
        f"the best checkpoints of {len(high)} of {len(peaks)} seeds won {span(high, percent)} of the development grid"
        if high
        else f"no seed's best checkpoint reached the PD's level on the development grid (best {percent(peaks[-1])})"
    )


@renders("normalization_swap")
def normalization_swap(res: Results) -> str:
    s = res.json("learning/normalization_swap.json")
    e, late, c, d = s["early_steps"], s["late_steps"], s["cases"], s["statistics_drift"]

    def wins(p: int, st: int) -> str:
        x = c[f"policy_{p}_stats_{st}"]
        return f"{x['wins']} of {x['episodes']}"

    lo, hi = d["sd_ratio_range"]
    return (
        f"`{s['run']}`'s {steps_k(e)} policy wins {wins(e, late)} grid episodes with the normalization "
        f"statistics of {steps_k(late)} ({wins(e, e)} with its own), and its {steps_k(late)} policy wins "
        f"{wins(late, e)} with those of {steps_k(e)} ({wins(late, late)} with its own). The statistics moved "
        f"little in between: means by at most {d['max_abs_mean_shift_in_early_sd']:.2f} σ, standard deviations "
        f"by a factor of {lo:.2f}–{hi:.2f}"
    )


@renders("learning_best_recipe")
def learning_best_recipe(res: Results) -> str:
    """The recipe with the highest mean success of its validation-chosen checkpoints (five seeds or more)."""
    rows = [r for r in _summary(res)["recipes"] if r["recipe"].endswith("@selected") and r["seeds"] >= 5]
    best = max(rows, key=lambda r: (r["mean_success"], r["worst_seed_success"]))
    per = best["per_shell_mean"]
    met = [k for k, ok in best["aims"].items() if ok]
    return (
        f"the best recipe over five seeds so far, `{best['recipe'].removesuffix('@selected')}`, wins "
        f"{percent(best['mean_success'])} of the development grid in the mean with each seed's validation-chosen checkpoint "
        f"(worst seed {percent(best['worst_seed_success'])}; point / injected / hydroelastic "
        f"{slash((percent(per[m]) for m in ('point', 'injected', 'hydroelastic')))}; rliable IQM "
        f"{percent(best['rliable_iqm'])}, 95 % CI {percent(best['rliable_iqm_ci'][0])}–"
        f"{percent(best['rliable_iqm_ci'][1])}), and meets {len(met)} of the {len(best['aims'])} aims"
    )


@renders("learning_section_recipe")
def learning_section_recipe(res: Results) -> str:
    """The figures over seeds of the recipe that ppo.yml's section is (:data:`SECTION_RECIPE`), and
    how many of its runs reached PD level on the validation grid."""
    s = _summary(res)
    r = _recipes(res).get(f"{SECTION_RECIPE}@selected")
    if r is None:
        raise DocsError(f"ppo.yml's recipe {SECTION_RECIPE!r} has no finished runs in learning/summary.json")
    per = r["per_shell_mean"]
    met = [k for k, ok in r["aims"].items() if ok]
    reached = r["validation_reached_pd_level"]
    level = (
        f"; {reached.split('/')[0]} of its {reached.split('/')[1]} runs reached PD level on the validation grid "
        f"(the PD wins {percent(s['pd_validation']['success_rate'])} there)"
        if reached
        else "; PD level on the validation grid is not recorded"
    )
    return (
        f"`{SECTION_RECIPE}` wins {percent(r['mean_success'])} of the development grid in the mean over {r['seeds']} "
        f"seeds with each seed's validation-chosen checkpoint (worst seed {percent(r['worst_seed_success'])}; point / "
        f"injected / hydroelastic {slash(percent(per[m]) for m in ('point', 'injected', 'hydroelastic'))}; tracking "
        f"RMSE {r['mean_tracking_rmse_rad_s']:.2f} rad/s; rliable IQM over whole runs {percent(r['rliable_iqm'])}, "
        f"95 % CI {percent(r['rliable_iqm_ci'][0])}–{percent(r['rliable_iqm_ci'][1])}) and meets {len(met)} of the "
        f"{len(r['aims'])} aims" + level
    )


@renders("learning_batch32_vs_batch")
def learning_batch32_vs_batch(res: Results) -> str:
    r = _recipes(res)
    a, b = r["stable_wide_batch32@selected"], r["stable_wide_batch@selected"]
    return (
        f"development grid: mean {percent(a['mean_success'])} and worst seed {percent(a['worst_seed_success'])} against "
        f"{percent(b['mean_success'])} and {percent(b['worst_seed_success'])}; point / injected / hydroelastic "
        f"{slash(percent(a['per_shell_mean'][m]) for m in ('point', 'injected', 'hydroelastic'))}"
    )


@renders("learning_batch32_failures")
def learning_batch32_failures(res: Results) -> str:
    """How the final models of ``stable_wide_batch32`` fail their grid episodes: off the lane, or at
    the run-out with a tracking RMSE over the tolerance; and where (shell, pressure)."""
    seeds = sorted(r["seed"] for r in _summary(res)["runs"] if r["method"] == "stable_wide_batch32")
    eps = [e for k in seeds for e in res.json(f"learning/runs/stable_wide_batch32/seed{k}.json")["episodes"]]
    failed = [e for e in eps if not e["is_success"]]
    at_runout = [e for e in failed if e["reached_runout"]]
    rmse = [e["tracking_rmse_rad_s"] for e in at_runout]

    def share(shell: str, p: float) -> str:
        cell = [e for e in eps if e["shell_model"] == shell and e["pressure_kpa"] == p]
        return f"{sum(not e['is_success'] for e in cell)} of {len(cell)}"

    low = min(e["pressure_kpa"] for e in eps)
    return (
        f"{len(at_runout)} of the {len(failed)} failed development-grid episodes of its final models reached the run-out in "
        f"the lane and failed on the tracking RMSE alone ({min(rmse):.2f}–{max(rmse):.2f} rad/s), most often on "
        f"the soft shells at {low:g} kPa (injected {share('injected', low)}, hydroelastic "
        f"{share('hydroelastic', low)}; point {share('point', low)})"
    )


#: The study's conditions in the order the page names them, with the words it uses.
STUDY_CONDITIONS = {
    "nominal": "nominal",
    "pressure": "pressure",
    "pressure_faults": "pressure + faults",
    "calibration": "calibration-aware",
    "pressure_faults_4m": "pressure + faults at 4 M steps",
}
#: The seeds the study aims at per condition: 10 for each of the four conditions, 5 (the floor of a
#: training claim) for the 4 M arm, which continues study_faults's runs and costs as much again.
STUDY_SEEDS = {"nominal": 10, "pressure": 10, "pressure_faults": 10, "calibration": 10, "pressure_faults_4m": 5}


@renders("randomization_study")
def randomization_study(res: Results) -> str:
    """The randomization study as it stands, as a list: runs per condition (a retired condition
    marked so) and how many chose the end of their budget, each grid's IQM per compared condition,
    each pair's difference of mean success per grid with what its interval says and whether it can
    show 10 points, and per pair the shells, faults and calibrations by what their difference's interval says
    (:data:`VERDICTS`). Every interval resamples whole runs, paired by seed where the seeds match."""
    s = _summary(res)
    rows = s.get("randomization_study") or []
    retired = {r["condition"]: r["retired"] for r in rows if "retired" in r}
    runs: dict[str, int] = {}
    at_end: dict[str, int] = {}
    for r in s["runs"]:
        if r["method"] in STUDY_RECIPES:
            runs[r["condition"]] = runs.get(r["condition"], 0) + 1
            at_end[r["condition"]] = at_end.get(r["condition"], 0) + chose_budget_end(r)
    counts = ", ".join(
        f"{STUDY_CONDITIONS[c]} {runs.get(c, 0)} of {STUDY_SEEDS[c]}"
        + (f" (retired: {retired[c]})" if c in retired else "")
        for c in STUDY_CONDITIONS
    )
    ends = ", ".join(f"{STUDY_CONDITIONS[c]} {at_end[c]} of {runs[c]}" for c in STUDY_CONDITIONS if c in runs)
    out = [
        f"Finished runs per condition, of the seeds it aims at: {counts}.",
        "Runs whose validation chose the end of their training budget (not past their best when training "
        f"stopped): {ends}.",
    ]
    for grid in GRIDS:
        iqm = [r for r in rows if r["grid"] == grid and "iqm" in r]
        if not iqm:
            continue
        parts = ", ".join(
            f"{STUDY_CONDITIONS[r['condition']]} {percent(r['iqm'])} [{percent(r['iqm_ci'][0])}, "
            f"{percent(r['iqm_ci'][1])}]"
            for r in iqm
        )
        out.append(f"IQM over whole runs on the {GRIDS[grid]}: {parts}.")

    def pair(p: str) -> str:
        a, b = p.split(" − ")
        return f"{STUDY_CONDITIONS[a]} − {STUDY_CONDITIONS[b]}"

    diffs = [r for r in rows if "mean_diff" in r]
    if diffs:
        by_pair: dict[str, list[str]] = {}
        for r in diffs:
            lo, hi = r["mean_diff_ci"]
            by_pair.setdefault(r["pair"], []).append(
                f"{GRIDS[r['grid']]} {100 * r['mean_diff']:+.0f} points [{100 * lo:+.0f}, {100 * hi:+.0f}], "
                f"{r['verdict']}"
            )
        paired = all(r.get("paired_by_seed") for r in diffs)
        out.append(
            "Difference of mean success, first condition minus second [95 % CI over whole runs"
            + (", paired by seed" if paired else "")
            + "], and what the interval says of the first:"
        )
        out += [f"  - {pair(p)}: {'; '.join(v)}." for p, v in by_pair.items()]
        wide = [r for r in diffs if not r["resolves_10_points"]]
        out.append(
            "Every such interval's half-width is under 10 points, so a 10-point difference would show."
            if not wide
            else f"{len(wide)} of {len(diffs)} such intervals are 10 points wide or more on each side, too wide "
            "to show a 10-point difference."
        )
    tasks = s.get("randomization_study_by_task") or []
    if tasks:
        by_task: dict[str, dict[str, list[str]]] = {}
        for r in tasks:
            told = r["verdict"] in ("higher", "lower")
            named = f"{r['task']} {100 * r['mean_diff']:+.0f}" if told else r["task"]
            by_task.setdefault(r["pair"], {}).setdefault(r["verdict"], []).append(named)
        out.append(
            "Per shell, fault and calibration, what each difference's interval says of the first condition (with the "
            "points where it excludes 0; the intervals are in the learning study's README):"
        )
        out += [
            f"  - {pair(p)}: " + "; ".join(f"{v}: {', '.join(by_v[v])}" for v in VERDICTS if v in by_v) + "."
            for p, by_v in by_task.items()
        ]
    else:
        out.append(f"The conditions are compared once two of them have {MIN_STUDY_RUNS} finished runs each.")
    return "\n".join(ln if ln.startswith("  - ") else f"- {ln}" for ln in out)


def _held_out_row(name: str, runs: str, r: dict, pd: dict, margin: float) -> list[str]:
    """One controller's test-set cells; ``r`` has the recipe summary's keys or a baseline's."""
    shells = r.get("per_shell_mean") or r["per_shell"]
    faults = r.get("faults_mean") or r["faults"]
    cals = r.get("calibrations_mean") or r["calibrations"]
    nominal = percent(r.get("mean", r["success_rate"]))
    if "worst_run" in r:
        nominal += f" ({percent(r['worst_run'])})"
    if r is pd:
        return [name, runs, nominal, slash(shells.values(), percent), "", "", slash(cals.values(), percent)]
    gap = {k: faults[k] - pd["faults"][k] for k in faults}
    worst = min(gap, key=lambda k: (gap[k], k))
    held = sum(gap[k] >= -margin - 1e-9 for k in gap)
    return [
        name,
        runs,
        nominal,
        slash(shells.values(), percent),
        f"{held} of {len(gap)}",
        f"{worst} {percent(faults[worst])} ({percent(pd['faults'][worst])})",
        slash((f"{percent(cals[k])} ({percent(pd['calibrations'][k])})" for k in cals)),
    ]


@renders("held_out_table")
def held_out_table(res: Results) -> str:
    h = res.json("learning/held_out.json")
    pd = h["baselines"]["pd"]
    margin = h["aims"]["pd_margin"]
    rows = [
        _held_out_row(f"`{name}`" if name not in ("pd", "zero") else name, "", b, pd, margin)
        for name, b in h["baselines"].items()
    ]
    notes = []
    for name, r in h["recipes"].items():
        rows.append(_held_out_row(f"`{name}`", str(r["runs"]), r, pd, margin))
        aims = r.get("aims", {})
        met = [k.replace("_", " ") for k, ok in aims.items() if ok]
        missed = [k.replace("_", " ") for k, ok in aims.items() if not ok]
        drop = max(r["final_below_chosen_on_validation"])
        crossings = [c for c in r["validation_pd_level_crossing_env_steps"] if c is not None]
        notes.append(
            f"- `{name}` (seeds {', '.join(map(str, r['seeds']))}): nominal mean {percent(r['mean'])}, 95 % CI over "
            f"whole runs {percent(r['mean_ci'][0])}–{percent(r['mean_ci'][1])}; the final model at most "
            f"{100 * drop:.0f} points below the chosen checkpoint on the validation set; "
            f"{len(crossings)} of {r['runs']} runs at PD level on the validation set"
            + (f", after {steps_k(sum(crossings) / len(crossings))} env steps in the mean" if crossings else "")
            + f". Aims met: {', '.join(met) or 'none'}; not met: {', '.join(missed) or 'none'}."
        )
    headers = (
        "controller",
        "runs",
        "nominal: mean (worst run)",
        "point / injected / hydroelastic",
        "faults at or above the PD − 3 points",
        "the fault with the least margin over the PD (the PD)",
        "free_robot / v0_linear (the PD)",
    )
    return table(headers, rows) + "\n\n" + "\n".join(notes)
