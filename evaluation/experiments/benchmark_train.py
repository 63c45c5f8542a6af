"""PPO training throughput against the single-env step rate, per vec-env layout and core count.

All cases are built first and then timed **interleaved** (``--rounds`` rounds, each case
``seconds / rounds`` per round), so they see the same machine load; ratios between rows of one run
count more than absolute figures on a shared machine. Per shell model (RampDescent, the shipped
PPO hyperparameters of ``training/hyperparams/ppo.yml``, VecNormalize and pressure randomization on):

* **single env**: one Monitor-wrapped env (as a training worker builds it) stepped with random
  actions, episode resets included — the rate one core can step.
* per **layout** (the shipped one, the former defaults, several envs per process, several envs per
  thread; every layout keeps the shipped rollout of :data:`~evaluation.experiments.train_cases.ROLLOUT` samples per update, so more envs
  mean shorter ``n_steps`` segments, which changes what PPO learns):
  PPO ``learn`` one update at a time, after a warm-up update.

  - **rollout steps/s** = env steps / (wall − update time): collection, policy forward pass and
    VecNormalize included; its ratio to cores × single-env rate (aim ≥ 80%);
  - **training steps/s** = env steps / wall, updates included; ratio (aim ≥ 50%);
  - update share of the wall time, main-process CPU ms per env step;
  - **main-process work per vectorized step** outside the env stepping (rollout wall time minus the
    time inside the innermost VecEnv's ``step_async`` and ``step_wait``: policy forward pass,
    VecNormalize, rollout buffer, callbacks), measured directly;
  - **env stepping alone**: env steps / time inside ``step_async`` + ``step_wait``, against cores ×
    single-env rate:
    the rollout ratio's ceiling with a free policy (SB3 waits for every vectorized step before the
    next forward pass, so the two do not overlap).
* **1 core**: the shipped layout again with the whole process (its threads and worker processes)
  pinned to one core (``sched_setaffinity``), interleaved with the 2-core rows: the scaling figure.

A scaling model (printed and returned, :func:`scaling_model`) gives the time per env step of the
shipped block layout with n envs on N cores as ``u + (c0 + c1 n) / n + e_b / min(N, n)``: u the
PPO update per sample, c0 + c1 n the main process's work per vectorized step outside the env
stepping, e_b one env step inside a block, all measured.

Then the learning recipe (RampDescent-v3) with the env under the reference contact solver and under
``contact_approximation: tamsi`` (:func:`run_solver_benchmark`).

    python -m evaluation.experiments.benchmark_train [--seconds 24] [--rounds 3] [--shell-models point injected]
        [--solver-updates 2] [--no-solvers | --solvers-only]

writes ``evaluation/results/benchmark_train.{md,json}`` (with the commit; ``--no-write``: print only).
"""

from __future__ import annotations

import argparse
import os

from sphere_env.evaluation.experiments.train_cases import ENV_ID, LAYOUTS, ROLLOUT, SingleEnv, TrainCase, usable_cores

TRAIN_COLUMNS = [
    ("shell_model", "shell", ""),
    ("case", "case", ""),
    ("cores", "cores", "{:d}"),
    ("steps", "env steps timed", "{:d}"),
    ("single_env_steps_per_s", "env steps/s", "{:.0f}"),
    ("rollout_steps_per_s", "rollout steps/s", "{:.0f}"),
    ("rollout_ratio_pct", "rollout / (cores × single) %", "{:.0f}"),
    ("stepping_ratio_pct", "env stepping alone / (cores × single) %", "{:.0f}"),
    ("train_steps_per_s", "training steps/s", "{:.0f}"),
    ("train_ratio_pct", "training / (cores × single) %", "{:.0f}"),
    ("update_share_pct", "update share %", "{:.0f}"),
    ("cpu_main_ms_per_step", "training process CPU ms/step", "{:.3f}"),
    ("main_ms_per_vec_step", "main-process ms per vectorized step outside env stepping", "{:.3f}"),
]


