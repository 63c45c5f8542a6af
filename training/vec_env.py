"""Vectorized envs for training (SB3 ``VecEnv`` API): ``BatchedSubprocVecEnv`` and ``ThreadedVecEnv``.

SB3's ``SubprocVecEnv`` runs one env per process, so every env step pays one pipe round trip and
the main process pays one policy forward pass per ``n_envs`` steps. On a 2-core machine the main
process then becomes the bottleneck (≈0.7 ms of main-process CPU per env step with 2 envs,
measured). ``BatchedSubprocVecEnv`` (the trainer's default, ``n_workers: auto``) splits the envs
into one block per usable core: the calling process steps the first block itself and one worker
process each of the others, so a step costs one message per worker and one forward pass for all
envs. Semantics match ``SubprocVecEnv`` exactly (auto-reset, ``terminal_observation``,
``TimeLimit.truncated``, ``reset_infos``, seeds).

``ThreadedVecEnv`` steps all envs in the main process on a persistent pool of threads: pydrake
releases the GIL inside ``Simulator.AdvanceTo``, so the twins' physics runs on several cores at once
while the envs' own Python (a small share of a step) is serialized. What that serialization costs
depends on the machine: where handing the GIL from one core to another is slow, two threads step
no faster than one (measured; docs/results/training_speed.md). Worker processes share no GIL.
"""

from __future__ import annotations

import io
import multiprocessing as mp
import os
import pickle
import time
from concurrent.futures import ThreadPoolExecutor
from functools import partial
from multiprocessing.reduction import ForkingPickler
from typing import Any, Callable, Sequence

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv
from stable_baselines3.common.vec_env.base_vec_env import CloudpickleWrapper, VecEnv

from sphere_env.parallel import deferred_interrupts
from sphere_env.schemas import checker, count

#: The module the fork server of the workers imports before it serves: it ignores SIGINT, and so
#: does every worker it forks, from the fork on (:mod:`sphere_env.training.worker_signals`).
WORKER_PRELOAD = "sphere_env.training.worker_signals"


def _worker_start_method(start_method: str | None = None) -> str:
    """The multiprocessing start method of worker processes (``forkserver`` where available, else
    ``spawn``, unless ``start_method`` names one). For ``forkserver`` it first sets the preload of
    the process's one fork server to :data:`WORKER_PRELOAD`, so that its workers ignore Ctrl-C from
    the fork on, whichever vector env starts the server first."""
    if start_method is None:
        start_method = "forkserver" if "forkserver" in mp.get_all_start_methods() else "spawn"
    if start_method == "forkserver":
        mp.get_context("forkserver").set_forkserver_preload(["__main__", WORKER_PRELOAD])
    return start_method


#: Seconds :meth:`BatchedSubprocVecEnv.close` waits, for all workers together, before stopping the
#: ones that have not ended.
CLOSE_TIMEOUT_S = 10.0


def _array(data: bytearray, dtype: str, shape: tuple[int, ...]) -> np.ndarray:
    return np.frombuffer(data, dtype).reshape(shape)


class _Pickler(ForkingPickler):
    """multiprocessing's pickler, with numeric arrays as their bytes, dtype and shape: numpy's own
    reduction costs ≈9 µs to dump and ≈5 µs to load per array, which for the few small arrays of
    every env's step (observation, ``info`` entries) came to about half of a worker's reply
    (measured). The loaded array is writable and equal in dtype, shape and every bit."""

    def reducer_override(self, obj):
        if type(obj) is np.ndarray and obj.dtype.kind in "biuf" and obj.flags.c_contiguous:
            return _array, (bytearray(obj), obj.dtype.str, obj.shape)
        return NotImplemented


def _send_message(remote, obj) -> None:
    """``remote.send(obj)`` with :class:`_Pickler`; :func:`_receive_message` reads it."""
    buf = io.BytesIO()
    _Pickler(buf, pickle.HIGHEST_PROTOCOL).dump(obj)
    remote.send_bytes(buf.getbuffer())


