"""What pressure randomization buys: PPO trained with and without it, evaluated across pressures.

Two training conditions, the same budget and hyperparameters (``training/hyperparams/ppo.yml``),
``--seeds`` training seeds each:

* ``randomized``: the inflation pressure drawn uniformly over the calibrated range at every reset
  (the shipped configuration);
* ``nominal``: the pressure fixed at the calibration's nominal value.

Every trained policy is evaluated with randomization off on ``--pressures`` [kPa] × the three
shell models × ``--eval-seeds``. Per condition and pressure the study reports the mean success
rate over training seeds with a 95 % bootstrap confidence interval across training seeds
(``scipy.stats.bootstrap``, percentile method; with three seeds the interval is coarse), and the
worst case: the success rate of the worst training seed at that pressure.

    python -m evaluation.experiments.randomization_study [--train-steps 200000] [--seeds 0 1 2]
        [--out out/randomization_study] [--publish]

Writes into ``--out``: ``runs/<condition>_s<seed>/`` (training run folders), ``eval/`` (the
evaluation sweep), ``study.csv`` (one row per condition × pressure), ``per_seed.csv`` (one row per
condition × training seed × pressure), ``study.md`` and ``study.png``. ``--publish`` copies the
last three into ``evaluation/results/randomization_study/``.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import shutil
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from sphere_env.files import write_text_atomic

ENV_ID = "sphere_env/RampDescent-v2"
CONDITIONS = ("randomized", "nominal")
PUBLISH = Path(__file__).resolve().parents[1] / "results" / "randomization_study"
DEFAULT_TRAIN_STEPS = 200_000


def condition_overrides(condition: str, nominal_kpa: float) -> dict[str, Any]:
    """Hyperparameter overrides of a condition: only the pressure randomization differs."""
    from sphere_env.resources import hyperparams_path
    from sphere_env.training.config import load_section

    section = load_section(hyperparams_path("ppo"), ENV_ID)
    kwargs = dict(section.get("env_kwargs") or {})
    pressure = {"distribution": "uniform"} if condition == "randomized" else nominal_kpa
    if "randomization" in section:  # the spec at the top level of the section
        return {"randomization": {"pressure_kpa": pressure}}
    return {"env_kwargs": {**kwargs, "randomization": {"pressure_kpa": pressure}}}


def bootstrap_ci(values: Sequence[float], confidence: float = 0.95) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of ``values`` (NaN-free); the value itself when
    all are equal or there is only one."""
    from scipy.stats import bootstrap

    v = np.asarray(values, float)
    if len(v) < 2 or np.all(v == v[0]):
        return float(v.mean()), float(v.mean())
    res = bootstrap(
        (v,),
        np.mean,
        confidence_level=confidence,
        method="percentile",
        n_resamples=2000,
        random_state=np.random.default_rng(0),
    )
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def summarize(rows: Sequence[dict[str, Any]]) -> tuple[list[dict], list[dict]]:
    """(per condition × pressure, per condition × training seed × pressure) from episode rows whose
    ``controller`` is ``<condition>_s<seed>``."""
    per_seed: dict[tuple[str, int, float], list[bool]] = {}
    for r in rows:
        cond, _, seed = r["controller"].rpartition("_s")
        per_seed.setdefault((cond, int(seed), float(r["pressure_kpa"])), []).append(bool(r["is_success"]))
    seed_rows = [
        {"condition": c, "train_seed": s, "pressure_kpa": p, "episodes": len(v), "success_rate": float(np.mean(v))}
        for (c, s, p), v in sorted(per_seed.items())
    ]
    out = []
    for cond in CONDITIONS:
        for p in sorted({r["pressure_kpa"] for r in seed_rows if r["condition"] == cond}):
            rates = [r["success_rate"] for r in seed_rows if r["condition"] == cond and r["pressure_kpa"] == p]
            lo, hi = bootstrap_ci(rates)
            out.append(
                {
                    "condition": cond,
                    "pressure_kpa": p,
                    "train_seeds": len(rates),
                    "mean_success": float(np.mean(rates)),
                    "ci95_low": lo,
                    "ci95_high": hi,
                    "worst_seed_success": float(np.min(rates)),
                }
            )
    return out, seed_rows


