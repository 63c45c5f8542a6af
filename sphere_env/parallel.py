"""A small process-pool executor for sweeps (calibration sensitivity, evaluation grids).

Same semantics as the local pool of ``evaluation.evaluate.run_jobs`` (forkserver workers, job-order
results, ``workers=1`` in-process), for any module-level job function.

Each job is a picklable mapping handed to a module-level function; results come back in job
order. ``workers=1`` runs in-process (no pool, easy debugging and profiling). Every worker
builds its own Drake diagrams: pydrake objects are never shipped between processes.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from typing import Any, Callable, Iterable, Mapping, Sequence


def default_workers() -> int:
    """Usable cores (respects CPU affinity), at least 1."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # pragma: no cover - not Linux
        return max(os.cpu_count() or 1, 1)


def run_parallel(fn: Callable[[Mapping[str, Any]], Any], jobs: Iterable[Mapping[str, Any]],
                 workers: int | None = None, progress: bool = False) -> list[Any]:
    """Run ``fn(job)`` for every job, on ``workers`` processes (None: all usable cores).

    ``fn`` must be importable at module level (pickled by reference). Results keep job order.
    """
    jobs = list(jobs)
    n = default_workers() if workers is None else int(workers)
    if n < 1:
        raise ValueError(f"workers: value {workers!r} must be >= 1")
    if n == 1 or len(jobs) <= 1:
        it: Sequence[Any] | Iterable[Any] = map(fn, jobs)
    else:
        # forkserver: workers never inherit torch/Drake threads of the parent (as evaluation.evaluate does)
        pool = ProcessPoolExecutor(max_workers=min(n, len(jobs)), mp_context=get_context("forkserver"))
        it = pool.map(fn, jobs, chunksize=max(1, math.ceil(len(jobs) / (n * 3))))
    if progress:
        from tqdm import tqdm

        it = tqdm(it, total=len(jobs))
    try:
        return list(it)
    finally:
        if n > 1 and len(jobs) > 1:
            pool.shutdown()
