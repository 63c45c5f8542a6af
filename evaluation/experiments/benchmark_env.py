"""Environment speed benchmark: env steps/s vs the bare twin, and reset() time.

Per env id × shell model, single process, 50 Hz control (20 ms chunks, 5 ms plant step):

* **env steps/s**: ``gym.make(id, shell_model=...)`` (with Gymnasium's default wrappers) stepped
  with uniformly random actions drawn beforehand; episode resets are not timed.
* **twin steps/s**: the env's own :class:`~sphere_env.physics.twin.Twin` replaying each block of
  25 env steps from the block's starting context (time, state, parameters) with the same torques
  through the public ``advance(0.02, τ)``, interleaved with the env — a paired measurement of
  the same trajectory (the replay's end state is checked against the env's), so the difference
  is the env's own work.
* **overhead %** = env time per step / twin time per step − 1 (paired).
* **env Python µs/step**: ``env.step`` (with wrappers) with the physics call stubbed out — the
  env's own per-step work, less sensitive to machine load than the overhead ratio.
* **reset ms**: mean wall time of ``env.reset()`` (diagram reused; no rebuild); hydroelastic
  after its per-pressure shell-mesh cache is warm.

    python -m evaluation.experiments.benchmark_env [--seconds 5] [--write]
"""

from __future__ import annotations

import argparse
import os
import time

import gymnasium as gym
import numpy as np

import sphere_env  # noqa: F401  (registers ids)
from sphere_env.params import SHELL_MODELS

ENV_IDS = ("sphere_env/RampDescent-v0", "sphere_env/Roll-v0")
#: Speed aims on one core at 50 Hz (env steps/s, env overhead over the bare twin, reset time).
AIM_STEPS_PER_S = {"point": 1800, "injected": 1600, "hydroelastic": 500}
AIM_OVERHEAD_PCT = 15.0
AIM_RESET_MS = 5.0

ENV_COLUMNS = [
    ("env", "env", ""),
    ("shell_model", "shell", ""),
    ("env_steps_per_s", "env steps/s", "{:.0f}"),
    ("twin_steps_per_s", "bare twin steps/s", "{:.0f}"),
    ("overhead_pct", "env overhead % (paired)", "{:+.1f}"),
    ("paired_max_state_diff", "replay max state diff", "{:.0e}"),
    ("python_us_per_step", "env Python µs/step (physics stubbed)", "{:.1f}"),
    ("reset_ms", "reset ms", "{:.2f}"),
    ("aims_met", "aims (steps/s, overhead, reset)", ""),
]


