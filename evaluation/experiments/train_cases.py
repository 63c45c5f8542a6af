"""The timed cases of the training benchmarks (:mod:`evaluation.experiments.benchmark_train`,
:mod:`evaluation.experiments.benchmark_recipe`): one env as a training worker builds it, and a PPO
model on a vec-env layout learning whole updates, each measuring its own wall, update, stepping and
CPU time; and the pinning of a case's threads and workers to some cores."""

from __future__ import annotations

import os
import time

import numpy as np

ENV_ID = "sphere_env/RampDescent-v2"  # the shipped PPO config's env (training/hyperparams/ppo.yml)
#: samples per PPO update (n_envs x n_steps) in every timed layout: the shipped RampDescent-v2 config's
ROLLOUT = 2048
#: (label, overrides of the shipped YAML section); None keys cancel the YAML's value. Every layout keeps
#: the shipped rollout of ROLLOUT samples per update (n_steps = ROLLOUT / n_envs).
LAYOUTS = {
    "shipped": ("shipped config", {}),
    "thread8": ("8 envs, 2 threads (ThreadedVecEnv)", {"n_envs": 8, "n_threads": 2}),
    "thread2": ("2 envs, 2 threads (ThreadedVecEnv)", {"n_envs": 2, "n_threads": 2}),
    "subproc2": ("2 envs, 1 process each (SubprocVecEnv)", {"n_envs": 2, "n_threads": None, "n_workers": None}),
    "proc16": ("16 envs in 2 blocks: this process + 1 worker (BatchedSubprocVecEnv)", {"n_envs": 16, "n_workers": 2}),
    "thread16": ("16 envs, 2 threads (ThreadedVecEnv)", {"n_envs": 16, "n_threads": 2}),
}


def usable_cores() -> int:
    from sphere_env.training.vec_env import usable_cores as _cores

    return _cores()


def _tasks(pid: int) -> list[int]:
    try:
        return [int(t) for t in os.listdir(f"/proc/{pid}/task")]
    except OSError:
        return []


def _pin(processes, cores: set[int]) -> None:
    """Every thread of this process and of ``processes`` (worker pids) onto ``cores``."""
    for pid in [os.getpid(), *[p.pid for p in processes]]:
        for tid in _tasks(pid):
            try:
                os.sched_setaffinity(tid, cores)
            except OSError:
                pass


def _cpu_s(pid: int) -> float:
    tick = os.sysconf("SC_CLK_TCK")
    try:
        fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / tick
    except (OSError, IndexError, ValueError):
        return 0.0


class SingleEnv:
    """One env as a training worker builds it, random actions, resets included."""

    def __init__(self, shell_model: str, seed: int = 0, env_id: str = ENV_ID, env_kwargs: dict | None = None):
        from sphere_env.training.config import resolve_config
        from sphere_env.training.env_factory import make_env

        # env_kwargs= merges over the YAML's env kwargs (an "env_kwargs" override would replace them,
        # dropping the randomization and the observation options of the shipped config).
        kwargs = {"shell_model": shell_model, **(env_kwargs or {})}
        cfg = resolve_config(env_id, "ppo", env_kwargs=kwargs, seed=seed, build_env=False)
        self.env = make_env(cfg.env_id, cfg.make_kwargs(), seed)
        self.rng = np.random.default_rng(seed)
        self.twin = self.env.unwrapped.twin
        self.steps, self.wall, self.advance_s = 0, 0.0, 0.0
        inner = self.twin.advance_unchecked

        def timed(duration_s, motor_torque):  # time inside Drake's AdvanceTo (GIL released)
            t0 = time.perf_counter()
            inner(duration_s, motor_torque)
            self.advance_s += time.perf_counter() - t0

        self._timed = timed

    def run(self, seconds: float) -> None:
        acts = self.rng.uniform(-1.0, 1.0, size=(4096, 2)).astype(np.float32)
        self.twin.advance_unchecked = self._timed
        t0 = time.perf_counter()
        k = 0
        while time.perf_counter() - t0 < seconds:
            _, _, term, trunc, _ = self.env.step(acts[k % len(acts)])
            k += 1
            if term or trunc:
                self.env.reset()
        self.wall += time.perf_counter() - t0
        self.steps += k
        del self.twin.advance_unchecked

    def close(self) -> None:
        self.env.close()


