"""TAMSI against the reference contact solver: how far the fast training setting moves the physics.

The reference is each shell model's default (``sap`` for point and injected contact, ``lagged``
for hydroelastic); the fast setting is ``contact_approximation="tamsi"``. Three comparisons:

* **ramp trajectories**: RampDescent-v3 episodes (the learning env, nothing randomized) under zero
  torque and under the PD baseline, point and injected shells at 3, 8.5 and 14 kPa, evaluation
  seeds; per cell the RMSE between the two solvers' ω_d trajectories over the samples both
  episodes have, the largest |Δω_d|, and the episode lengths and outcomes;
* **free-motion replays**: the real logs' free windows (steer_free on the steer plane with the
  shipped calibration, free_robot on the free base with the ``free_robot`` calibration) replayed
  by every shell model under both solvers, as ``python -m sphere_env.calibration validate`` replays
  them; the RMSE of each against the log and between the two simulations (logs read from
  ``../shared/data/roboball``; the section is skipped when they are absent);
* **the PD on the grid**: success and tracking RMSE of the PD over the nominal grid (3 shells ×
  3, 8.5, 14 kPa × seeds 0, 1, 2) with the env under each solver.

    python -m evaluation.experiments.contact_solver [--workers 2] [--skip-replays]

writes ``evaluation/results/contact_solver.{json,md}``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from sphere_env.evaluation.faults import PRESSURES_KPA, SEEDS, SHELLS, grid_jobs

ENV_ID = "sphere_env/RampDescent-v3"  # the learning env (evaluation.experiments.learning)
FAST = "tamsi"
RIGID = ("point", "injected")
MANIFEST = Path(__file__).resolve().parents[2] / "assets" / "logs" / "roboball.yaml"
#: Replayed log groups and the calibration each is validated with.
REPLAY_GROUPS = {"steer_free": None, "free_robot": "free_robot"}
REPLAY_CHANNELS = ("phi", "theta", "omega_d", "pendulum_pitch")


def _solver_kwargs(solver: str) -> dict[str, Any]:
    return {} if solver == "reference" else {"contact_approximation": FAST}


def episode_jobs(seeds: Sequence[int] = SEEDS) -> list[dict[str, Any]]:
    """Every episode of the study, each under the reference and the fast solver (``solver`` key):
    the zero torque on the rigid shells, the PD on the whole grid."""
    jobs = []
    for solver in ("reference", "fast"):
        kw = _solver_kwargs(solver)
        for job in grid_jobs("zero", "zero", ENV_ID, kw, RIGID, PRESSURES_KPA, seeds):
            jobs.append(job | {"solver": solver})
        for job in grid_jobs("pd", "pd", ENV_ID, kw, SHELLS, PRESSURES_KPA, seeds):
            jobs.append(job | {"solver": solver})
    return jobs


#: |Δω_d| [rad/s] past which two episodes count as apart (a tenth of the task's tracking tolerance).
APART_RAD_S = 0.05
CONTROL_PERIOD_S = 0.02


def compare_traces(ref: np.ndarray, fast: np.ndarray) -> dict[str, float]:
    """ω_d of two episodes [rad/s] sampled every control step: RMSE and largest |difference| over
    the samples both have, when |Δω_d| first exceeds :data:`APART_RAD_S` [s] (NaN: never), the
    reference's peak |ω_d|, and the compared sample count."""
    n = min(len(ref), len(fast))
    d = fast[:n] - ref[:n]
    apart = np.flatnonzero(np.abs(d) > APART_RAD_S)
    return {
        "apart_after_s": float((apart[0] + 1) * CONTROL_PERIOD_S) if len(apart) else math.nan,
        "rmse_rad_s": float(np.sqrt(np.mean(d**2))) if n else math.nan,
        "max_abs_diff_rad_s": float(np.max(np.abs(d))) if n else math.nan,
        "peak_rad_s": float(np.max(np.abs(ref))) if len(ref) else math.nan,
        "compared_samples": n,
    }


