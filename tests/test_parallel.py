"""The process pool of the calibration and evaluation sweeps (:func:`sphere_env.parallel.run_parallel`):
its worker count is checked, and long jobs go to whichever worker is free."""

import multiprocessing
import os

import pytest

from sphere_env.parallel import run_parallel


def test_a_pool_needs_one_worker_at_least():
    for workers in (0, -2, 1.5, "2"):
        with pytest.raises(ValueError, match=rf"^workers = {workers!r}: .*; allowed: an integer >= 1 or None$"):
            run_parallel(abs, [{}], workers=workers)
    assert run_parallel(len, [{}, {"a": 1}], workers=1) == [0, 1]


def _pid_once_met(job):
    """Job ``{"set": event}`` sets the event; job ``{"wait": event}`` holds its worker until the event
    is set (at most a minute). Returns (the worker's pid, whether the wait was met)."""
    if "set" in job:
        job["set"].set()
    met = job["wait"].wait(timeout=60) if "wait" in job else True
    return os.getpid(), met


def test_long_jobs_go_one_at_a_time_to_whichever_worker_is_free():
    """With ``chunksize=1`` the job after a long one starts on the other worker while the long one
    still runs: job 0 holds its worker until job 1 has run. With the default chunks for many jobs,
    job 1 shares job 0's chunk, so job 0's worker runs it too."""
    with multiprocessing.get_context("spawn").Manager() as manager:
        job1_ran = manager.Event()
        jobs = [{"wait": job1_ran}, {"set": job1_ran}] + [{}] * 10
        one = run_parallel(_pid_once_met, jobs, workers=2, chunksize=1)
    assert one[0][1], "job 1 never ran while job 0 held its worker"
    assert one[1][0] != one[0][0]
    chunked = run_parallel(_pid_once_met, [{}] * 12, workers=2)
    assert chunked[1][0] == chunked[0][0]
