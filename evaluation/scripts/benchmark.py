"""Speed benchmark (single process). Writes ``evaluation/results/benchmark.{md,json}``.

Twin section: 10 s of free rolling from rest down the 16° ramp (4 m, then a flat
run-out), Majd friction on both joints, advanced in 20 ms chunks as an environment would; per
shell model, plus the same run on the bare plant (no friction system, no injected torques) of the
same contact model. Real-time factor = simulated seconds / wall seconds; best of ``--repeats``.
Environment section: ``evaluation.scripts.benchmark_env.run_env_benchmarks``.
Training section: ``evaluation.scripts.benchmark_train.run_train_benchmark`` (PPO, 2 workers).

    python -m evaluation.scripts.benchmark [--seconds 10] [--repeats 3] [--skip-env] [--skip-train]
"""

from __future__ import annotations

import argparse
import json
import time
from datetime import datetime, timezone

from sphere_env.models.shell import SHELL_MODELS
from sphere_env.physics import Twin, TwinConfig

from sphere_env.evaluation._report import RESULTS, machine_info, markdown_table

CHUNK_S = 0.02
RAMP = dict(incline_deg=16.0, ramp_length_m=4.0)


def time_twin(config: TwinConfig, seconds: float, repeats: int) -> float:
    """Best wall time [s] to advance ``seconds`` of simulation in 20 ms chunks from rest."""
    twin = Twin(config)
    n = int(round(seconds / CHUNK_S))
    best = float("inf")
    for _ in range(repeats):
        twin.reset()
        t0 = time.perf_counter()
        for _ in range(n):
            twin.advance(CHUNK_S)
            twin.state()  # an env reads the state every chunk
        best = min(best, time.perf_counter() - t0)
    return best


def run_twin_benchmarks(seconds: float = 10.0, repeats: int = 3) -> list[dict]:
    rows = []
    bare_wall = {}
    for contact in ("point", "hydroelastic"):
        cfg = TwinConfig(shell_model=contact, steer_friction="none", drive_friction="none", bare_plant=True, **RAMP)
        bare_wall[contact] = time_twin(cfg, seconds, repeats)
        rows.append(dict(case=f"bare plant, {contact} contact", shell_model=contact, friction="none",
                         rtf=seconds / bare_wall[contact], chunks_per_s=seconds / CHUNK_S / bare_wall[contact],
                         overhead_pct=""))
    for model in SHELL_MODELS:
        cfg = TwinConfig(shell_model=model, steer_friction="majd", drive_friction="majd", **RAMP)
        wall = time_twin(cfg, seconds, repeats)
        floor = bare_wall["hydroelastic" if model == "hydroelastic" else "point"]
        rows.append(dict(case=f"twin, {model}", shell_model=model, friction="majd/majd",
                         rtf=seconds / wall, chunks_per_s=seconds / CHUNK_S / wall,
                         overhead_pct=100.0 * (wall / floor - 1.0)))
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per case")
    parser.add_argument("--repeats", type=int, default=3, help="repeats per case (best is kept)")
    parser.add_argument("--skip-env", action="store_true", help="skip the Gymnasium environment section")
    parser.add_argument("--env-seconds", type=float, default=10.0, help="wall seconds per env case")
    parser.add_argument("--skip-train", action="store_true", help="skip the PPO training-throughput section")
    parser.add_argument("--train-seconds", type=float, default=30.0, help="wall seconds per training case")
    args = parser.parse_args(argv)

    info = machine_info()
    twin_rows = run_twin_benchmarks(args.seconds, args.repeats)
    cols = [("case", "case", ""), ("rtf", "real-time factor", "{:.1f}x"),
            ("chunks_per_s", "20 ms chunks/s", "{:.0f}"), ("overhead_pct", "overhead vs bare %", "{:+.0f}")]
    md = [
        "# sphere_env benchmark",
        "",
        f"Generated {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC "
        f"by `python -m evaluation.scripts.benchmark` "
        f"(commit {info['commit']}), single process.",
        f"Machine: {info['cpu']}, {info['cores']} cores; Python {info['python']}, drake {info['drake']}, "
        f"torch {info['torch']}, sb3 {info['stable_baselines3']}, gymnasium {info['gymnasium']}.",
        "",
        "## Twin: 10 s rolling down the 16° ramp, 20 ms chunks, plant step 5 ms",
        "",
        f"Simulated {args.seconds:g} s per case, best of {args.repeats}. Bare plant = same contact model "
        "without the friction/injected-torque system (injected's floor is the point-contact plant).",
        "",
        markdown_table(twin_rows, cols),
    ]
    env_rows = []
    if not args.skip_env:
        from sphere_env.evaluation.scripts.benchmark_env import ENV_COLUMNS, run_env_benchmarks

        env_rows = run_env_benchmarks(args.env_seconds)
        md += ["", "## Environments: env steps/s at 50 Hz control, random actions", "",
               markdown_table(env_rows, ENV_COLUMNS)]
    train_rows = []
    if not args.skip_train:
        from sphere_env.evaluation.scripts.benchmark_train import TRAIN_COLUMNS, run_train_benchmark

        train_rows = run_train_benchmark(args.train_seconds)
        md += ["", "## Training: PPO throughput with 2 worker processes", "", markdown_table(train_rows, TRAIN_COLUMNS)]
    text = "\n".join(md) + "\n"
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "benchmark.md").write_text(text)
    (RESULTS / "benchmark.json").write_text(json.dumps({"machine": info, "twin": twin_rows, "env": env_rows, "train": train_rows}, indent=2))
    print(text)


if __name__ == "__main__":
    main()