def _layout_name(cfg) -> str:
    if cfg.n_threads is not None:
        return f"{cfg.n_envs} envs, {cfg.n_threads} threads (ThreadedVecEnv)"
    if cfg.n_workers is not None:
        return (
            f"{cfg.n_envs} envs, {cfg.n_workers} blocks: this process + workers, one per usable core "
            "(BatchedSubprocVecEnv)"
            if cfg.n_workers == "auto"
            else f"{cfg.n_envs} envs in {cfg.n_workers} blocks: this process + workers (BatchedSubprocVecEnv)"
        )
    return f"{cfg.n_envs} envs, 1 process each (SubprocVecEnv)"


def _single_row(m: str, s: SingleEnv) -> dict:
    """The row of the single env of shell model ``m``."""
    single = s.steps / s.wall
    return dict(
        shell_model=m,
        case="single env (one core)",
        layout="single",
        cores=1,
        steps=s.steps,
        single_env_steps_per_s=single,
        gil_us_per_step=1e6 * (s.wall - s.advance_s) / s.steps,
    )


def _case_row(c: TrainCase, single: float) -> dict:
    """The row of a timed layout ``c``; ``single``: the single-env rate of its shell model [steps/s]."""
    rollout = c.steps / (c.wall - c.update_s)
    train = c.steps / c.wall
    label = f"{c.label}: {_layout_name(c.cfg)}" if c.layout == "shipped" else c.label
    return dict(
        shell_model=c.shell_model,
        case=label + (" — pinned to 1 core" if c.cores == 1 else ""),
        layout=c.layout,
        cores=c.cores,
        steps=c.steps,
        single_env_steps_per_s=single,
        rollout_steps_per_s=rollout,
        rollout_ratio_pct=100 * rollout / (c.cores * single),
        stepping_ratio_pct=100 * c.steps / c.stepping_s / (c.cores * single),
        train_steps_per_s=train,
        train_ratio_pct=100 * train / (c.cores * single),
        update_share_pct=100 * c.update_s / c.wall,
        cpu_main_ms_per_step=1e3 * c.cpu_main / c.steps,
        main_ms_per_vec_step=1e3 * (c.wall - c.update_s - c.stepping_s) / (c.steps / c.cfg.n_envs),
        update_ms_per_step=1e3 * c.update_s / c.steps,
        n_envs=c.cfg.n_envs,
        n_steps=c.cfg.hyperparams["n_steps"],
        n_threads=c.cfg.n_threads,
        n_workers=c.cfg.n_workers,
    )


def run_train_benchmark(
    seconds: float = 24.0,
    shell_models: tuple[str, ...] = ("point", "injected"),
    rounds: int = 3,
    layouts: dict[str, tuple[str, ...]] | None = None,
    one_core: bool = True,
) -> dict:
    """Interleaved timing of the single env, the layouts (``layouts[shell_model]``, default: all for
    point, shipped and the 2-process baseline otherwise) and, with ``one_core``, the shipped layout
    on one core. Returns ``{"rows": [...], "model": {...}, "load_avg": (...), "cores": n}``."""
    import torch

    torch.set_num_threads(1)
    cores = usable_cores()
    load0 = os.getloadavg()
    singles, cases = {}, []
    for m in shell_models:
        singles[m] = SingleEnv(m)
        names = (layouts or {}).get(m) or (tuple(LAYOUTS) if m == "point" else ("shipped", "thread8", "proc16"))
        cases += [TrainCase(m, name) for name in names]
        if one_core and cores > 1:
            cases.append(TrainCase(m, "shipped", cores=1))
    try:
        per = seconds / rounds
        for _ in range(rounds):
            for m in shell_models:
                singles[m].run(per)
            for case in cases:
                case.run(per)
    finally:
        for c in (*singles.values(), *cases):
            c.close()
    load1 = os.getloadavg()

    rows, model = [], {}
    for m in shell_models:
        s = singles[m]
        single = s.steps / s.wall
        rows.append(_single_row(m, s))
        rows += [_case_row(c, single) for c in cases if c.shell_model == m]
        model[m] = scaling_model(rows, m, cores)
    return {
        "rows": rows,
        "model": model,
        "load_avg_start": load0,
        "load_avg_end": load1,
        "cores": cores,
        "seconds_per_case": seconds,
        "rounds": rounds,
    }


