"""The envs of a training run: each training env built inside its worker, the evaluation env, the
VecEnv that steps them and the VecNormalize around it.

:func:`make_env` builds one Monitor-wrapped env (a module-level function, so ``SubprocVecEnv`` and
the batched workers pickle it by reference); :class:`EvaluationEpisodes` makes an env replay the
same evaluation episodes at every evaluation; :func:`make_vec_env` chooses the VecEnv from the
configuration's layout (``n_workers``, ``n_threads``) and :func:`wrap_normalize` adds VecNormalize,
fresh or from saved statistics.
"""

from __future__ import annotations

import csv
import time
from functools import partial
from pathlib import Path
from typing import Any, Mapping, Sequence

import gymnasium as gym

from sphere_env.training.config import MONITOR_KEYWORDS, TrainConfig, apply_env_wrappers

_ENV_MONITOR = None


def _monitor_class():
    """SB3's ``Monitor`` that passes assignments to settable properties of the wrapped env (such as
    ``SphereEnv.randomization``) through, so ``venv.set_attr("randomization", spec)`` reaches the env,
    validated, on every VecEnv (SB3's ``set_attr`` assigns on the outermost wrapper, where the value
    would otherwise be stored and ignored). Built on first use: stable-baselines3 is an extra."""
    global _ENV_MONITOR
    if _ENV_MONITOR is None:
        from stable_baselines3.common.monitor import Monitor

        class EnvMonitor(Monitor):
            def __setattr__(self, name: str, value: Any) -> None:
                env = self.__dict__.get("env")
                if (
                    env is not None
                    and name not in self.__dict__
                    and not hasattr(type(self), name)
                    and isinstance(getattr(type(env.unwrapped), name, None), property)
                ):
                    env.set_wrapper_attr(name, value)
                else:
                    super().__setattr__(name, value)

        _ENV_MONITOR = EnvMonitor
    return _ENV_MONITOR


class EvaluationEpisodes(gym.Wrapper):
    """Fixed evaluation episodes: the k-th reset since :meth:`restart_evaluation` runs at pressure
    ``pressures_kpa[k % len]`` (a reset option, so no randomization moves it) with seed
    ``seed + k`` (fixing the command), whatever seed the caller passes. Every evaluation round thus
    plays the same episodes, and best-model selection compares policies on them. An empty
    ``pressures_kpa`` keeps the seeds and leaves the pressure to the env."""

    def __init__(self, env: gym.Env, pressures_kpa: Sequence[float], seed: int):
        super().__init__(env)
        self.pressures_kpa = [float(p) for p in pressures_kpa]
        self.first_seed = int(seed)
        self.episode = 0

    def restart_evaluation(self) -> None:
        """The next reset plays the first evaluation episode again."""
        self.episode = 0

    def reset(self, *, seed: int | None = None, options: Mapping[str, Any] | None = None):
        k = self.episode
        self.episode += 1
        opts = dict(options or {})
        if self.pressures_kpa:
            opts.setdefault("pressure_kpa", self.pressures_kpa[k % len(self.pressures_kpa)])
        return self.env.reset(seed=self.first_seed + k, options=opts or None)


def make_env(
    env_id: str,
    env_kwargs: Mapping[str, Any],
    seed: int,
    monitor_file: str | None = None,
    torch_threads: int = 1,
    eval_pressures_kpa: Sequence[float] | None = None,
    env_wrapper: Sequence[Mapping[str, Mapping[str, Any]]] = (),
):
    """Build one Monitor-wrapped env seeded with ``seed`` (called inside the worker), inside the
    ``env_wrapper`` entries (``TrainConfig.env_wrapper``). ``eval_pressures_kpa`` (a list, possibly
    empty) makes it an evaluation env (:class:`EvaluationEpisodes`)."""
    import sphere_env  # noqa: F401 - registers the ids

    try:
        import torch

        torch.set_num_threads(torch_threads)
    except ImportError:  # pragma: no cover
        pass
    env = apply_env_wrappers(gym.make(env_id, **dict(env_kwargs)), env_wrapper)
    if eval_pressures_kpa is not None:
        env = EvaluationEpisodes(env, eval_pressures_kpa, seed)
    # A new file gets SB3's header (what stable_baselines3.common.monitor.load_results reads); a
    # resumed run appends to its file.
    fresh = monitor_file is None or not Path(monitor_file + ".monitor.csv").exists()
    env = _monitor_class()(env, filename=monitor_file, info_keywords=MONITOR_KEYWORDS, override_existing=fresh)
    if not fresh:  # the episode times continue from the file's last one, without the time the run was stopped
        env.t_start = time.time() - _last_monitor_time_s(Path(monitor_file + ".monitor.csv"))
    env.reset(seed=seed)
    env.action_space.seed(seed)
    return env


