"""Speed benchmark (single process). Writes ``evaluation/results/benchmark.{md,json}``.

Twin section: 10 s of free rolling from rest down the 16° ramp (4 m, then a flat
run-out), Majd friction on both joints, advanced in 20 ms chunks as an environment would; per
shell model, plus the same run on the bare plant (no friction system, no injected torques) of the
same contact model. Real-time factor = simulated seconds / wall seconds; best of ``--repeats``.
Floor section: every setting against Drake's floor (the robot URDF alone on the same ground), paired
and interleaved in one run (``evaluation.experiments.benchmark_floor``). Profile section: where a
20 ms chunk goes, from Linux ``perf`` samples (``evaluation.experiments.profile_twin``).
Environment section: ``evaluation.experiments.benchmark_env.run_env_benchmarks``.
Training section: ``evaluation.experiments.benchmark_train.run_train_benchmark`` (PPO layouts against the
single-env rate, 1 and all cores, interleaved).

    python -m evaluation.experiments.benchmark [--seconds 10] [--repeats 3] [--skip-floor] [--skip-profile]
        [--skip-env] [--skip-train]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from datetime import datetime, timezone

from sphere_env.evaluation.experiments import RESULTS
from sphere_env.files import write_text_atomic
from sphere_env.params import SHELL_MODELS
from sphere_env.physics import Twin, TwinConfig
from sphere_env.provenance import machine_info
from sphere_env.reporting import markdown_table

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


def time_twin_paired(config: TwinConfig, seconds: float, repeats: int) -> tuple[float, float]:
    """(best wall time [s] of the twin over ``seconds`` in 20 ms chunks from rest, twin time / bare
    plant time over the **same trajectory**). Before each chunk the bare plant (same contact model
    and pressure, no friction/injected-torque system) is set to the twin's state and advanced the
    same 20 ms, alternating with the twin so both see the same load and the same contacts (the
    twin's state is set to itself as well, so both pay the same cache invalidation)."""
    twin = Twin(config)
    bare = Twin(config.replace(bare_plant=True))
    n = int(round(seconds / CHUNK_S))
    best, t_twin, t_bare = float("inf"), 0.0, 0.0
    for _ in range(repeats):
        twin.reset()
        bare.reset()
        wall = 0.0
        for _ in range(n):
            x = twin.plant.GetPositionsAndVelocities(twin.plant_context)
            for t in (bare, twin):  # both get their state set (same cache invalidation)
                t.plant.SetPositionsAndVelocities(t.plant_context, x)
                t.context.SetTime(twin.context.get_time())
            t0 = time.perf_counter()
            bare.advance(CHUNK_S)
            bare.state()
            t1 = time.perf_counter()
            twin.advance(CHUNK_S)
            twin.state()
            t2 = time.perf_counter()
            t_bare += t1 - t0
            wall += t2 - t1
        t_twin += wall
        best = min(best, wall)
    return best, t_twin / t_bare


def run_twin_benchmarks(seconds: float = 10.0, repeats: int = 3) -> list[dict]:
    """Bare plants (free run, no joint friction: a different, faster trajectory than the twin's) and
    each shell model's twin with its overhead over the bare plant measured paired, on the twin's
    own trajectory (:func:`time_twin_paired`)."""
    rows = []
    for contact in ("point", "hydroelastic"):
        cfg = TwinConfig(shell_model=contact, steer_friction="none", drive_friction="none", bare_plant=True, **RAMP)
        wall = time_twin(cfg, seconds, repeats)
        rows.append(
            dict(
                case=f"bare plant, {contact} contact (own trajectory, no friction)",
                shell_model=contact,
                friction="none",
                rtf=seconds / wall,
                chunks_per_s=seconds / CHUNK_S / wall,
                overhead_pct="",
            )
        )
    for model in SHELL_MODELS:
        cfg = TwinConfig(shell_model=model, steer_friction="majd", drive_friction="majd", **RAMP)
        wall, ratio = time_twin_paired(cfg, seconds, repeats)
        rows.append(
            dict(
                case=f"twin, {model}",
                shell_model=model,
                friction="majd/majd",
                rtf=seconds / wall,
                chunks_per_s=seconds / CHUNK_S / wall,
                overhead_pct=100.0 * (ratio - 1.0),
            )
        )
    return rows


FLOOR_HEADING = "## Against Drake's floor: the same states, interleaved (point and hydroelastic contact)"
PROFILE_HEADING = "## Where a 20 ms chunk goes"
BEFORE_FLOOR = "## Environments"


def floor_and_profile(args, info: dict) -> tuple[dict, dict, list[str]]:
    """The floor and profile sections (unless skipped): their results and Markdown lines."""
    floor, profile, md = {}, {}, []
    if not args.skip_floor:
        from sphere_env.evaluation.experiments.benchmark_floor import floor_markdown, run_paired, summary

        floor = run_paired(args.seconds, args.floor_repeats)
        floor.update(
            summary=summary(floor), commit=info["commit"], run_utc=f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M}"
        )
        md += [
            "",
            FLOOR_HEADING,
            "",
            f"Run {floor['run_utc']} UTC at commit {info['commit']}.",
            "",
            floor_markdown(floor),
        ]
    if not args.skip_profile:
        from sphere_env.evaluation.experiments.profile_twin import FREQUENCY_HZ, profile_cases, profile_markdown

        load0 = os.getloadavg()
        profile = profile_cases(args.profile_seconds)
        profile.update(load_avg_start=load0, commit=info["commit"])
        md += [
            "",
            PROFILE_HEADING,
            "",
            f"Linux `perf` sampling the stepping loop at {FREQUENCY_HZ} Hz with DWARF call stacks, "
            f"{args.profile_seconds:g} s of wall time per case, each rolling down the ramp from rest (its own "
            "trajectory); each sample goes to the first piece whose frames it contains, in the order of the rows "
            "(`evaluation/experiments/profile_twin.py`). The twin has no Python leaf systems: its joint friction and "
            "shell law are `SymbolicVectorSystem`s evaluated in C++. Shares of this process's CPU time, so they hold "
            f"under load (1-min load average {load0[0]:.1f} at the start).",
            "",
            profile_markdown(profile),
        ]
    return floor, profile, md