def trajectory_table(results: list[tuple[dict, dict, dict]]) -> list[dict[str, Any]]:
    """Per (controller, shell, pressure, seed): the ω_d comparison of the two solvers' episodes
    and each episode's length and success."""
    by = {}
    for job, row, trace in results:
        key = (job["controller"], job["shell_model"], job["pressure_kpa"], job["seed"])
        by.setdefault(key, {})[job["solver"]] = (row, trace)
    out = []
    for (controller, shell, p, seed), pair in sorted(by.items()):
        if controller == "pd" and shell not in RIGID:
            continue
        (r_ref, t_ref), (r_fast, t_fast) = pair["reference"], pair["fast"]
        out.append(
            dict(
                controller=controller,
                shell_model=shell,
                pressure_kpa=p,
                seed=seed,
                **compare_traces(t_ref["omega_d"], t_fast["omega_d"]),
                length_reference=int(r_ref["length"]),
                length_fast=int(r_fast["length"]),
                success_reference=bool(r_ref["is_success"]),
                success_fast=bool(r_fast["is_success"]),
            )
        )
    return out


def grid_summary(results: list[tuple[dict, dict, dict]]) -> dict[str, Any]:
    """The PD's grid figures (success, tracking RMSE, per shell) under each solver, and the cells
    whose outcome differs."""
    from sphere_env.evaluation.experiments.learning import grid_figures

    rows = {
        s: [r for j, r, _ in results if j["controller"] == "pd" and j["solver"] == s] for s in ("reference", "fast")
    }
    key = lambda r: (r["shell_model"], r["pressure_kpa"], r["seed"])  # noqa: E731
    ref = {key(r): bool(r["is_success"]) for r in rows["reference"]}
    flips = [
        dict(shell_model=k[0], pressure_kpa=k[1], seed=k[2], reference=ref[k], fast=bool(r["is_success"]))
        for r in rows["fast"]
        if ref[(k := key(r))] != bool(r["is_success"])
    ]
    return {"reference": grid_figures(rows["reference"]), "fast": grid_figures(rows["fast"]), "differing_cells": flips}


def _episode(job: dict) -> tuple[dict, dict, dict]:
    from sphere_env.evaluation.cells import rollout

    row, trace = rollout(job)
    return job, row, {"omega_d": trace["omega_d"]}


def run_episodes(seeds: Sequence[int] = SEEDS, workers: int = 2) -> list[tuple[dict, dict, dict]]:
    from sphere_env.parallel import run_parallel

    return run_parallel(_episode, episode_jobs(seeds), workers=workers)


def _rmse(a: np.ndarray, b: np.ndarray) -> float:
    ok = np.isfinite(a) & np.isfinite(b)
    return float(np.sqrt(np.mean((a[ok] - b[ok]) ** 2))) if ok.any() else math.nan


def run_replays(data_root: Path | None = None, models: Sequence[str] = SHELLS) -> dict[str, Any]:
    """The free-motion windows replayed under both solvers (module docstring); ``{"available":
    False}`` without the logs."""
    from sphere_env.calibration.manifest import load_manifest
    from sphere_env.calibration.validate import validate_log
    from sphere_env.physics import Twin, TwinConfig

    man = load_manifest(MANIFEST, data_root)
    if not man.available():
        return {"available": False, "data_root": str(man.data_root)}
    rows = []
    for group, calibration in REPLAY_GROUPS.items():
        logs = [spec.load() for spec in man.group(group)]
        for model in models:
            twins: dict[tuple, Any] = {}
            for log in logs:
                val = {}
                for solver in ("reference", "fast"):
                    key = (log.fixture, log.pressure_kpa, solver)
                    if key not in twins:
                        twins[key] = Twin(
                            TwinConfig(
                                fixture=log.fixture or "free",
                                shell_model=model,
                                calibration=calibration,
                                pressure_kpa=log.pressure_kpa,
                                **_solver_kwargs(solver),
                            )
                        )
                    val[solver] = validate_log(twins[key], log)
                ref, fast = val["reference"], val["fast"]
                between = {
                    ch: _rmse(ref.trace[ch], fast.trace[ch])
                    for ch in REPLAY_CHANNELS
                    if ch in ref.trace.channels and ch in fast.trace.channels
                }
                rows.append(
                    dict(
                        group=group,
                        calibration=calibration or "default",
                        trial=log.name,
                        fixture=ref.fixture,
                        shell_model=model,
                        rmse_vs_log_reference={k: v for k, v in ref.rmse.items() if math.isfinite(v)},
                        rmse_vs_log_fast={k: v for k, v in fast.rmse.items() if math.isfinite(v)},
                        rmse_between_solvers=between,
                    )
                )
    return {"available": True, "rows": rows}


