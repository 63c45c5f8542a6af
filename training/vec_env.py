"""Vectorized envs for training (SB3 ``VecEnv`` API): ``ThreadedVecEnv`` and ``BatchedSubprocVecEnv``.

``ThreadedVecEnv`` steps all envs in the main process on a persistent pool of threads: pydrake
releases the GIL inside ``Simulator.AdvanceTo``, so the twins' physics runs on several cores at once
while only the envs' own Python (a small share of a step) is serialized. No pipes, no pickling,
and the policy's forward pass is shared by all envs.


SB3's ``SubprocVecEnv`` runs one env per process, so every env step pays one pipe round trip and
the main process pays one policy forward pass per ``n_envs`` steps. On a 2-core machine the main
process then becomes the bottleneck (≈0.7 ms of main-process CPU per env step with 2 envs,
measured). Hosting ``n_envs / n_workers`` envs in each of ``n_workers`` processes amortizes both: one
message per worker per step, one forward pass for all envs. Semantics match ``SubprocVecEnv``
exactly (auto-reset, ``terminal_observation``, ``TimeLimit.truncated``, ``reset_infos``, seeds).
"""

from __future__ import annotations

import multiprocessing as mp
import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable, Sequence

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import DummyVecEnv
from stable_baselines3.common.vec_env.base_vec_env import CloudpickleWrapper, VecEnv
from stable_baselines3.common.vec_env.util import obs_space_info


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity, e.g. under ``taskset``)."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # pragma: no cover - not Linux
        return max(os.cpu_count() or 1, 1)


class ThreadedVecEnv(DummyVecEnv):
    """``len(env_fns)`` envs in this process, stepped by ``n_threads`` threads (contiguous blocks,
    the calling thread steps the first block, a persistent pool the others).

    Results are those of ``DummyVecEnv`` for the same seeds and actions (each env's step and
    auto-reset are done by one thread; buffers are filled in env order afterwards), whatever
    ``n_threads`` is. Envs must not share mutable state (sphere_env envs each own their twin and
    random generator).

    :param env_fns: env factories (called here, in order).
    :param n_threads: stepping threads, 1..len(env_fns); ``None``: the usable cores (at most one
        thread per env).
    """

    def __init__(self, env_fns: Sequence[Callable[[], gym.Env]], n_threads: int | None = None):
        n = len(env_fns)
        if n_threads is None:
            n_threads = min(usable_cores(), n)
        if isinstance(n_threads, bool) or not isinstance(n_threads, int) or not 1 <= n_threads <= n:
            raise ValueError(f"n_threads: value {n_threads!r} must be an integer within 1..{n} (the number of envs)")
        super().__init__(list(env_fns))
        per, extra = divmod(n, n_threads)
        bounds = np.cumsum([0] + [per + (1 if k < extra else 0) for k in range(n_threads)])
        self.blocks = [list(range(bounds[k], bounds[k + 1])) for k in range(n_threads)]
        self.n_threads = n_threads
        self._pool = ThreadPoolExecutor(max_workers=n_threads - 1, thread_name_prefix="env") if n_threads > 1 else None

    def _step_block(self, block: list[int]) -> list[tuple]:
        out = []
        for i in block:
            obs, rew, terminated, truncated, info = self.envs[i].step(self.actions[i])
            done = terminated or truncated
            info["TimeLimit.truncated"] = truncated and not terminated
            reset_info = None
            if done:
                info["terminal_observation"] = obs
                obs, reset_info = self.envs[i].reset()
            out.append((i, obs, rew, done, info, reset_info))
        return out

    def step_wait(self):
        futures = [self._pool.submit(self._step_block, b) for b in self.blocks[1:]] if self._pool else []
        results = self._step_block(self.blocks[0])
        for f in futures:
            results += f.result()
        for i, obs, rew, done, info, reset_info in results:
            self.buf_rews[i] = rew
            self.buf_dones[i] = done
            self.buf_infos[i] = info
            if reset_info is not None:
                self.reset_infos[i] = reset_info
            self._save_obs(i, obs)
        # The info dicts are this step's fresh dicts (Gymnasium's convention; sphere_env's envs build
        # new ones every step): a shallow copy each, not DummyVecEnv's deepcopy (≈8% of a PPO step).
        return self._obs_from_buf(), np.copy(self.buf_rews), np.copy(self.buf_dones), [dict(i) for i in self.buf_infos]

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None
        super().close()