def bench_case(env_id: str, shell_model: str, seconds: float, seed: int = 0, block: int = 25) -> dict:
    """Env and bare twin over the **same trajectory**: the env steps a block of ``block`` random
    actions; then its own twin is put back to the block's starting context (time, state,
    parameters) and stepped with the same motor torques through the public ``advance``; then the
    env's context is restored and it continues. Both see the same machine load, states, contacts
    and parameters, so the time difference is the env's own work. The replay's end state is
    compared with the env's (``paired_max_state_diff``: 0 when the trajectories are identical)."""
    env = gym.make(env_id, shell_model=shell_model)
    u = env.unwrapped
    rng = np.random.default_rng(seed)
    twin = u.twin
    lim = np.array([u.steer_torque_limit_nm, -u.drive_torque_limit_nm])
    env.reset(seed=seed)
    env.step(np.zeros(2, np.float32))  # warm-up (first-step checker)
    env.reset(seed=seed)
    n, t_env, t_twin, max_diff = 0, 0.0, 0.0, 0.0
    deadline = time.perf_counter() + seconds
    while time.perf_counter() < deadline:
        actions = rng.uniform(-1.0, 1.0, size=(block, 2)).astype(np.float32)
        torques = [tuple(a) for a in actions.astype(float) * lim]
        start = twin.context.Clone()
        done_at, done = block, False
        t0 = time.perf_counter()
        for k in range(block):
            _, _, term, trunc, info = env.step(actions[k])
            if term or trunc:
                done_at, done = k + 1, True
                break
        t_env += time.perf_counter() - t0
        end = twin.context.Clone()
        x_env = twin.plant.GetPositionsAndVelocities(twin.plant_context).copy()
        twin.context.SetTimeStateAndParametersFrom(start)
        twin.simulator.Initialize()
        t0 = time.perf_counter()
        for k in range(done_at):
            twin.advance(0.02, torques[k])
        t_twin += time.perf_counter() - t0
        x_twin = twin.plant.GetPositionsAndVelocities(twin.plant_context)
        if not info.get("physics_failure"):
            max_diff = max(max_diff, float(np.max(np.abs(x_twin - x_env))))
        twin.context.SetTimeStateAndParametersFrom(end)
        twin.simulator.Initialize()
        n += done_at
        if done:
            env.reset()

    # reset() time with the diagram reused; hydroelastic after its pressure-mesh cache is warm
    # (the first reset at each new 0.5 kPa grid pressure re-meshes the shell, ≈50–100 ms).
    for _ in range(60 if shell_model == "hydroelastic" else 5):
        env.reset()
    t0 = time.perf_counter()
    n_reset = 50
    for _ in range(n_reset):
        env.reset()
    reset_ms = (time.perf_counter() - t0) / n_reset * 1e3
    # The env's own Python per step, physics stubbed out (state frozen): less load-sensitive.
    env.reset()
    twin_now = u.twin
    twin_now.advance_unchecked = lambda duration_s, motor_torque_nm: None
    acts = rng.uniform(-1.0, 1.0, size=(2000, 2)).astype(np.float32)
    t0 = time.perf_counter()
    for a in acts:
        env.step(a)
    python_us = (time.perf_counter() - t0) / len(acts) * 1e6
    del twin_now.advance_unchecked
    env.close()
    env_sps, twin_sps = n / t_env, n / t_twin
    overhead = 100.0 * (t_env / t_twin - 1.0)
    aims = (
        env_sps >= AIM_STEPS_PER_S[shell_model],
        overhead <= AIM_OVERHEAD_PCT,
        reset_ms <= AIM_RESET_MS,
    )
    return dict(
        env=env_id.split("/")[1],
        shell_model=shell_model,
        steps=n,
        env_steps_per_s=env_sps,
        twin_steps_per_s=twin_sps,
        overhead_pct=overhead,
        paired_max_state_diff=max_diff,
        python_us_per_step=python_us,
        reset_ms=reset_ms,
        aims_met=" / ".join("yes" if ok else "no" for ok in aims),
    )


def run_env_benchmarks(seconds_per_case: float = 5.0) -> list[dict]:
    """One row per env id × shell model (see the module docstring for the columns)."""
    return [bench_case(env_id, sm, seconds_per_case) for env_id in ENV_IDS for sm in SHELL_MODELS]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=5.0, help="wall seconds of env stepping per case")
    parser.add_argument("--write", action="store_true", help="also write evaluation/results/benchmark_env.md")
    args = parser.parse_args(argv)
    from datetime import datetime, timezone

    from sphere_env.evaluation.experiments import RESULTS
    from sphere_env.provenance import machine_info
    from sphere_env.reporting import markdown_table

    info = machine_info()
    load = os.getloadavg()[0]
    rows = run_env_benchmarks(args.seconds)
    text = (
        "\n".join(
            [
                "# sphere_env environment benchmark",
                "",
                f"Generated {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC "
                f"by `python -m evaluation.experiments.benchmark_env` "
                f"(commit {info['commit']}); {info['cpu']}, {info['cores']} cores, 1-min load average at start "
                f"{load:.1f}. {args.seconds:g} s of env stepping per case.",
                "",
                markdown_table(rows, ENV_COLUMNS),
                "",
                f"Aims at 50 Hz: point >= {AIM_STEPS_PER_S['point']}, injected >= {AIM_STEPS_PER_S['injected']}, "
                f"hydroelastic >= {AIM_STEPS_PER_S['hydroelastic']} steps/s; overhead <= {AIM_OVERHEAD_PCT:.0f}%; "
                f"reset <= {AIM_RESET_MS:.0f} ms. Env steps/s can never exceed the bare twin's: where the twin itself "
                "is below the aim, only the overhead column is the env's to meet.",
            ]
        )
        + "\n"
    )
    if args.write:
        RESULTS.mkdir(parents=True, exist_ok=True)
        (RESULTS / "benchmark_env.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