def _receive_message(remote):
    return pickle.loads(remote.recv_bytes())


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity, e.g. under ``taskset``)."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # pragma: no cover - not Linux
        return max(os.cpu_count() or 1, 1)


def _step_env(env: gym.Env, action) -> tuple:
    """One step with SB3's auto-reset: ``(obs, reward, done, info, reset_info)``; on an episode's end
    ``info`` holds ``terminal_observation``, ``obs`` is the next episode's first and ``reset_info``
    its reset info (else None)."""
    obs, reward, terminated, truncated, info = env.step(action)
    done = terminated or truncated
    info["TimeLimit.truncated"] = truncated and not terminated
    reset_info = None
    if done:
        info["terminal_observation"] = obs
        obs, reset_info = env.reset()
    return obs, reward, done, info, reset_info


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
        n_threads = checker(count(1, n))(n_threads, "n_threads")  # at most one thread per env
        super().__init__(list(env_fns))
        per, extra = divmod(n, n_threads)
        bounds = np.cumsum([0] + [per + (1 if k < extra else 0) for k in range(n_threads)])
        self.blocks = [list(range(bounds[k], bounds[k + 1])) for k in range(n_threads)]
        self.n_threads = n_threads
        self._pool = ThreadPoolExecutor(max_workers=n_threads - 1, thread_name_prefix="env") if n_threads > 1 else None

    def _step_block(self, block: list[int]) -> list[tuple]:
        return [(i, *_step_env(self.envs[i], self.actions[i])) for i in block]

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


class _Block:
    """The envs of one block and what a :class:`BatchedSubprocVecEnv` asks of them: run in a worker
    process, or in the calling process for the first block."""

    def __init__(self, fns: Sequence[Callable[[], gym.Env]]):
        self.envs = [fn() for fn in fns]
        self.reset_infos: list[dict] = [{} for _ in self.envs]

    def step(self, actions) -> tuple:
        """One step of every env: ``(observations stacked, rewards, dones, infos, new reset infos
        by env index in the block)``; a reset info goes out once, when its episode starts (the
        caller keeps it until the env's next reset, as SB3's ``SubprocVecEnv`` resends it)."""
        obs, rewards, dones, infos, resets = [], [], [], [], {}
        for i, (env, action) in enumerate(zip(self.envs, actions)):
            o, reward, done, info, reset_info = _step_env(env, action)
            if reset_info is not None:
                self.reset_infos[i] = resets[i] = reset_info
            obs.append(o)
            rewards.append(reward)
            dones.append(done)
            infos.append(info)
        return np.stack(obs), rewards, dones, infos, resets

    def handle(self, cmd: str, data):
        """The reply to ``cmd`` (every command but ``close``)."""
        from stable_baselines3.common.env_util import is_wrapped

        envs = self.envs
        if cmd == "step":
            return self.step(data)
        if cmd == "reset":
            out = []
            for i, (env, (seed, options)) in enumerate(zip(envs, data)):
                kw = {"options": options} if options else {}
                obs, self.reset_infos[i] = env.reset(seed=seed, **kw)
                out.append((obs, self.reset_infos[i]))
            return out
        if cmd == "render":
            return [env.render() for env in envs]
        if cmd == "get_spaces":
            return envs[0].observation_space, envs[0].action_space
        local = data[0]
        if cmd == "env_method":
            _, name, args, kwargs = data
            return [envs[j].get_wrapper_attr(name)(*args, **kwargs) for j in local]
        if cmd == "get_attr":
            return [envs[j].get_wrapper_attr(data[1]) for j in local]
        if cmd == "has_attr":
            out = []
            for j in local:
                try:
                    envs[j].get_wrapper_attr(data[1])
                    out.append(True)
                except AttributeError:
                    out.append(False)
            return out
        if cmd == "set_attr":
            for j in local:
                setattr(envs[j], data[1], data[2])
            return None
        if cmd == "is_wrapped":
            return [is_wrapped(envs[j], data[1]) for j in local]
        raise NotImplementedError(f"`{cmd}` is not implemented in the worker")

    def close(self) -> None:
        for env in self.envs:
            env.close()


