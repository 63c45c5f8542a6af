"""The learning recipe's PPO throughput with the env under the reference contact solver and under
the fast one (``contact_approximation: tamsi``), interleaved update by update; part of
``evaluation.experiments.benchmark_train`` (and of ``make bench``'s training section)."""

from __future__ import annotations

import os

from sphere_env.evaluation.experiments.train_cases import SingleEnv, TrainCase, usable_cores

#: The learning recipe's env (its section of training/hyperparams/ppo.yml) and the fast contact solver.
RECIPE_ENV_ID = "sphere_env/RampDescent-v3"
FAST_SOLVER = "tamsi"
SOLVERS = {"reference": {}, FAST_SOLVER: {"contact_approximation": FAST_SOLVER}}
SOLVER_HEADING = "## The learning recipe with the fast contact solver"


def run_solver_benchmark(updates: int = 2, single_seconds: float = 10.0, env_id: str = RECIPE_ENV_ID) -> dict:
    """The recipe's PPO (its YAML section as the trainer reads it: envs, layout, policy, env kwargs
    and randomization; its callbacks left out) with the env under the reference solver and under
    ``contact_approximation: tamsi``. After a warm-up update each, ``updates`` updates per solver,
    interleaved update by update (the order alternating), and the single-env rate of each (random
    actions, ``single_seconds`` in all). Returns rows per solver and the tamsi ÷ reference ratios."""
    import torch

    torch.set_num_threads(1)
    load0 = os.getloadavg()
    singles = {k: SingleEnv("injected", env_id=env_id, env_kwargs=kw) for k, kw in SOLVERS.items()}
    cases = {k: TrainCase("injected", "shipped", env_id=env_id, env_kwargs=kw) for k, kw in SOLVERS.items()}
    try:
        for i in range(updates):
            order = list(SOLVERS) if i % 2 == 0 else list(reversed(SOLVERS))
            for k in order:
                singles[k].run(single_seconds / updates)
            for k in order:
                cases[k].run_updates(1)
    finally:
        for c in (*singles.values(), *cases.values()):
            c.close()
    load1 = os.getloadavg()
    rows = []
    for k, c in cases.items():
        single = singles[k].steps / singles[k].wall
        rows.append(
            dict(
                solver=k,
                single_env_steps_per_s=single,
                steps=c.steps,
                rollout_steps_per_s=c.steps / (c.wall - c.update_s),
                train_steps_per_s=c.steps / c.wall,
                update_share_pct=100 * c.update_s / c.wall,
                n_envs=c.cfg.n_envs,
                n_steps=c.cfg.hyperparams["n_steps"],
            )
        )
    ref, fast = rows
    ratio = {
        key: fast[key] / ref[key] for key in ("single_env_steps_per_s", "rollout_steps_per_s", "train_steps_per_s")
    }
    return {
        "env_id": env_id,
        "rows": rows,
        "ratio": ratio,
        "updates": updates,
        "cores": usable_cores(),
        "load_avg_start": load0,
        "load_avg_end": load1,
    }


def solver_markdown(result: dict) -> str:
    from sphere_env.reporting import markdown_table

    r0 = result["rows"][0]
    l0, l1, ratio = result["load_avg_start"], result["load_avg_end"], result["ratio"]
    cols = [
        ("solver", "env solver", ""),
        ("single_env_steps_per_s", "single env steps/s", "{:.0f}"),
        ("steps", "env steps timed", "{:d}"),
        ("rollout_steps_per_s", "rollout steps/s", "{:.0f}"),
        ("train_steps_per_s", "training steps/s", "{:.0f}"),
        ("update_share_pct", "update share %", "{:.0f}"),
    ]
    return "\n".join(
        [
            f"PPO on `{result['env_id']}` as its section of `training/hyperparams/ppo.yml` gives it ({r0['n_envs']} envs "
            f"× {r0['n_steps']} steps per update, {result['cores']} usable cores; the recipe's callbacks left out), "
            f"the env under the reference solver (`sap`) and under `contact_approximation: {FAST_SOLVER}`; after a "
            f"warm-up update each, {result['updates']} updates per solver interleaved update by update. 1-min load "
            f"average {l0[0]:.1f} at the start, {l1[0]:.1f} at the end: compare rows, not runs.",
            "",
            markdown_table(result["rows"], cols),
            "",
            f"{FAST_SOLVER} ÷ reference: training **×{ratio['train_steps_per_s']:.2f}**, rollout "
            f"×{ratio['rollout_steps_per_s']:.2f}, single env ×{ratio['single_env_steps_per_s']:.2f}.",
        ]
    )
