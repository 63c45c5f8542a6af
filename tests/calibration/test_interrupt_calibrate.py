"""SIGTERM on `calibrate` stops every worker process and leaves nothing half-written: the
sensitivity sweep's pool, and the report, whose files are staged and moved into place only when
every check has finished."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

from tests.processes import descendants, survivors

CALIBRATE = [sys.executable, "-m", "sphere_env.calibration"]


def _terminate_when(proc: subprocess.Popen, ready, timeout_s: float = 180.0) -> tuple[set[int], str]:
    """Wait until ``ready(children)``, send SIGTERM, wait for the exit; (children seen, stderr)."""
    deadline = time.monotonic() + timeout_s
    seen: set[int] = set()
    while time.monotonic() < deadline and proc.poll() is None:
        seen |= descendants(proc.pid)
        if ready(seen):
            break
        time.sleep(0.2)
    assert proc.poll() is None, "the command ended before it could be interrupted"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    return seen, err


def _assert_interrupted(proc: subprocess.Popen, err: str, workers: set[int]) -> None:
    assert proc.returncode == 130, err[-2000:]
    assert "interrupted" in err and "Traceback" not in err, err[-2000:]
    assert not survivors(workers), "worker processes outlived the command"


def test_sigterm_on_the_sensitivity_sweep_stops_its_pool_and_writes_no_plot(tmp_path):
    plot = tmp_path / "sensitivity.png"
    proc = subprocess.Popen(
        [*CALIBRATE, "sensitivity", "--workers", "2", "--duration-s", "30", "--plot", str(plot)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    workers, err = _terminate_when(proc, lambda seen: len(seen) >= 2)
    assert workers, "the sweep never started its pool"
    _assert_interrupted(proc, err, workers)
    assert not list(tmp_path.iterdir()), "the plot or a temporary file was left behind"


def test_sigterm_on_the_report_leaves_the_earlier_report_as_it_was(tmp_path, roboball_dir):
    out = tmp_path / "report"
    out.mkdir()
    (out / "README.md").write_text("the earlier report\n")
    proc = subprocess.Popen(
        [*CALIBRATE, "report", "--data-root", str(roboball_dir), "--out", str(out), "--workers", "2", "--starts", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    staged_at: list[float] = []

    def ready(_seen: set[int]) -> bool:  # the staging folder exists and the checks have run a while
        if not staged_at and list(tmp_path.glob(".report.partial-*")):
            staged_at.append(time.monotonic())
        return bool(staged_at) and time.monotonic() - staged_at[0] > 3.0

    workers, err = _terminate_when(proc, ready)
    assert staged_at, "the report never staged its files"
    _assert_interrupted(proc, err, workers)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"], "a staging folder was left behind"
    assert [p.name for p in out.iterdir()] == ["README.md"]
    assert (out / "README.md").read_text() == "the earlier report\n"