#: Commands whose failure (a bad argument from the caller) is sent back and raised in the caller
#: instead of ending the worker.
_CALLER_COMMANDS = ("env_method", "get_attr", "set_attr", "has_attr", "is_wrapped")


class _Failed:
    """A command's exception, carried back to the calling process."""

    def __init__(self, err: BaseException):
        self.kind = type(err).__name__
        self.message = str(err)

    def raise_(self):
        cls = {
            "ValueError": ValueError,
            "TypeError": TypeError,
            "AttributeError": AttributeError,
            "KeyError": KeyError,
        }.get(self.kind, RuntimeError)
        raise cls(self.message if cls is not RuntimeError else f"{self.kind}: {self.message}")


def _answer(block: "_Block", cmd: str, data):
    """``block.handle``, with a caller command's exception returned as :class:`_Failed`."""
    if cmd not in _CALLER_COMMANDS:
        return block.handle(cmd, data)
    try:
        return block.handle(cmd, data)
    except Exception as err:  # noqa: BLE001 - any failure of the caller's request goes back to it
        return _Failed(err)


def _worker(remote, parent_remote, fns: CloudpickleWrapper) -> None:
    import signal

    # Ctrl-C reaches the whole process group: the training process saves and then closes the
    # workers itself, so a worker must not die under it first.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # forked, it has its parent's handlers: terminate() must end it
    parent_remote.close()
    block = _Block(fns.var)
    try:
        while True:
            cmd, number, data = _receive_message(remote)
            if cmd == "close":
                block.close()
                remote.close()
                break
            _send_message(remote, (number, _answer(block, cmd, data)))
    except (EOFError, KeyboardInterrupt):
        pass


class _Replies:
    """Numbered messages to the workers: each reply repeats its message's number, and a reader takes
    the reply to its own message, dropping older ones. A command interrupted (Ctrl-C) between
    sending and receiving leaves replies in the pipes; they are never mistaken for a later
    command's (an interrupted run's checkpoint asks every env for its random state right after the
    interrupted step)."""

    _number = 0

    def _send(self, messages: list[tuple[Any, tuple[str, Any]]]) -> tuple[int, list]:
        """Send each (remote, (command, data)); the ticket that :meth:`_replies` redeems."""
        self._number += 1
        for remote, (cmd, data) in messages:
            _send_message(remote, (cmd, self._number, data))
        return self._number, [remote for remote, _ in messages]

    @staticmethod
    def _replies(ticket: tuple[int, list]) -> list:
        """The replies to the messages of ``ticket``, in the order they went out."""
        number, remotes = ticket
        out = []
        for remote in remotes:
            while True:
                got, reply = _receive_message(remote)
                if got == number:
                    out.append(reply)
                    break
        return out