def _last_monitor_time_s(path: Path) -> float:
    """The ``t`` [s] of a Monitor CSV's last episode (0 without one)."""
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(line for line in f if not line.startswith("#"))]
    if len(rows) < 2:
        return 0.0
    return float(rows[-1][rows[0].index("t")])


def make_vec_env(cfg: TrainConfig, run_dir: Path | None, evaluation: bool = False):
    """Training or evaluation (one in-process env) VecEnv. Training: ``BatchedSubprocVecEnv`` when
    ``n_workers`` is set (``auto``: the usable cores, at most ``n_envs``), ``ThreadedVecEnv`` when
    ``n_threads`` is, else SB3's ``SubprocVecEnv`` whose bad calls raise in the caller
    (``SafeSubprocVecEnv``; ``DummyVecEnv`` for one env)."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    kwargs = cfg.make_kwargs(evaluation)
    mon = None if run_dir is None else run_dir / "monitor"
    if mon is not None:
        mon.mkdir(parents=True, exist_ok=True)
    if evaluation:
        fns = [
            partial(
                make_env,
                cfg.env_id,
                kwargs,
                cfg.eval_seed,
                None if mon is None else str(mon / "eval"),
                cfg.torch_threads,
                cfg.eval_pressures_kpa or [],
                cfg.env_wrapper,
            )
        ]
        return DummyVecEnv(fns)
    fns = [
        partial(
            make_env,
            cfg.env_id,
            kwargs,
            s,
            None if mon is None else str(mon / f"train_{rank}"),
            cfg.torch_threads,
            None,
            cfg.env_wrapper,
        )
        for rank, s in enumerate(cfg.worker_seeds)
    ]
    if cfg.n_envs == 1:
        venv = DummyVecEnv(fns)
    elif cfg.n_workers is not None:
        from sphere_env.training.vec_env import BatchedSubprocVecEnv, usable_cores

        n_workers = min(usable_cores(), cfg.n_envs) if cfg.n_workers == "auto" else cfg.n_workers
        venv = BatchedSubprocVecEnv(fns, n_workers)
    elif cfg.n_threads is not None:
        from sphere_env.training.vec_env import ThreadedVecEnv

        venv = ThreadedVecEnv(fns, None if cfg.n_threads == "auto" else cfg.n_threads)
    else:
        from sphere_env.training.vec_env import SafeSubprocVecEnv

        venv = SafeSubprocVecEnv(fns)
    venv.seed(cfg.seed)
    return venv


def wrap_normalize(cfg: TrainConfig, venv, evaluation: bool = False, stats: Path | None = None):
    """VecNormalize per ``cfg.normalize``, with the statistics and settings saved in ``stats`` when
    given (:func:`sphere_env.training.saved.read_stats`; refused by name when they do not fit the
    envs' observations)."""
    from stable_baselines3.common.vec_env import VecNormalize

    if cfg.normalize is None:
        return venv
    venv = VecNormalize(venv, **cfg.normalize)
    if stats is not None:
        from sphere_env.training.saved import read_stats

        saved = read_stats(stats)
        if saved.obs_rms.mean.shape != venv.obs_rms.mean.shape:
            raise ValueError(
                f"{stats}: statistics of observations of shape {saved.obs_rms.mean.shape}; the envs give "
                f"{venv.obs_rms.mean.shape}"
            )
        saved.into(venv)
    if evaluation:
        venv.training = False
        venv.norm_reward = False
    return venv
