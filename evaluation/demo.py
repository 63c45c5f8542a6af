"""`make demo`: the project's main job on its default configuration, end to end.

1. Train two PPO policies on ``sphere_env/RampDescent-v2`` (injected shell, Majd friction) with the
   inflation pressure randomized uniformly over the calibrated range at every reset, the same budget
   each (``--train-steps``):

   * ``ppo``: from scratch (training/hyperparams/ppo.yml);
   * ``ppo_residual``: a residual over the tuned PD baseline (training/hyperparams/ppo_residual.yml,
     :class:`sphere_env.wrappers.PDResidualAction`): what PPO adds to a working controller.
2. Evaluate both against the baselines — zero torque (the paper's uncontrolled descent) and the tuned
   PD controller — at the low, middle and high calibrated pressures (3, 8.5, 14 kPa) × all three
   shell models × 3 seeds, randomization off.
3. Write ``summary.json`` into the output folder (per controller: ``success_rate``,
   ``reached_runout_rate``, ``mean_return`` and ``tracking_rmse_rad_s`` over the whole grid, plus
   timings) and print where the run folders, report, plots and Meshcat replays are.

    python -m evaluation.demo [--train-steps 200000] [--out out/demo] [--publish]

``--publish`` copies the report and plots into ``evaluation/results/demo/`` (what the README shows).
The uncontrolled-descent table of ``python -m evaluation.scripts.uncontrolled_descent`` is still
available on its own.
"""

from __future__ import annotations

import argparse
import json
import shutil
import time
from pathlib import Path

from sphere_env.files import write_text_atomic
from sphere_env.resources import hyperparams_path

