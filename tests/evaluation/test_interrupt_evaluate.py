"""SIGTERM on `evaluate` stops every worker process and leaves no staging folder behind."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

from tests.processes import descendants, survivors


def test_sigterm_stops_the_pool_and_removes_the_staging_folder(tmp_path):
    out = tmp_path / "eval"
    cmd = [
        sys.executable,
        "-m",
        "sphere_env.evaluation.evaluate",
        "--controller",
        "pd",
        "zero",
        "--shell-models",
        "hydroelastic",
        "--pressure-kpa",
        "3",
        "8.5",
        "14",
        "--seeds",
        "0",
        "1",
        "2",
        "--workers",
        "2",
        "--out",
        str(out),
        "--replay",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    workers: set[int] = set()
    while time.monotonic() < deadline:  # the pool is up and the staging folder exists
        workers = descendants(proc.pid)
        if len(workers) >= 2 and list(tmp_path.glob(".eval.partial-*")):
            break
        time.sleep(0.2)
    assert workers, "the evaluation never started its pool"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err[-2000:]
    assert "interrupted" in err and "Traceback" not in err
    assert not survivors(workers), "worker processes outlived the evaluation"
    assert not list(tmp_path.iterdir()), "a staging or output folder was left behind"
    os.sync()


def test_an_executor_threads_cancelled_result_error_is_dropped_and_others_are_not():
    """The pool's stop path hides only InvalidStateError (a result for a cancelled future) raised in
    the executor's thread; any other thread error still reaches the previous hook."""
    import threading
    from concurrent.futures import InvalidStateError

    from sphere_env.parallel import _unless_cancelled

    seen = []

    def args(exc):
        return threading.ExceptHookArgs((type(exc), exc, None, None))

    _unless_cancelled(seen.append, args(InvalidStateError("CANCELLED")))
    _unless_cancelled(seen.append, args(RuntimeError("real")))
    assert [type(a.exc_value) for a in seen] == [RuntimeError]