def merge_floor_and_profile(floor: dict, profile: dict, lines: list[str]) -> None:
    """Put the floor and profile sections into the written results in place of their last run,
    the other sections left as their own run wrote them."""
    md = (RESULTS / "benchmark.md").read_text()
    head, found, rest = md.partition("\n" + FLOOR_HEADING)
    if found:  # up to the next heading that is not the profile's
        at = rest.find("\n## ")
        while at >= 0 and rest.startswith("\n" + PROFILE_HEADING, at):
            at = rest.find("\n## ", at + 1)
        tail = rest[at:] if at >= 0 else ""
    else:  # no floor section yet: before the environments, else at the end
        head, sep, tail = md.partition("\n" + BEFORE_FLOOR)
        tail = sep + tail
    write_text_atomic(RESULTS / "benchmark.md", head.rstrip("\n") + "\n" + "\n".join(lines) + "\n" + tail)
    data = json.loads((RESULTS / "benchmark.json").read_text())
    data.update(floor=floor, profile=profile)
    write_text_atomic(RESULTS / "benchmark.json", json.dumps(data, indent=2))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per case")
    parser.add_argument("--repeats", type=int, default=3, help="repeats per case (best is kept)")
    parser.add_argument("--skip-floor", action="store_true", help="skip the section against Drake's floor")
    parser.add_argument("--floor-repeats", type=int, default=2, help="repeats of the paired floor section")
    parser.add_argument("--skip-profile", action="store_true", help="skip the perf profile of a chunk")
    parser.add_argument("--profile-seconds", type=float, default=8.0, help="wall seconds sampled per profiled case")
    parser.add_argument("--skip-env", action="store_true", help="skip the Gymnasium environment section")
    parser.add_argument("--env-seconds", type=float, default=10.0, help="wall seconds per env case")
    parser.add_argument("--skip-train", action="store_true", help="skip the PPO training-throughput section")
    parser.add_argument("--train-seconds", type=float, default=24.0, help="wall seconds per training case")
    parser.add_argument("--train-rounds", type=int, default=3, help="interleaved rounds of the training cases")
    parser.add_argument(
        "--floor-only",
        action="store_true",
        help="run only the floor and profile sections and put them into the written results in place of their last run",
    )
    args = parser.parse_args(argv)

    info = machine_info()
    if args.floor_only:
        merge_floor_and_profile(*floor_and_profile(args, info))
        print((RESULTS / "benchmark.md").read_text())
        return
    load0 = os.getloadavg()
    twin_rows = run_twin_benchmarks(args.seconds, args.repeats)
    cols = [
        ("case", "case", ""),
        ("rtf", "real-time factor", "{:.1f}x"),
        ("chunks_per_s", "20 ms chunks/s", "{:.0f}"),
        ("overhead_pct", "overhead vs bare plant, same trajectory %", "{:+.1f}"),
    ]
    md = [
        "# sphere_env benchmark",
        "",
        f"Generated {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC "
        f"by `python -m evaluation.experiments.benchmark` "
        f"(commit {info['commit']}), single process.",
        f"Machine: {info['cpu']}, {info['cores']} cores; Python {info['python']}, drake {info['drake']}, "
        f"torch {info['torch']}, sb3 {info['stable_baselines3']}, gymnasium {info['gymnasium']}.",
        f"1-min load average {load0[0]:.1f} at the start (other jobs share the machine: the paired and interleaved "
        "ratios hold under load, the absolute rates do not).",
        "",
        "## Twin: 10 s rolling down the 16° ramp, 20 ms chunks, plant step 5 ms",
        "",
        f"Simulated {args.seconds:g} s per case, best of {args.repeats}. Bare plant = same contact model "
        "without the friction/injected-torque system. The overhead is paired: before every chunk the bare "
        "plant of the same shell model is set to the twin's state and advanced the same 20 ms, so both "
        "time the same trajectory and contacts (the bare plant's own free run has no joint friction and "
        "follows a different path).",
        "",
        markdown_table(twin_rows, cols),
    ]
    floor, profile, lines = floor_and_profile(args, info)
    md += lines
    env_rows = []
    if not args.skip_env:
        from sphere_env.evaluation.experiments.benchmark_env import ENV_COLUMNS, run_env_benchmarks

        env_rows = run_env_benchmarks(args.env_seconds)
        md += [
            "",
            "## Environments: env steps/s at 50 Hz control, random actions",
            "",
            markdown_table(env_rows, ENV_COLUMNS),
        ]
    train = {}
    if not args.skip_train:
        from sphere_env.evaluation.experiments.benchmark_recipe import run_solver_benchmark, solver_markdown
        from sphere_env.evaluation.experiments.benchmark_train import report_markdown, run_train_benchmark

        train = run_train_benchmark(args.train_seconds, rounds=args.train_rounds)
        train["solvers"] = run_solver_benchmark()
        md += [
            "",
            "## Training: PPO throughput against the single-env rate (RampDescent, shipped hyperparameters)",
            "",
            report_markdown(train),
            "",
            "## Training: the learning recipe with the fast contact solver",
            "",
            solver_markdown(train["solvers"]),
        ]
    else:
        md += [
            "",
            "## Training",
            "",
            "Not run (`--skip-train`): `evaluation/results/benchmark_train.md` has the last training-throughput run "
            "(`python -m evaluation.experiments.benchmark_train`), the learning recipe with the fast contact solver "
            "included.",
        ]
    text = "\n".join(md) + "\n"
    RESULTS.mkdir(parents=True, exist_ok=True)
    write_text_atomic(RESULTS / "benchmark.md", text)
    write_text_atomic(
        RESULTS / "benchmark.json",
        json.dumps(
            {
                "machine": info,
                "load_avg_start": load0,
                "twin": twin_rows,
                "floor": floor,
                "profile": profile,
                "env": env_rows,
                "train": train,
            },
            indent=2,
        ),
    )
    print(text)


if __name__ == "__main__":
    main()
