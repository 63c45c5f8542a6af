"""Blocks of the speed page's section on Drake's floor, the profile of a chunk and the fast contact
solver: ``benchmark.json`` (floor, profile), ``benchmark_train.json`` (solvers) and
``contact_solver.json``."""

from __future__ import annotations

import math

from sphere_env.evaluation.experiments.benchmark_recipe import FAST_SOLVER
from sphere_env.evaluation.experiments.docs.base import Results, fixed, fixed2, kpa, percent, renders, table, whole

SHELLS = ("point", "injected", "hydroelastic")


def _load(result: dict) -> str:
    return f"1-min load average {result['load_avg_start'][0]:.1f}–{result['load_avg_end'][0]:.1f}"


@renders("floor_table")
def floor_table(res: Results) -> str:
    b = res.json("benchmark.json")
    floor = b["floor"]
    rows = [
        [
            r["contact"],
            r["case"],
            whole(r["chunks_per_s"]),
            fixed2(r["ratio_floor"]),
            fixed2(r["ratio_floor_live"]),
        ]
        for r in floor["rows"]
    ]
    head = (
        f"Commit {floor['commit']}, {floor['repeats']} × {floor['seconds']:g} s per case, "
        f"{_load(floor)} on {b['machine']['cores']} cores.\n\n"
    )
    return head + table(
        ["contact", "case", "20 ms chunks/s", "÷ floor, Drake's default config", "÷ floor, live output ports"],
        rows,
        ["left", "left", "right", "right", "right"],
    )


@renders("floor_figures")
def floor_figures(res: Results) -> str:
    s = res.json("benchmark.json")["floor"]["summary"]
    tamsi = " / ".join(f"×{s['tamsi_over_sap'][m]:.2f}" for m in SHELLS)
    return "\n".join(
        [
            f"- full twin (point, SAP) ÷ Drake's floor: **{fixed2(s['twin_over_floor'])}** against Drake's default "
            f"configuration, {fixed2(s['twin_over_floor_live'])} against the floor with live output ports (the bare "
            f"twin {fixed2(s['bare_over_floor_live'])});",
            f"- TAMSI ÷ the default solver, full twin, point / injected / hydroelastic: **{tamsi}** (Drake's floor, "
            f"point: ×{s['floor_tamsi_over_sap']:.2f});",
            f"- hydroelastic ÷ point, full twin: **{fixed2(s['hydro_over_point'])}** with each model's default "
            f"solver, {fixed2(s['hydro_over_point_tamsi'])} with TAMSI for both (Drake's floors: "
            f"{fixed2(s['hydro_floor_over_point_floor'])}).",
        ]
    )


@renders("chunk_profile")
def chunk_profile(res: Results) -> str:
    p = res.json("benchmark.json")["profile"]
    if not p.get("available"):
        return "(no profile in the last run: Linux `perf` was not available)"
    cases = p["cases"]
    rows = [[label] + [fixed(c["pct"][key]) for c in cases.values()] for key, label in p["labels"].items()]
    rows.append(
        ["… of which SAP's per-solve context allocation"] + [fixed(c["sap_context_pct"]) for c in cases.values()]
    )
    return table(
        ["share of a chunk, %"] + [c["label"] for c in cases.values()],
        rows,
        ["left"] + ["right"] * len(cases),
    )