ENV_ID = "sphere_env/RampDescent-v2"
DEFAULT_TRAIN_STEPS = 200_000
PUBLISH = Path(__file__).resolve().parent / "results" / "demo"
RESIDUAL_YAML = hyperparams_path("ppo_residual")


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--train-steps", type=int, default=DEFAULT_TRAIN_STEPS, help="PPO env steps")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="evaluation seeds")
    parser.add_argument("--out", type=Path, default=Path("out/demo"), help="evaluation output folder")
    parser.add_argument("--run-dir", type=Path, default=None,
                        help="training run folder of ppo (default runs/demo_<time>); ppo_residual's gets '_residual'")
    parser.add_argument("--workers", type=int, default=None, help="evaluation processes (default: all cores)")
    parser.add_argument("--publish", action="store_true", help="copy report and plots to evaluation/results/demo/")
    args = parser.parse_args(argv)

    t_start = time.perf_counter()
    from sphere_env.models.shell import ShellCalibration
    from sphere_env.training.config import resolve_config
    from sphere_env.training.train import train

    from sphere_env.evaluation.evaluate import SweepSpec, evaluate

    cal = ShellCalibration.load()
    lo, hi = cal.pressure_range_kpa
    pressures = [lo, round((lo + hi) / 2, 3), hi]  # 3, 8.5, 14 kPa: both ends and the middle
    n = args.train_steps
    stamp = time.strftime('%Y%m%d-%H%M%S')
    base_dir = args.run_dir or Path("runs") / f"demo_{stamp}"
    policies = {"ppo": (None, base_dir), "ppo_residual": (RESIDUAL_YAML, base_dir.with_name(base_dir.name + "_residual"))}
    t_train, timings = {}, {}
    for k, (label, (yaml_file, run_dir)) in enumerate(policies.items(), start=1):
        print(f"[1/3] Training {label} ({k}/{len(policies)}) on {ENV_ID} for {n} env steps, "
              f"pressure ~ U[{lo:g}, {hi:g}] kPa per episode ...", flush=True)
        cfg = resolve_config(ENV_ID, "ppo", yaml_file, overrides={"n_timesteps": n}, seed=args.seed,
                             eval_freq=max(n // 6, 1), eval_episodes=6, checkpoint_freq=max(n // 3, 1))
        t0 = time.perf_counter()
        train(cfg, run_dir, progress_bar=True, command=["python", "-m", "evaluation.demo"])
        t_train[label] = time.perf_counter() - t0
        timings[label] = json.loads((run_dir / "timing.json").read_text())

    print(f"[2/3] Evaluating {', '.join(policies)} vs zero torque vs PD: pressures {pressures} kPa x "
          f"point/injected/hydroelastic x seeds {args.seeds} ...", flush=True)
    spec = SweepSpec(controllers=["zero", "pd"] + [f"{label}={d}" for label, (_, d) in policies.items()], env_id=ENV_ID,
                     pressures_kpa=pressures, seeds=args.seeds)
    t0 = time.perf_counter()
    trained = "; ".join(
        f"{label} trained {timings[label]['num_timesteps']} env steps in {t_train[label]:.0f} s "
        f"({timings[label]['steps_per_s']:.0f} env steps/s), run folder `{d}`" for label, (_, d) in policies.items())
    res = evaluate(spec, args.out, workers=args.workers,
                   replays=[f"ppo,hydroelastic,{pressures[1]}", f"zero,hydroelastic,{pressures[1]}"],
                   progress=True, extra_report=f"Policies: {trained}.")
    t_eval = time.perf_counter() - t0
    wall = time.perf_counter() - t_start

    from sphere_env.evaluation.reporting import markdown_table

    agg = {a["controller"]: a for a in res["agg_controller"]}
    cols = [("controller", "controller", ""), ("success_rate", "success", "{:.0%}"),
            ("reached_runout_rate", "reached run-out", "{:.0%}"), ("return", "mean return", "{:.2f}"),
            ("tracking_rmse_rad_s", "tracking RMSE rad/s", "{:.2f}"), ("lateral_drift_m", "lateral drift m", "{:.3f}"),
            ("energy_j", "energy J", "{:.1f}"), ("peak_torque_nm", "peak torque N m", "{:.1f}")]
    summary = {
        "env_id": ENV_ID, "pressures_kpa": pressures, "shell_models": list(spec.shell_models), "seeds": args.seeds,
        "episodes_per_controller": agg["ppo"]["episodes"],
        "controllers": {k: {"success_rate": v["success_rate"], "reached_runout_rate": v["reached_runout_rate"],
                            "mean_return": v["return"], "tracking_rmse_rad_s": v["tracking_rmse_rad_s"]}
                        for k, v in agg.items()},
        "train_steps": {label: t["num_timesteps"] for label, t in timings.items()},
        "train_wall_s": t_train, "train_steps_per_s": {label: t["steps_per_s"] for label, t in timings.items()},
        "eval_wall_s": t_eval, "total_wall_s": wall, "run_dir": {label: str(d) for label, (_, d) in policies.items()},
    }
    write_text_atomic(Path(args.out) / "summary.json", json.dumps(summary, indent=2) + "\n")
    print("\n" + markdown_table(res["agg_controller"], cols) + "\n")
    print(f"Success over the grid: PPO {agg['ppo']['success_rate']:.0%}, PPO residual over the PD "
          f"{agg['ppo_residual']['success_rate']:.0%}, PD {agg['pd']['success_rate']:.0%}, "
          f"zero torque {agg['zero']['success_rate']:.0%}.")
    print(f"[3/3] Done in {wall / 60:.1f} min (training {sum(t_train.values()):.0f} s, evaluation {t_eval:.0f} s).")
    for label, (_, d) in policies.items():
        print(f"  run folder ({label}) : {d.resolve()}")
    for k, v in res["files"].items():
        print(f"  {k:<22s}: {Path(v).resolve()}")
    if args.publish:
        PUBLISH.mkdir(parents=True, exist_ok=True)
        for f in ["report.md", "summary.json", "episodes.csv"]:
            shutil.copy(Path(args.out) / f, PUBLISH / f)
        for png in (Path(args.out) / "plots").glob("*.png"):
            shutil.copy(png, PUBLISH / png.name)
        for label, (_, d) in policies.items():
            shutil.copy(d / "learning_curve.png", PUBLISH / f"learning_curve_{label}.png")
        print(f"  published  : {PUBLISH}")
    return summary


if __name__ == "__main__":
    main()
