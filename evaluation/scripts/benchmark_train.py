"""PPO training throughput: environment steps per second with 2 SubprocVecEnv workers.

The shipped PPO hyperparameters for ``sphere_env/RampDescent-v0`` (training/hyperparams/ppo.yml),
VecNormalize on, pressure randomization on, per shell model (point contact is the headline case).
Timing starts after the first rollout+update (worker start-up and imports excluded) and
includes rollouts and gradient updates, as a real training run does. The CPU seconds of the main
process and of the workers are reported too, with the throughput they imply on an otherwise idle
machine (the development machine is shared, so the measured wall-clock rate depends on its load).

    python -m evaluation.scripts.benchmark_train [--seconds 30] [--shell-models point injected]
"""

from __future__ import annotations

import argparse
import os
import time

ENV_ID = "sphere_env/RampDescent-v0"
TRAIN_COLUMNS = [("case", "case", ""), ("n_workers", "worker processes", "{:d}"), ("steps", "env steps timed", "{:d}"),
                 ("wall_s", "wall s", "{:.1f}"), ("steps_per_s", "env steps/s", "{:.0f}"),
                 ("cpu_main_ms_per_step", "main CPU ms/step", "{:.3f}"),
                 ("cpu_workers_ms_per_step", "workers CPU ms/step", "{:.3f}"),
                 ("idle_estimate_steps_per_s", "idle-machine estimate steps/s", "{:.0f}"),
                 ("load_avg_1min", "load avg", "{:.1f}")]


def _throughput(shell_model: str, seconds: float, n_envs: int = 2, n_workers: int | None = None, seed: int = 0) -> dict:
    import torch
    from stable_baselines3.common.callbacks import BaseCallback

    from sphere_env.training.config import algo_class, resolve_config
    from sphere_env.training.train import make_vec_env, wrap_normalize

    overrides: dict = {"n_envs": n_envs, "env_kwargs": {"shell_model": shell_model}}
    if n_workers is not None:  # same 512-sample rollout per update as the shipped 2 x 256
        overrides.update(n_workers=n_workers, n_steps=max(512 // n_envs, 1))
    cfg = resolve_config(ENV_ID, "ppo", overrides=overrides, seed=seed, build_env=False)
    torch.set_num_threads(cfg.torch_threads)

    class Clock(BaseCallback):
        """Starts the clock after the first update; stops training after ``seconds``."""

        def __init__(self):
            super().__init__()
            self.t0 = None
            self.s0 = 0
            self.t1 = None

        def _on_rollout_start(self) -> None:
            if self.t0 is None and self.num_timesteps > 0:
                self.t0, self.s0 = time.perf_counter(), self.num_timesteps
                self.c0 = (time.process_time(), _worker_cpu_s(venv))

        def _on_step(self) -> bool:
            if self.t0 is not None and time.perf_counter() - self.t0 > seconds:
                return False
            return True

        def _on_rollout_end(self) -> None:
            if self.t0 is not None:
                self.t1, self.s1 = time.perf_counter(), self.num_timesteps

    venv = wrap_normalize(cfg, make_vec_env(cfg, None))
    try:
        model = algo_class("ppo")(cfg.policy, venv, seed=seed, device="cpu", **cfg.algo_kwargs())
        clock = Clock()
        model.learn(total_timesteps=10**9, callback=clock)
        # the last (interrupted) rollout is counted up to where it stopped: no update follows it
        t1 = time.perf_counter()
        steps = model.num_timesteps - clock.s0
        wall = t1 - clock.t0
        cpu_main = time.process_time() - clock.c0[0]
        cpu_workers = _worker_cpu_s(venv) - clock.c0[1]
    finally:
        venv.close()
    # What the same work needs on an otherwise idle machine: the CPU seconds spent, spread over the
    # cores, but never less than the main process's own share (it is serial with the workers).
    cores = max(len(os.sched_getaffinity(0)), 1)
    idle_wall = max((cpu_main + cpu_workers) / cores, cpu_main, cpu_workers / n_envs)
    layout = (f"{n_envs} SubprocVecEnv workers" if n_workers is None
              else f"{n_envs} envs on {n_workers} workers (BatchedSubprocVecEnv)")
    return dict(case=f"PPO, RampDescent, {shell_model} contact, {layout}", shell_model=shell_model,
                n_envs=n_envs, n_workers=n_workers or n_envs,
                steps=int(steps), wall_s=wall, steps_per_s=steps / wall, cpu_main_ms_per_step=1e3 * cpu_main / steps,
                cpu_workers_ms_per_step=1e3 * cpu_workers / steps, idle_estimate_steps_per_s=steps / idle_wall,
                load_avg_1min=os.getloadavg()[0])


def _worker_cpu_s(venv) -> float:
    """CPU seconds (user + system) used so far by the SubprocVecEnv worker processes."""
    while hasattr(venv, "venv"):
        venv = venv.venv
    total = 0.0
    tick = os.sysconf("SC_CLK_TCK")
    for proc in getattr(venv, "processes", []):
        try:
            fields = open(f"/proc/{proc.pid}/stat").read().rsplit(")", 1)[1].split()
            total += (int(fields[11]) + int(fields[12])) / tick
        except (OSError, IndexError, ValueError):
            pass
    return total


def run_train_benchmark(seconds: float = 30.0, shell_models: tuple[str, ...] = ("point",),
                        batched: bool = True) -> list[dict]:
    """PPO training throughput [env steps/s] with 2 worker processes, per shell model: the shipped
    config (2 envs, SubprocVecEnv) and, with ``batched``, 8 envs on the same 2 workers."""
    rows = []
    for m in shell_models:
        rows.append(_throughput(m, seconds))
        if batched:
            rows.append(_throughput(m, seconds, n_envs=8, n_workers=2))
    return rows


def main(argv: list[str] | None = None) -> None:
    from sphere_env.evaluation._report import machine_info, markdown_table

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=30.0, help="timed wall seconds per case")
    parser.add_argument("--shell-models", nargs="+", default=["point"])
    args = parser.parse_args(argv)
    rows = run_train_benchmark(args.seconds, tuple(args.shell_models))
    info = machine_info()
    print(f"Machine: {info['cpu']}, {info['cores']} cores; torch {info['torch']}, sb3 {info['stable_baselines3']}\n")
    print(markdown_table(rows, TRAIN_COLUMNS))


if __name__ == "__main__":
    main()