class TrainCase:
    """A PPO model on a layout; ``run`` learns whole updates for about ``seconds``."""

    def __init__(
        self,
        shell_model: str,
        layout: str,
        cores: int | None = None,
        seed: int = 0,
        env_id: str = ENV_ID,
        env_kwargs: dict | None = None,
    ):
        from sphere_env.training.config import algo_class, resolve_config
        from sphere_env.training.env_factory import make_vec_env, wrap_normalize

        label, over = LAYOUTS[layout]
        if "n_envs" in over:
            over = dict(over, n_steps=ROLLOUT // over["n_envs"])
        kwargs = {"shell_model": shell_model, **(env_kwargs or {})}
        cfg = resolve_config(env_id, "ppo", overrides=over, env_kwargs=kwargs, seed=seed, build_env=False)
        if env_id == ENV_ID and cfg.n_envs * cfg.hyperparams["n_steps"] != ROLLOUT:
            raise ValueError(
                f"layout {layout!r}: {cfg.n_envs} x {cfg.hyperparams['n_steps']} samples per update, "
                f"not the shipped {ROLLOUT} (ROLLOUT)"
            )
        self.cfg, self.layout, self.label, self.shell_model = cfg, layout, label, shell_model
        self.cores = cores or usable_cores()
        self.venv = wrap_normalize(cfg, make_vec_env(cfg, None))
        self.model = algo_class("ppo")(cfg.policy, self.venv, seed=seed, device="cpu", **cfg.algo_kwargs())
        self.rollout = cfg.n_envs * cfg.hyperparams["n_steps"]
        self.update_s = 0.0
        train = self.model.train

        def timed_train():
            t0 = time.perf_counter()
            train()
            self.update_s += time.perf_counter() - t0

        self.model.train = timed_train
        # Time inside the innermost VecEnv's step_async and step_wait (the env stepping, all threads
        # or workers; a worker may step its block while step_async sends to the next one), to separate
        # the main process's own work per vectorized step from the stepping.
        inner = self.venv
        while hasattr(inner, "venv"):
            inner = inner.venv
        self.stepping_s = 0.0
        step_async, step_wait = inner.step_async, inner.step_wait
        started = [0.0]

        def timed_step_async(actions):
            started[0] = time.perf_counter()
            step_async(actions)

        def timed_step_wait():
            out = step_wait()
            self.stepping_s += time.perf_counter() - started[0]
            return out

        inner.step_async, inner.step_wait = timed_step_async, timed_step_wait
        self._learn()  # warm-up: first reset and update, not timed
        self.steps, self.wall, self.update_s, self.cpu_main, self.stepping_s = 0, 0.0, 0.0, 0.0, 0.0

    def _learn(self) -> None:
        from sphere_env.training.session import unchecked_distributions

        with unchecked_distributions():  # as the trainer runs
            self.model.learn(total_timesteps=self.rollout, reset_num_timesteps=False)

    def run_updates(self, updates: int) -> None:
        """Learn ``updates`` whole updates (rollout and PPO update each), timed as :meth:`run`."""
        s0, c0, t0 = self.model.num_timesteps, _cpu_s(os.getpid()), time.perf_counter()
        for _ in range(updates):
            self._learn()
        self.wall += time.perf_counter() - t0
        self.cpu_main += _cpu_s(os.getpid()) - c0
        self.steps += self.model.num_timesteps - s0

    @property
    def processes(self):
        v = self.venv
        while hasattr(v, "venv"):
            v = v.venv
        return list(getattr(v, "processes", []))

    def run(self, seconds: float) -> None:
        all_cores = os.sched_getaffinity(0)
        if self.cores < len(all_cores):
            _pin(self.processes, set(sorted(all_cores)[: self.cores]))
        try:
            s0, c0, t0 = self.model.num_timesteps, _cpu_s(os.getpid()), time.perf_counter()
            while time.perf_counter() - t0 < seconds:
                self._learn()
            self.wall += time.perf_counter() - t0
            self.cpu_main += _cpu_s(os.getpid()) - c0
            self.steps += self.model.num_timesteps - s0
        finally:
            if self.cores < len(all_cores):
                _pin(self.processes, all_cores)

    def close(self) -> None:
        self.venv.close()