@renders("solver_accuracy")
def solver_accuracy(res: Results) -> str:
    c = res.json("contact_solver.json")
    traj = c["trajectories"]

    def worst(controller: str) -> dict:
        rs = [r for r in traj if r["controller"] == controller]
        return max(rs, key=lambda r: r["rmse_rad_s"])

    def rmse_span(controller: str) -> str:
        vals = sorted(r["rmse_rad_s"] for r in traj if r["controller"] == controller)
        return f"{vals[0]:.3f}–{vals[-1]:.3f}"

    lines = []
    for controller, name in (("pd", "the PD"), ("zero", "zero torque")):
        w = worst(controller)
        flips = sum(r["success_reference"] != r["success_fast"] for r in traj if r["controller"] == controller)
        lines.append(
            f"- ramp descent under {name} (point and injected, 3 / 8.5 / 14 kPa, seeds "
            f"{', '.join(map(str, c['seeds']))}): ω_d RMSE between the solvers {rmse_span(controller)} rad/s; the "
            f"largest, {w['rmse_rad_s']:.3f} rad/s (max |Δω_d| {w['max_abs_diff_rad_s']:.2f} rad/s against a peak of "
            f"{w['peak_rad_s']:.2f}), is the {w['shell_model']} shell at {kpa(w['pressure_kpa'])} kPa, seed "
            f"{w['seed']}; outcomes differing: {flips};"
        )
    g = c["grid"]
    ref, fast = g["reference"], g["fast"]

    def shells(f: dict) -> str:
        return " / ".join(f"{100 * f['per_shell'][s]:.0f}" for s in SHELLS)

    lines.append(
        f"- the PD on the grid ({ref['episodes']} episodes): success {100 * ref['success_rate']:.0f} % under the "
        f"reference, {100 * fast['success_rate']:.0f} % under TAMSI (point / injected / hydroelastic "
        f"{shells(ref)} % against {shells(fast)} %), tracking RMSE "
        f"{ref['tracking_rmse_rad_s']:.3f} against {fast['tracking_rmse_rad_s']:.3f} rad/s; cells whose outcome "
        f"differs: {len(g['differing_cells'])};"
    )
    rep = c["replays"]
    if rep.get("available"):
        for shell in SHELLS:
            rs = [r for r in rep["rows"] if r["shell_model"] == shell]
            between = max(r["rmse_between_solvers"].get("phi", math.nan) for r in rs)
            delta = max(abs(r["rmse_vs_log_fast"]["phi"] - r["rmse_vs_log_reference"]["phi"]) for r in rs)
            worst_row = max(rs, key=lambda r: r["rmse_between_solvers"].get("phi", 0.0))
            lines.append(
                f"- free-motion replays of the real logs, {shell} ({len(rs)} windows): φ between the solvers at most "
                f"{between:.3f} rad ({worst_row['trial']}); φ RMSE against the log moves by at most {delta:.3f} rad;"
            )
    else:
        lines.append("- free-motion replays: not run (the real logs were absent);")
    lines[-1] = lines[-1].rstrip(";") + "."
    return "\n".join(lines)


def _solver_line(t: dict, commit: str) -> str:
    ref, fast = t["rows"]
    r = t["ratio"]
    return (
        f"{whole(ref['train_steps_per_s'])} → **{whole(fast['train_steps_per_s'])} env steps/s** "
        f"(×{r['train_steps_per_s']:.2f}; rollout ×{r['rollout_steps_per_s']:.2f}, single env "
        f"×{r['single_env_steps_per_s']:.2f}), {t['env_id'].split('/')[-1]}, {ref['steps']:,} + {fast['steps']:,} env "
        f"steps timed, commit {commit}, {_load(t)}"
    )


@renders("solver_training")
def solver_training(res: Results) -> str:
    bench = res.json("benchmark.json")
    alone = res.json("benchmark_train.json")["solvers"]
    return (
        f"- `make bench` (`evaluation/results/benchmark.md`, the run of the floor and the profile above): "
        f"{_solver_line(bench['train']['solvers'], bench['machine']['commit'])};\n"
        f"- the training benchmark alone (`evaluation/results/benchmark_train.md`): "
        f"{_solver_line(alone, alone['machine']['commit'])}"
    )


@renders("tamsi_policy")
def tamsi_policy(res: Results) -> str:
    """The recipes trained with the fast solver, as the test set judges them under the reference one."""
    from sphere_env.evaluation.experiments.learning import load_recipes

    recipes = load_recipes()
    h = res.json("learning/held_out.json")
    pd = h["baselines"]["pd"]["success_rate"]
    lines = []
    for name, r in h["recipes"].items():
        if recipes[name].get("env_kwargs", {}).get("contact_approximation") != FAST_SOLVER:
            continue
        aims = r.get("aims", {})
        lines.append(
            f"- `{name}`, trained with {FAST_SOLVER.upper()}, evaluated under SAP on the test set over {r['runs']} "
            f"run{'s' if r['runs'] != 1 else ''}: nominal mean {percent(r['mean'])} (worst run "
            f"{percent(r['worst_run'])}; the PD {percent(pd)}); test-set aims met "
            f"{sum(aims.values())} of {len(aims)} (not met: {', '.join(k for k, ok in aims.items() if not ok) or 'none'})"
        )
    return "\n".join(lines) or "- no recipe trained with the fast solver has test-set figures yet"