def scaling_model(rows: list[dict], shell_model: str, cores: int) -> dict:
    """Time per env step of the block layout (``BatchedSubprocVecEnv``, the shipped one) with ``n``
    envs on ``N`` cores:

        t = u + (c0 + c1 n) / n + e_b / min(N, n)

    u: PPO update per sample (serial); c0 + c1 n: the main process's work per vectorized step
    outside the env stepping (policy forward pass, VecNormalize, rollout buffer; c1 the part that
    grows with the envs, such as unpickling the workers' results), measured directly in the shipped
    layout and, for c1, in the 16-env block layout where it ran; e_b: one env step inside a block
    (time inside ``step_async`` + ``step_wait`` per env step × blocks): a single env step plus its share of the
    message passing and of waking up between steps. All measured on ``cores`` cores; predictions for
    the shipped ``n_envs`` and for ``n = N`` envs (one per core) at 1, 2, 4, 8, 16, 64 cores. The
    1-core row is measured, not used by the model."""
    ship = [r for r in rows if r["shell_model"] == shell_model and r["layout"] == "shipped"]
    full = next((r for r in ship if r["cores"] == cores), None)
    one = next((r for r in ship if r["cores"] == 1), None)
    if full is None or cores < 2 or full["n_workers"] is None:
        return {}
    n_envs = full["n_envs"]
    blocks = min(cores, n_envs)
    u = 1e-3 * full["update_ms_per_step"]
    # stepping rate = stepping_ratio × cores × single rate, in env steps per second of stepping
    e_b = blocks / (full["stepping_ratio_pct"] / 100 * cores * full["single_env_steps_per_s"])
    c_full = 1e-3 * full["main_ms_per_vec_step"]
    wide = next(
        (r for r in rows if r["shell_model"] == shell_model and r["layout"] == "proc16" and r["cores"] == cores), None
    )
    c1 = (
        max(1e-3 * (wide["main_ms_per_vec_step"] - full["main_ms_per_vec_step"]) / (wide["n_envs"] - n_envs), 0.0)
        if wide is not None and wide["n_envs"] != n_envs
        else 0.0
    )
    c0 = max(c_full - c1 * n_envs, 0.0)

    def rate(n_cores: int, n: int) -> float:
        return 1.0 / (u + (c0 + c1 * n) / n + e_b / min(n_cores, n))

    grid = (1, 2, 4, 8, 16, 64)
    out = {
        "env_ms_per_step_single": 1e3 / full["single_env_steps_per_s"],
        "env_ms_per_step_in_block": 1e3 * e_b,
        "update_ms_per_step": 1e3 * u,
        "main_ms_per_vec_step_fixed": 1e3 * c0,
        "main_ms_per_env_per_vec_step": 1e3 * c1,
        "n_envs": n_envs,
        f"measured_{cores}_cores": full["train_steps_per_s"],
        "predicted_shipped": {n: rate(n, n_envs) for n in grid},
        "predicted_one_env_per_core": {n: rate(n, n) for n in grid},
    }
    if one is not None:
        out["measured_1_core"] = one["train_steps_per_s"]
    return out