class BatchedSubprocVecEnv(_Replies, VecEnv):
    """``len(env_fns)`` envs in ``n_workers`` contiguous blocks stepped in parallel (env i in block
    i // ceil(n / n_workers)): the calling process steps the first block itself, one worker process
    each of the others.

    Stepping the first block in the calling process saves one process, one pipe round trip and the
    pickling of that block's results per step, and the calling process's core does env work while
    the workers step; with one block per core the processes match the cores (pinning them to cores
    changed nothing, measured on 2 cores).

    :param env_fns: picklable env factories (the first block's are called here).
    :param n_workers: blocks stepped in parallel, the calling process included (1..number of envs;
        1: every env in this process, no worker).
    :param start_method: multiprocessing start method (default ``forkserver`` when available).
    """

    def __init__(self, env_fns: Sequence[Callable[[], gym.Env]], n_workers: int, start_method: str | None = None):
        n = len(env_fns)
        n_workers = checker(count(1, n))(n_workers, "n_workers")  # at most one block per env
        per = -(-n // n_workers)
        self.blocks = [list(range(i, min(i + per, n))) for i in range(0, n, per)]
        self.waiting = False
        self.closed = False
        self.remotes, self.processes = [], []
        self.local = _Block([env_fns[i] for i in self.blocks[0]])
        try:
            if len(self.blocks) > 1:
                ctx = mp.get_context(_worker_start_method(start_method))
                for block in self.blocks[1:]:
                    remote, work_remote = ctx.Pipe()
                    args = (work_remote, remote, CloudpickleWrapper([env_fns[i] for i in block]))
                    p = ctx.Process(target=_worker, args=args, daemon=True)
                    with deferred_interrupts():  # a started worker is always one this object stops
                        p.start()
                        self.processes.append(p)
                    work_remote.close()
                    self.remotes.append(remote)
            observation_space, action_space = self.local.handle("get_spaces", None)
            super().__init__(n, observation_space, action_space)  # asks every env for its render_mode
        except BaseException:
            # an interrupt or a failure while the workers start: they are stopped now, not asked to
            # close (a worker still importing or building its envs reads no command, and ignores
            # Ctrl-C)
            self._stop_workers()
            self.local.close()
            self.closed = True
            raise

    # ---- stepping ----------------------------------------------------------------------------------
    def step_async(self, actions: np.ndarray) -> None:
        # each block's actions as one slice (the blocks are contiguous): one array to pickle
        self._ticket = self._send(
            [(remote, ("step", actions[b[0] : b[-1] + 1])) for remote, b in zip(self.remotes, self.blocks[1:])]
        )
        self._local_actions = [actions[i] for i in self.blocks[0]]
        self.waiting = True

    def step_wait(self):
        parts = [self.local.step(self._local_actions), *self._replies(self._ticket)]
        self.waiting = False
        for block, part in zip(self.blocks, parts):
            for j, reset_info in part[4].items():
                self.reset_infos[block[j]] = reset_info
        obs = np.concatenate([part[0] for part in parts])
        rews = np.array([r for part in parts for r in part[1]], dtype=np.float32)
        dones = np.array([d for part in parts for d in part[2]])
        return obs, rews, dones, [info for part in parts for info in part[3]]

    def reset(self):
        data = [[(self._seeds[i], self._options[i]) for i in block] for block in self.blocks]
        ticket = self._send([(remote, ("reset", d)) for remote, d in zip(self.remotes, data[1:])])
        results = self.local.handle("reset", data[0])
        results += [r for reply in self._replies(ticket) for r in reply]
        obs, self.reset_infos = zip(*results)
        self.reset_infos = list(self.reset_infos)
        self._reset_seeds()
        self._reset_options()
        return np.stack(obs)

    def close(self) -> None:
        if self.closed:
            return
        for remote in self.remotes:
            try:  # a worker that died (or failed to start) has nothing to answer
                # replies still in the pipe (a command interrupted by Ctrl-C): taken, never waited for
                while remote.poll(0.05):
                    remote.recv_bytes()
                _send_message(remote, ("close", 0, None))
            except (EOFError, OSError):
                pass
        deadline = time.monotonic() + CLOSE_TIMEOUT_S
        for p in self.processes:
            p.join(max(deadline - time.monotonic(), 0.0))
        self._stop_workers()  # a worker that missed its close (busy, or its pipe out of step)
        self.local.close()
        self.closed = True

    def _stop_workers(self) -> None:
        """Terminate the workers still running and wait for them to end."""
        for p in self.processes:
            if p.is_alive():
                p.terminate()
        for p in self.processes:
            p.join()

    def get_images(self) -> Sequence[np.ndarray | None]:
        return self._gather("render", None)

    # ---- attribute access --------------------------------------------------------------------------
    def _gather(self, cmd: str, indices, *payload) -> list[Any]:
        """``cmd`` on the envs ``indices`` (all for ``render``), the replies in env order."""
        idx = None if cmd == "render" else self._get_indices(indices)
        routes = []  # (remote or None for the calling process's block, data); the calling process's first
        for k, block in enumerate(self.blocks):
            local = [block.index(i) for i in idx if i in block] if idx is not None else None
            if local is None or local:
                routes.append((self.remotes[k - 1] if k else None, None if local is None else (local, *payload)))
        ticket = self._send([(remote, (cmd, data)) for remote, data in routes if remote is not None])
        here = [_answer(self.local, cmd, data) for remote, data in routes if remote is None]
        out, failed = [], None
        for reply in here + self._replies(ticket):  # every reply is received, so the pipes stay in step
            if isinstance(reply, _Failed):
                failed = failed or reply
            elif reply is not None:
                out += reply
        if failed is not None:
            failed.raise_()
        return out

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        return self._gather("get_attr", indices, attr_name)

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        self._gather("set_attr", indices, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list[Any]:
        return self._gather("env_method", indices, method_name, method_args, method_kwargs)

    def has_attr(self, attr_name: str) -> bool:
        return all(self._gather("has_attr", None, attr_name))

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices=None) -> list[bool]:
        return self._gather("is_wrapped", indices, wrapper_class)


class _SafeCalls(gym.Wrapper):
    """Outermost wrapper of each env of :class:`SafeSubprocVecEnv`: methods reached through
    ``get_wrapper_attr`` (how SB3's worker runs ``env_method``) return a failure as
    :class:`_Failed` instead of raising in the worker (which ended SB3's worker loop), and
    attribute reads and writes go through :meth:`safe_get_attr` and :meth:`safe_set_attr` the same
    way."""

    def get_wrapper_attr(self, name: str):
        try:
            attr = (
                getattr(self, name)
                if name in ("safe_get_attr", "safe_set_attr", "numbered_call")
                else self.env.get_wrapper_attr(name)
            )
        except AttributeError as err:  # no such method: the call answers with the error
            failed = _Failed(err)
            return lambda *args, **kwargs: failed
        if not callable(attr):
            return attr

        def call(*args, **kwargs):
            try:
                return attr(*args, **kwargs)
            except Exception as err:  # noqa: BLE001 - the caller's bad request goes back to the caller
                return _Failed(err)

        return call

    def safe_get_attr(self, name: str):
        return self.env.get_wrapper_attr(name)

    def numbered_call(self, number: int, name: str, args, kwargs) -> "_Numbered":
        """``name(*args, **kwargs)`` as ``env_method`` runs it, its reply numbered."""
        return _Numbered(number, self.get_wrapper_attr(name)(*args, **kwargs))

    def safe_set_attr(self, name: str, value: Any) -> None:
        setattr(self.env, name, value)  # the Monitor passes settable env properties through, validated


class _Numbered:
    """A reply and the number of the message it answers."""

    def __init__(self, number: int, value: Any):
        self.number, self.value = number, value


def _safe_env(fn):
    return _SafeCalls(fn())


def _raise_failed(replies: list[Any]) -> list[Any]:
    for r in replies:
        if isinstance(r, _Failed):
            r.raise_()
    return replies


class SafeSubprocVecEnv(SubprocVecEnv):
    """SB3's ``SubprocVecEnv`` (one process per env) whose ``env_method``, ``get_attr`` and
    ``set_attr`` raise a bad call's error in the caller; the worker stays alive and its env
    unchanged (SB3's worker loop ends on any exception, which killed a training run). Their replies
    are numbered (:meth:`_SafeCalls.numbered_call`): a reply left in a pipe by an interrupted
    command is dropped, never taken for a later one's. Its workers ignore Ctrl-C from the fork on,
    as :class:`BatchedSubprocVecEnv`'s do (:func:`_worker_start_method`)."""

    _number = 0

    def __init__(self, env_fns, start_method: str | None = None):
        super().__init__([partial(_safe_env, fn) for fn in env_fns], _worker_start_method(start_method))

    def _call(self, method_name: str, args, kwargs, indices) -> list[Any]:
        self._number += 1
        remotes = self._get_target_remotes(indices)
        for remote in remotes:
            remote.send(("env_method", ("numbered_call", (self._number, method_name, args, kwargs), {})))
        out = []
        for remote in remotes:
            while True:
                reply = remote.recv()
                if isinstance(reply, _Numbered) and reply.number == self._number:
                    out.append(reply.value)
                    break
        return _raise_failed(out)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list[Any]:
        return self._call(method_name, method_args, method_kwargs, indices)

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        return self._call("safe_get_attr", (attr_name,), {}, indices)

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        self._call("safe_set_attr", (attr_name, value), {}, indices)
