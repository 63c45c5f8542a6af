"""The one executor for sweeps (evaluation grids, calibration sensitivity): in-process, a local
process pool, or a Ray cluster, with identical results in job order.

Each job is a picklable mapping handed to a module-level function; results come back in job
order. ``workers=1`` runs in-process (no pool, easy debugging and profiling). Every worker
builds its own Drake diagrams: pydrake objects are never shipped between processes.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import signal
import threading
from concurrent.futures import InvalidStateError, ProcessPoolExecutor
from multiprocessing import get_context
from typing import Any, Callable, Iterable, Mapping, Sequence

from sphere_env.schemas import checker, count


def default_workers() -> int:
    """Usable cores (respects CPU affinity), at least 1."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # pragma: no cover - not Linux
        return max(os.cpu_count() or 1, 1)


#: Processes of a pool: an integer >= 1, or None for every usable core.
_WORKERS = checker(count(1) | None)


def run_parallel(
    fn: Callable[[Mapping[str, Any]], Any],
    jobs: Iterable[Mapping[str, Any]],
    workers: int | None = None,
    progress: bool = False,
    ray_address: str | None = None,
    chunksize: int | None = None,
) -> list[Any]:
    """Run ``fn(job)`` for every job, on ``workers`` processes (None: all usable cores), or on Ray.

    ``chunksize``: jobs a pool worker takes at a time (None: about a third of an even share, for
    many short jobs; 1 for long jobs, which are then started in job order as workers free up).

    ``fn`` must be importable at module level (pickled by reference). Results keep job order.
    ``ray_address``: ``"local"`` starts a local Ray instance, anything else is passed to
    ``ray.init(address=...)`` (``auto``, ``ray://host:10001``); needs ``pip install -e .[ray]``.
    """
    jobs = list(jobs)
    workers = _WORKERS(workers, "workers")
    if ray_address is not None:
        return _run_ray(fn, jobs, ray_address, workers)
    n = default_workers() if workers is None else workers
    if n == 1 or len(jobs) <= 1:
        it: Sequence[Any] | Iterable[Any] = map(fn, jobs)
    else:
        # spawn: workers never inherit torch/Drake threads of the parent, and they are the parent's own
        # children, so stopping them on an interrupt leaves no server process behind (forkserver's
        # server printed a traceback when its parent went away)
        pool = ProcessPoolExecutor(max_workers=min(n, len(jobs)), mp_context=get_context("spawn"))
        it = pool.map(fn, jobs, chunksize=chunksize or max(1, math.ceil(len(jobs) / (n * 3))))
    if progress:
        from tqdm import tqdm

        it = tqdm(it, total=len(jobs))
    hook = threading.excepthook
    manager = None  # the executor's manager thread, joined before the hook is restored
    try:
        return list(it)
    except BaseException:
        if n > 1 and len(jobs) > 1:  # an error or an interrupt: stop the workers now, not after their jobs
            # The executor's manager thread may still be handed the result of a job whose future was
            # just cancelled; Python 3.11 then raises InvalidStateError in that thread, which printed a
            # traceback over the interrupt's one-line message. Nothing is lost: the job was cancelled.
            threading.excepthook = functools.partial(_unless_cancelled, hook)
            procs = list((getattr(pool, "_processes", None) or {}).values())  # no public terminate before 3.14
            # shutdown(wait=False) forgets the manager thread, so a later shutdown() would not join it
            manager = getattr(pool, "_executor_manager_thread", None)
            pool.shutdown(wait=False, cancel_futures=True)
            for proc in procs:
                proc.terminate()
            for proc in procs:
                proc.join(5)
        raise
    finally:
        if n > 1 and len(jobs) > 1:
            pool.shutdown()  # joins the manager thread unless a stop above already let it go
            if manager is not None:
                manager.join(10)
            threading.excepthook = hook


def _unless_cancelled(hook, args) -> None:
    """``threading.excepthook`` that drops an executor thread's InvalidStateError (a result for a
    cancelled future) and passes everything else to ``hook``."""
    if not isinstance(args.exc_value, InvalidStateError):
        hook(args)


@contextlib.contextmanager
def sigterm_as_interrupt():
    """Inside the block, SIGTERM raises KeyboardInterrupt in the main thread, so a command stopped by
    ``kill`` unwinds as Ctrl-C does: staging folders are removed and worker processes stopped."""

    def _raise(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, _raise)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def deferred_interrupts():
    """Inside the block, Ctrl-C (and SIGTERM where it raises KeyboardInterrupt) is held and raised at
    its end. For starting a worker process: an interrupt inside ``Process.start`` once the child
    exists would leave a worker its parent knows nothing of, so never stops. Signals whose handler
    is not Python's (ignored, default), and calls outside the main thread, are left as they are."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []
    previous = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        handler = signal.getsignal(sig)
        if callable(handler):
            previous[sig] = handler
            signal.signal(sig, lambda signum, frame: held.append(signum))
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        if held:
            previous[held[0]](held[0], None)


def _run_ray(fn: Callable[[Mapping[str, Any]], Any], jobs: list, address: str, workers: int | None) -> list:
    try:
        import ray
    except ImportError:
        raise ValueError("ray_address: Ray is not installed; pip install -e '.[ray]'") from None
    started = False
    if not ray.is_initialized():
        if address == "local":
            ray.init(num_cpus=workers or None, include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=address, log_to_driver=False)
        started = True
    try:
        remote = ray.remote(num_cpus=1)(fn)
        return ray.get([remote.remote(j) for j in jobs])
    finally:
        if started:
            ray.shutdown()