def report_markdown(result: dict) -> str:
    from sphere_env.reporting import markdown_table

    l0, l1 = result["load_avg_start"], result["load_avg_end"]
    lines = [
        f"{result['cores']} usable cores; each case timed {result['seconds_per_case']:g} s in {result['rounds']} "
        f"interleaved rounds; 1-min load average {l0[0]:.1f} at start, {l1[0]:.1f} at end (other jobs share the "
        f"machine: compare rows, not runs). Rollout of {ROLLOUT} samples per update in every layout "
        f"(n_steps = {ROLLOUT} / n_envs).",
        "",
        markdown_table(result["rows"], TRAIN_COLUMNS),
    ]
    for m, fit in result["model"].items():
        if not fit:
            continue
        ship = ", ".join(f"{n}: {v:.0f}" for n, v in fit["predicted_shipped"].items())
        wide = ", ".join(f"{n}: {v:.0f}" for n, v in fit["predicted_one_env_per_core"].items())
        lines += [
            "",
            f"Scaling model, {m} (t = u + (c0 + c1 n)/n + e_b/min(N, n) per env step, the block layout): "
            f"env step in a block e_b = {fit['env_ms_per_step_in_block']:.3f} ms (single env "
            f"{fit['env_ms_per_step_single']:.3f} ms); main process outside the env stepping c0 = "
            f"{fit['main_ms_per_vec_step_fixed']:.3f} ms per vectorized step + c1 = "
            f"{fit['main_ms_per_env_per_vec_step']:.3f} ms per env; PPO update u = {fit['update_ms_per_step']:.3f} ms "
            f"per sample. Predicted training steps/s by cores N, shipped {fit['n_envs']} envs: {ship}; one env per "
            f"core (n = N): {wide}.",
        ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    import json
    import sys
    from datetime import datetime, timezone

    from sphere_env.evaluation.experiments import RESULTS
    from sphere_env.evaluation.experiments.benchmark_recipe import SOLVER_HEADING, run_solver_benchmark, solver_markdown
    from sphere_env.provenance import machine_info

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=24.0, help="timed wall seconds per case (all rounds)")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds")
    parser.add_argument("--shell-models", nargs="+", default=["point", "injected"])
    parser.add_argument("--no-one-core", action="store_true", help="skip the 1-core (pinned) rows")
    parser.add_argument(
        "--no-write",
        action="store_true",
        help="print only (default: also write evaluation/results/benchmark_train.{md,json})",
    )
    parser.add_argument("--solver-updates", type=int, default=2, help="timed PPO updates per contact solver")
    parser.add_argument("--no-solvers", action="store_true", help="skip the recipe's contact-solver comparison")
    parser.add_argument(
        "--solvers-only",
        action="store_true",
        help="run only the contact-solver comparison and put it into the written results in place of its last run",
    )
    args = parser.parse_args(argv)
    info = machine_info()
    command = " ".join(
        ["python -m evaluation.experiments.benchmark_train", *(argv if argv is not None else sys.argv[1:])]
    )
    solvers = None if args.no_solvers else run_solver_benchmark(args.solver_updates)
    solver_text = (
        ""
        if solvers is None
        else f"\n{SOLVER_HEADING}\n\nGenerated {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC by `{command}` "
        f"(commit {info['commit']}).\n\n{solver_markdown(solvers)}\n"
    )
    if args.solvers_only:
        print(solver_text)
        if not args.no_write and solvers is not None:
            from sphere_env.files import write_text_atomic

            md = (RESULTS / "benchmark_train.md").read_text().split(f"\n{SOLVER_HEADING}")[0]
            data = json.loads((RESULTS / "benchmark_train.json").read_text())
            data["solvers"] = solvers | {"machine": info}
            write_text_atomic(RESULTS / "benchmark_train.md", md.rstrip("\n") + "\n" + solver_text)
            write_text_atomic(RESULTS / "benchmark_train.json", json.dumps(data, indent=2))
        return
    result = run_train_benchmark(args.seconds, tuple(args.shell_models), args.rounds, one_core=not args.no_one_core)
    text = (
        "\n".join(
            [
                "# sphere_env training throughput",
                "",
                f"Generated {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC by `{command}` (commit {info['commit']}).",
                f"Machine: {info['cpu']}, {info['cores']} cores; Python {info['python']}, drake {info['drake']}, "
                f"torch {info['torch']}, sb3 {info['stable_baselines3']}, gymnasium {info['gymnasium']}.",
                "",
                f"PPO on {ENV_ID}, shipped hyperparameters, VecNormalize and pressure randomization on.",
                "",
                report_markdown(result),
            ]
        )
        + "\n"
        + solver_text
    )
    print(text)
    if not args.no_write:
        from sphere_env.files import write_text_atomic

        RESULTS.mkdir(parents=True, exist_ok=True)
        write_text_atomic(RESULTS / "benchmark_train.md", text)
        write_text_atomic(
            RESULTS / "benchmark_train.json",
            json.dumps({"machine": info, "train": result, "solvers": solvers}, indent=2),
        )


if __name__ == "__main__":
    main()