def _worker(remote, parent_remote, fns: CloudpickleWrapper) -> None:
    from stable_baselines3.common.env_util import is_wrapped

    parent_remote.close()
    envs = [fn() for fn in fns.var]
    reset_infos: list[dict] = [{} for _ in envs]
    try:
        while True:
            cmd, data = remote.recv()
            if cmd == "step":
                out = []
                for i, (env, action) in enumerate(zip(envs, data)):
                    obs, reward, terminated, truncated, info = env.step(action)
                    done = terminated or truncated
                    info["TimeLimit.truncated"] = truncated and not terminated
                    if done:
                        info["terminal_observation"] = obs
                        obs, reset_infos[i] = env.reset()
                    out.append((obs, reward, done, info, reset_infos[i]))
                remote.send(out)
            elif cmd == "reset":
                out = []
                for i, (env, (seed, options)) in enumerate(zip(envs, data)):
                    kw = {"options": options} if options else {}
                    obs, reset_infos[i] = env.reset(seed=seed, **kw)
                    out.append((obs, reset_infos[i]))
                remote.send(out)
            elif cmd == "render":
                remote.send([env.render() for env in envs])
            elif cmd == "close":
                for env in envs:
                    env.close()
                remote.close()
                break
            elif cmd == "get_spaces":
                remote.send((envs[0].observation_space, envs[0].action_space))
            elif cmd == "env_method":
                local, name, args, kwargs = data
                remote.send([envs[j].get_wrapper_attr(name)(*args, **kwargs) for j in local])
            elif cmd == "get_attr":
                local, name = data
                remote.send([envs[j].get_wrapper_attr(name) for j in local])
            elif cmd == "has_attr":
                local, name = data
                out = []
                for j in local:
                    try:
                        envs[j].get_wrapper_attr(name)
                        out.append(True)
                    except AttributeError:
                        out.append(False)
                remote.send(out)
            elif cmd == "set_attr":
                local, name, value = data
                for j in local:
                    setattr(envs[j], name, value)
                remote.send(None)
            elif cmd == "is_wrapped":
                local, cls = data
                remote.send([is_wrapped(envs[j], cls) for j in local])
            else:
                raise NotImplementedError(f"`{cmd}` is not implemented in the worker")
    except (EOFError, KeyboardInterrupt):
        pass


class BatchedSubprocVecEnv(VecEnv):
    """``len(env_fns)`` envs on ``n_workers`` processes (contiguous blocks, env i on worker
    i // ceil(n / n_workers)).

    :param env_fns: picklable env factories.
    :param n_workers: worker processes (≤ number of envs).
    :param start_method: multiprocessing start method (default ``forkserver`` when available).
    """

    def __init__(self, env_fns: Sequence[Callable[[], gym.Env]], n_workers: int, start_method: str | None = None):
        n = len(env_fns)
        if not 1 <= n_workers <= n:
            raise ValueError(f"n_workers: value {n_workers} must be within 1..{n} (the number of envs)")
        per = -(-n // n_workers)
        self.blocks = [list(range(i, min(i + per, n))) for i in range(0, n, per)]
        self.waiting = False
        self.closed = False
        if start_method is None:
            start_method = "forkserver" if "forkserver" in mp.get_all_start_methods() else "spawn"
        ctx = mp.get_context(start_method)
        self.remotes, work_remotes = zip(*[ctx.Pipe() for _ in self.blocks])
        self.processes = []
        for block, work_remote, remote in zip(self.blocks, work_remotes, self.remotes):
            args = (work_remote, remote, CloudpickleWrapper([env_fns[i] for i in block]))
            p = ctx.Process(target=_worker, args=args, daemon=True)
            p.start()
            self.processes.append(p)
            work_remote.close()
        self.remotes[0].send(("get_spaces", None))
        observation_space, action_space = self.remotes[0].recv()
        super().__init__(n, observation_space, action_space)
        self._keys, shapes, dtypes = obs_space_info(observation_space)

    # ---- stepping ----------------------------------------------------------------------------------
    def step_async(self, actions: np.ndarray) -> None:
        for remote, block in zip(self.remotes, self.blocks):
            remote.send(("step", [actions[i] for i in block]))
        self.waiting = True

    def step_wait(self):
        results = [r for remote in self.remotes for r in remote.recv()]
        self.waiting = False
        obs, rews, dones, infos, self.reset_infos = zip(*results)
        return np.stack(obs), np.array(rews, dtype=np.float32), np.array(dones), list(infos)

    def reset(self):
        for remote, block in zip(self.remotes, self.blocks):
            remote.send(("reset", [(self._seeds[i], self._options[i]) for i in block]))
        results = [r for remote in self.remotes for r in remote.recv()]
        obs, self.reset_infos = zip(*results)
        self.reset_infos = list(self.reset_infos)
        self._reset_seeds()
        self._reset_options()
        return np.stack(obs)

    def close(self) -> None:
        if self.closed:
            return
        if self.waiting:
            for remote in self.remotes:
                remote.recv()
        for remote in self.remotes:
            remote.send(("close", None))
        for p in self.processes:
            p.join()
        self.closed = True

    def get_images(self) -> Sequence[np.ndarray | None]:
        for remote in self.remotes:
            remote.send(("render", None))
        return [img for remote in self.remotes for img in remote.recv()]

    # ---- attribute access --------------------------------------------------------------------------
    def _route(self, indices) -> list[tuple[Any, list[int]]]:
        """[(remote, local indices)] for the global ``indices``, in worker order."""
        idx = self._get_indices(indices)
        out = []
        for remote, block in zip(self.remotes, self.blocks):
            local = [block.index(i) for i in idx if i in block]
            if local:
                out.append((remote, local))
        return out

    def _gather(self, cmd: str, indices, *payload) -> list[Any]:
        routes = self._route(indices)
        for remote, local in routes:
            remote.send((cmd, (local, *payload)))
        return [x for remote, _ in routes for x in remote.recv()]

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        return self._gather("get_attr", indices, attr_name)

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        routes = self._route(indices)
        for remote, local in routes:
            remote.send(("set_attr", (local, attr_name, value)))
        for remote, _ in routes:
            remote.recv()

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list[Any]:
        return self._gather("env_method", indices, method_name, method_args, method_kwargs)

    def has_attr(self, attr_name: str) -> bool:
        return all(self._gather("has_attr", None, attr_name))

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices=None) -> list[bool]:
        return self._gather("is_wrapped", indices, wrapper_class)
