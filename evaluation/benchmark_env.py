"""Environment speed benchmark (issue 3): env steps/s vs the bare twin, and reset() time.

Per env id × shell model, single process, 50 Hz control (20 ms chunks, 5 ms plant step):

* **env steps/s**: ``gym.make(id, shell_model=...)`` (with Gymnasium's default wrappers) stepped
  with uniformly random actions drawn beforehand; episode resets are not timed.
* **twin steps/s**: the bare :class:`~sphere_env.physics.twin.Twin` of the same configuration
  replaying exactly the same torques and resets (same pressure per episode) with the public
  ``advance(0.02, τ)`` — the same trajectories, so the difference is the env's own work.
* **overhead %** = env time per step / twin time per step − 1.
* **reset ms**: mean wall time of ``env.reset()`` (diagram reused; no rebuild).

    python -m evaluation.benchmark_env [--seconds 5]
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import sphere_env  # noqa: F401  (registers ids)
from sphere_env.physics.twin import InitialState, Twin

ENV_IDS = ("sphere_env/RampDescent-v0", "sphere_env/Roll-v0")
SHELL_MODELS = ("point", "injected", "hydroelastic")
#: Issue 3 aims on one core at 50 Hz.
AIM_STEPS_PER_S = {"point": 1800, "injected": 1600, "hydroelastic": 500}
AIM_OVERHEAD_PCT = 15.0
AIM_RESET_MS = 5.0

ENV_COLUMNS = [
    ("env", "env", ""),
    ("shell_model", "shell", ""),
    ("env_steps_per_s", "env steps/s", "{:.0f}"),
    ("twin_steps_per_s", "bare twin steps/s", "{:.0f}"),
    ("overhead_pct", "env overhead %", "{:+.1f}"),
    ("reset_ms", "reset ms", "{:.2f}"),
    ("aims_met", "aims (steps/s, overhead, reset)", ""),
]


def bench_case(env_id: str, shell_model: str, seconds: float, seed: int = 0) -> dict:
    env = gym.make(env_id, shell_model=shell_model)
    u = env.unwrapped
    rng = np.random.default_rng(seed)
    actions = rng.uniform(-1.0, 1.0, size=(200_000, 2)).astype(np.float32)
    episodes: list[tuple[float, int, int]] = []  # (pressure, first action index, n actions)
    env.reset(seed=seed)
    env.step(actions[0])  # warm-up (first-step checker)
    obs, info = env.reset(seed=seed)
    start, i, t_env = 0, 0, 0.0
    pressure = info["pressure_kpa"]
    deadline = time.perf_counter() + seconds
    while time.perf_counter() < deadline and i < len(actions) - 100:
        t0 = time.perf_counter()
        for _ in range(50):
            _, _, term, trunc, info = env.step(actions[i])
            i += 1
            if term or trunc:
                break
        t_env += time.perf_counter() - t0
        if term or trunc:
            episodes.append((pressure, start, i - start))
            _, info = env.reset()
            pressure, start = info["pressure_kpa"], i
    episodes.append((pressure, start, i - start))
    n_env = i

    # Reset time (same incline, diagram reused).
    t0 = time.perf_counter()
    n_reset = 50
    for _ in range(n_reset):
        env.reset()
    reset_ms = (time.perf_counter() - t0) / n_reset * 1e3

    # Bare twin replaying the same torques and resets.
    twin = Twin(u.twin.config)
    lim = np.array([u.steer_torque_limit_nm, -u.drive_torque_limit_nm])
    t_twin = 0.0
    for p, first, n in episodes:
        twin.reset(InitialState(), pressure_kpa=p)
        torques = [tuple(a * lim) for a in np.clip(actions[first:first + n].astype(float), -1, 1)]
        t0 = time.perf_counter()
        for tau in torques:
            try:
                twin.advance(0.02, tau)
            except (RuntimeError, ValueError):
                break
        t_twin += time.perf_counter() - t0
    env.close()
    env_sps, twin_sps = n_env / t_env, n_env / t_twin
    overhead = 100.0 * (t_env / t_twin - 1.0)
    aims = (
        env_sps >= AIM_STEPS_PER_S[shell_model], overhead <= AIM_OVERHEAD_PCT, reset_ms <= AIM_RESET_MS,
    )
    return dict(env=env_id.split("/")[1], shell_model=shell_model, steps=n_env, episodes=len(episodes),
                env_steps_per_s=env_sps, twin_steps_per_s=twin_sps, overhead_pct=overhead, reset_ms=reset_ms,
                aims_met=" / ".join("yes" if ok else "no" for ok in aims))


def run_env_benchmarks(seconds_per_case: float = 5.0) -> list[dict]:
    """One row per env id × shell model (see the module docstring for the columns)."""
    return [bench_case(env_id, sm, seconds_per_case) for env_id in ENV_IDS for sm in SHELL_MODELS]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=5.0, help="wall seconds of env stepping per case")
    args = parser.parse_args(argv)
    from evaluation._report import markdown_table

    rows = run_env_benchmarks(args.seconds)
    print(markdown_table(rows, ENV_COLUMNS))
    print(f"\nAims at 50 Hz: point >= {AIM_STEPS_PER_S['point']}, injected >= {AIM_STEPS_PER_S['injected']}, "
          f"hydroelastic >= {AIM_STEPS_PER_S['hydroelastic']} steps/s; overhead <= {AIM_OVERHEAD_PCT:.0f}%; "
          f"reset <= {AIM_RESET_MS:.0f} ms.")


if __name__ == "__main__":
    main()