def _csv_text(rows: Sequence[dict[str, Any]]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
    return buf.getvalue()


def plot(summary: Sequence[dict[str, Any]], path: Path) -> Path:
    from sphere_env.plotting import pyplot, save_figure

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for cond, color in zip(CONDITIONS, ("tab:blue", "tab:orange")):
        rs = [r for r in summary if r["condition"] == cond]
        p = [r["pressure_kpa"] for r in rs]
        ax.plot(p, [r["mean_success"] for r in rs], "o-", color=color, label=f"{cond}: mean over training seeds")
        ax.fill_between(p, [r["ci95_low"] for r in rs], [r["ci95_high"] for r in rs], color=color, alpha=0.2)
        ax.plot(p, [r["worst_seed_success"] for r in rs], "v--", color=color, alpha=0.8, label=f"{cond}: worst seed")
    ax.set_xlabel("inflation pressure [kPa]")
    ax.set_ylabel("success rate (3 shell models × eval seeds)")
    ax.set_ylim(-0.03, 1.03)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(
        f"{ENV_ID}: PPO trained with / without pressure randomization\n(band: 95 % bootstrap CI across training seeds)",
        fontsize=9,
    )
    tmp = path.with_name(path.stem + ".tmp.png")
    save_figure(fig, tmp)
    tmp.replace(path)
    return path


def report(summary, seed_rows, args, timings: dict[str, float]) -> str:
    from sphere_env.evaluation.reporting import machine_info
    from sphere_env.reporting import markdown_table

    info = machine_info()
    cols = [
        ("condition", "training", ""),
        ("pressure_kpa", "pressure kPa", "{:g}"),
        ("mean_success", "mean success", "{:.0%}"),
        ("ci95_low", "95 % CI low", "{:.0%}"),
        ("ci95_high", "95 % CI high", "{:.0%}"),
        ("worst_seed_success", "worst seed", "{:.0%}"),
    ]
    overall = {c: float(np.mean([r["success_rate"] for r in seed_rows if r["condition"] == c])) for c in CONDITIONS}
    worst = {c: float(np.min([r["success_rate"] for r in seed_rows if r["condition"] == c])) for c in CONDITIONS}
    lines = [
        "# What pressure randomization buys",
        "",
        f"`python -m evaluation.experiments.randomization_study --train-steps {args.train_steps} --seeds "
        f"{' '.join(map(str, args.seeds))}` on `{ENV_ID}`; commit {info['commit']}, {info['cpu']}, {info['cores']} cores.",
        "",
        f"PPO (`training/hyperparams/ppo.yml`, injected shell) trained {args.train_steps} env steps per run, "
        f"training seeds {args.seeds}: **randomized** = pressure uniform over the calibrated range at every reset, "
        f"**nominal** = pressure fixed at {timings['nominal_kpa']:g} kPa. Evaluated with randomization off at "
        f"{', '.join(f'{p:g}' for p in args.pressures)} kPa × point/injected/hydroelastic × eval seeds "
        f"{args.eval_seeds}. Success as defined by the task (reach the run-out in the lane, tracking RMSE ≤ the "
        "tolerance after settling).",
        "",
        markdown_table(summary, cols),
        "",
        "Over all pressures: "
        + "; ".join(f"{c} {overall[c]:.0%} mean, worst seed × pressure {worst[c]:.0%}" for c in CONDITIONS)
        + ".",
        "",
        "Per training seed (success rate over shell models × eval seeds):",
        "",
        markdown_table(
            seed_rows,
            [
                ("condition", "training", ""),
                ("train_seed", "seed", "{}"),
                ("pressure_kpa", "pressure kPa", "{:g}"),
                ("success_rate", "success", "{:.0%}"),
            ],
        ),
        "",
        f"Wall time: training {timings['train_s'] / 60:.1f} min, evaluation {timings['eval_s'] / 60:.1f} min.",
        "",
        "![success vs pressure](study.png)",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--train-steps", type=int, default=DEFAULT_TRAIN_STEPS, help="PPO env steps per run")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="training seeds per condition")
    parser.add_argument("--eval-seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument(
        "--pressures",
        type=float,
        nargs="+",
        default=None,
        help="evaluation pressures [kPa] (default: 5 points over the calibrated range)",
    )
    parser.add_argument("--out", type=Path, default=Path("out/randomization_study"))
    parser.add_argument("--workers", type=int, default=None, help="evaluation processes (default: all cores)")
    parser.add_argument("--publish", action="store_true", help=f"copy study.md/.csv/.png to {PUBLISH}")
    args = parser.parse_args(argv)

    from sphere_env.evaluation.evaluate import SweepSpec, evaluate
    from sphere_env.models.shell import ShellCalibration
    from sphere_env.training.config import resolve_config
    from sphere_env.training.train import train

    cal = ShellCalibration.load()
    lo, hi = cal.pressure_range_kpa
    if args.pressures is None:
        args.pressures = [float(x) for x in np.round(np.linspace(lo, hi, 5), 3)]
    # ---- validate everything before anything runs or is written ----
    if args.train_steps < 1:
        parser.error(f"--train-steps: value {args.train_steps} must be >= 1")
    for name in ("seeds", "eval_seeds"):
        vals = getattr(args, name)
        if any(s < 0 for s in vals) or len(set(vals)) != len(vals):
            parser.error(f"--{name.replace('_', '-')}: values {vals} must be distinct integers >= 0")
    for p in args.pressures:
        if not (math.isfinite(p) and lo <= p <= hi):
            parser.error(f"--pressures: {p} kPa outside the calibrated range [{lo:g}, {hi:g}] kPa")
    if args.out.exists() and not args.out.is_dir():
        parser.error(f"--out: {args.out} exists and is not a folder")
    configs = {}
    for cond in CONDITIONS:
        for seed in args.seeds:
            configs[(cond, seed)] = resolve_config(
                ENV_ID,
                "ppo",
                overrides={"n_timesteps": args.train_steps, **condition_overrides(cond, cal.nominal_pressure_kpa)},
                seed=seed,
                eval_freq=max(args.train_steps // 4, 1),
                eval_episodes=3,
                checkpoint_freq=max(args.train_steps // 2, 1),
            )
    # ---- train ----
    runs_dir = args.out / "runs"
    t0 = time.perf_counter()
    runs = {}
    for (cond, seed), cfg in configs.items():
        run = runs_dir / f"{cond}_s{seed}"
        if (run / "model.zip").exists():  # a finished run of an interrupted study is reused
            print(f"[train] {cond} seed {seed}: reusing {run}", flush=True)
        else:
            if run.exists():
                shutil.rmtree(run)
            print(f"[train] {cond} seed {seed}: {args.train_steps} steps -> {run}", flush=True)
            train(cfg, run, progress_bar=False, command=["python", "-m", "evaluation.experiments.randomization_study"])
        runs[(cond, seed)] = run
    t_train = time.perf_counter() - t0
    # ---- evaluate ----
    t0 = time.perf_counter()
    spec = SweepSpec(
        controllers=[f"{c}_s{s}={run}" for (c, s), run in runs.items()],
        env_id=ENV_ID,
        pressures_kpa=args.pressures,
        seeds=args.eval_seeds,
    )
    res = evaluate(spec, args.out / "eval", workers=args.workers, plots=False, progress=True)
    t_eval = time.perf_counter() - t0
    summary, seed_rows = summarize(res["rows"])
    timings = {"train_s": t_train, "eval_s": t_eval, "nominal_kpa": cal.nominal_pressure_kpa}
    write_text_atomic(args.out / "study.csv", _csv_text(summary))
    write_text_atomic(args.out / "per_seed.csv", _csv_text(seed_rows))
    plot(summary, args.out / "study.png")
    write_text_atomic(args.out / "study.md", report(summary, seed_rows, args, timings))
    write_text_atomic(
        args.out / "study.json",
        json.dumps({"summary": summary, "per_seed": seed_rows, "timings": timings}, indent=2) + "\n",
    )
    print((args.out / "study.md").read_text())
    if args.publish:
        PUBLISH.mkdir(parents=True, exist_ok=True)
        for f in ("study.md", "study.csv", "per_seed.csv", "study.png"):
            shutil.copy(args.out / f, PUBLISH / f)
        print(f"published: {PUBLISH}")
    return {"summary": summary, "per_seed": seed_rows}


if __name__ == "__main__":
    main()