def _f(x: float, fmt: str = "{:.3f}") -> str:
    return "—" if x is None or not math.isfinite(x) else fmt.format(x)


def _pct(x: float) -> str:
    return f"{100 * x:.0f}%"


def report_markdown(result: dict[str, Any]) -> str:
    from sphere_env.reporting import markdown_table

    m = result["machine"]
    lines = [
        "# TAMSI against the reference contact solver",
        "",
        f"Generated by `python -m evaluation.experiments.contact_solver` (commit {m['commit']}, drake {m['drake']}); "
        f"runtime {result['runtime_s']:.0f} s, 1-min load average {result['load_avg_start'][0]:.1f} at the start. "
        "Reference: each shell model's default solver (`sap` for point and injected contact, `lagged` for "
        f'hydroelastic); fast: `contact_approximation="{FAST}"`. Env `{ENV_ID}`, nothing randomized.',
        "",
        "## Ramp descent: ω_d of the two solvers' episodes",
        "",
        "Per controller, shell and pressure over seeds "
        f"{', '.join(str(s) for s in result['seeds'])}: the RMSE between the ω_d trajectories (mean over seeds; "
        "samples both episodes have), the largest |Δω_d| (over seeds), the reference's peak |ω_d|, and the "
        "episodes whose outcome (success) differs.",
        "",
    ]
    cells: dict[tuple, list[dict]] = {}
    for r in result["trajectories"]:
        cells.setdefault((r["controller"], r["shell_model"], r["pressure_kpa"]), []).append(r)
    rows = []
    for (controller, shell, p), rs in cells.items():
        rows.append(
            {
                "controller": controller,
                "shell": shell,
                "p": f"{p:g}",
                "rmse": _f(float(np.mean([r["rmse_rad_s"] for r in rs]))),
                "max": _f(max(r["max_abs_diff_rad_s"] for r in rs)),
                "peak": _f(max(r["peak_rad_s"] for r in rs), "{:.2f}"),
                "apart": _f(
                    min([r["apart_after_s"] for r in rs if math.isfinite(r["apart_after_s"])] or [math.nan]), "{:.2f}"
                ),
                "len": ", ".join(f"{r['length_reference']}/{r['length_fast']}" for r in rs),
                "flips": str(sum(r["success_reference"] != r["success_fast"] for r in rs)),
            }
        )
    lines.append(
        markdown_table(
            rows,
            [
                ("controller", "controller", ""),
                ("shell", "shell", ""),
                ("p", "kPa", ""),
                ("rmse", "ω_d RMSE rad/s", ""),
                ("max", "max |Δω_d| rad/s", ""),
                ("peak", "peak |ω_d| rad/s", ""),
                ("apart", f"first |Δω_d| > {APART_RAD_S:g} rad/s, s (— never)", ""),
                ("len", "steps reference/fast per seed", ""),
                ("flips", "outcome differs", ""),
            ],
        )
    )
    g = result["grid"]
    lines += ["", "## The PD on the grid", ""]
    grid_rows = []
    for solver, label in (("reference", "reference (sap; lagged for hydroelastic)"), ("fast", FAST)):
        f = g[solver]
        grid_rows.append(
            {
                "solver": label,
                "success": _pct(f["success_rate"]),
                "shells": " / ".join(_pct(f["per_shell"][s]) for s in SHELLS),
                "rmse": _f(f["tracking_rmse_rad_s"]),
            }
        )
    lines.append(
        markdown_table(
            grid_rows,
            [
                ("solver", "env solver", ""),
                ("success", f"success ({g['reference']['episodes']} episodes)", ""),
                ("shells", " / ".join(SHELLS), ""),
                ("rmse", "tracking RMSE rad/s", ""),
            ],
        )
    )
    flips = g["differing_cells"]
    lines += [
        "",
        "Cells whose outcome differs: "
        + (
            ", ".join(
                f"{c['shell_model']} {c['pressure_kpa']:g} kPa seed {c['seed']} "
                f"({'won' if c['reference'] else 'lost'} → {'won' if c['fast'] else 'lost'})"
                for c in flips
            )
            or "none"
        )
        + ".",
        "",
        "## Free-motion replays of the real logs",
        "",
    ]
    rep = result["replays"]
    if not rep.get("available"):
        lines.append(f"Skipped: the real logs were not found at {rep.get('data_root')}.")
    else:
        lines += [
            "RMSE against the log under the reference and the fast solver (rad, rad/s), and between the two "
            "simulations. φ pipe angle, θ steer angle, α pendulum pitch (free windows).",
            "",
        ]
        rrows = []
        for r in rep["rows"]:
            a, b, d = r["rmse_vs_log_reference"], r["rmse_vs_log_fast"], r["rmse_between_solvers"]
            chans = [c for c in REPLAY_CHANNELS if c in a and c in b]
            rrows.append(
                {
                    "trial": f"{r['trial']} ({r['calibration']})",
                    "shell": r["shell_model"],
                    "ref": ", ".join(f"{c} {_f(a[c])}" for c in chans),
                    "fast": ", ".join(f"{c} {_f(b[c])}" for c in chans),
                    "between": ", ".join(f"{c} {_f(d[c])}" for c in chans if c in d),
                }
            )
        lines.append(
            markdown_table(
                rrows,
                [
                    ("trial", "window (calibration)", ""),
                    ("shell", "shell", ""),
                    ("ref", "vs log, reference", ""),
                    ("fast", f"vs log, {FAST}", ""),
                    ("between", "reference vs fast", ""),
                ],
            )
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    from sphere_env.evaluation.experiments import RESULTS
    from sphere_env.files import write_text_atomic
    from sphere_env.provenance import machine_info

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--workers", type=int, default=2, help="processes for the episodes")
    parser.add_argument("--seeds", type=int, nargs="+", default=list(SEEDS), help="evaluation seeds")
    parser.add_argument("--skip-replays", action="store_true", help="leave out the real-log replays")
    parser.add_argument("--data-root", type=Path, default=None, help="the real logs (default: the manifest's)")
    parser.add_argument("--no-write", action="store_true", help="print only")
    args = parser.parse_args(argv)

    t0, load0 = time.perf_counter(), os.getloadavg()
    episodes = run_episodes(args.seeds, args.workers)
    replays = {"available": False, "data_root": "skipped (--skip-replays)"} if args.skip_replays else None
    if replays is None:
        replays = run_replays(args.data_root)
    result = {
        "machine": machine_info(),
        "env_id": ENV_ID,
        "fast": FAST,
        "seeds": list(args.seeds),
        "load_avg_start": load0,
        "runtime_s": time.perf_counter() - t0,
        "trajectories": trajectory_table(episodes),
        "grid": grid_summary(episodes),
        "replays": replays,
    }
    text = report_markdown(result)
    print(text)
    if not args.no_write:
        write_text_atomic(RESULTS / "contact_solver.md", text)
        write_text_atomic(RESULTS / "contact_solver.json", json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
