"""Two commands never write one folder at once: a second `evaluate` into an ``--out`` another
evaluation is writing is refused by name (the folder and the holder's pid) and writes nothing, and
`export` refuses a run folder a training (a resumed run) is writing, rather than read a model in the
middle of being saved. Both take the lock run folders take (``<folder>/.lock``)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from sphere_env.cli import main
from tests.conftest import REPO, TINY_PPO
from tests.processes import as_from_a_terminal

GRID = ["--shell-models", "point", "--pressure-kpa", "8.5", "--seeds", "0", "--workers", "1", "--replay"]


def _holds(proc: subprocess.Popen, lock, timeout: float = 180) -> None:
    """Wait until ``proc`` holds ``lock`` (its pid written there)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()[1][-2000:]
        if lock.exists() and lock.read_text().strip() == str(proc.pid):
            return
        time.sleep(0.05)
    raise AssertionError(f"{lock} was never held by {proc.pid}")


def test_a_second_evaluation_into_an_out_in_use_is_refused_and_writes_nothing(tmp_path, capsys):
    out, release = tmp_path / "eval", tmp_path / "release"
    first = subprocess.Popen(
        [sys.executable, "-m", "sphere_env.evaluation.evaluate", "--controller",
         "held=tests.hostile.held_controller:HeldController", *GRID, "--out", str(out)],
        cwd=REPO,
        env={**os.environ, "SPHERE_ENV_TEST_RELEASE": str(release)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    try:
        _holds(first, out / ".lock")
        staged = sorted(p.name for p in tmp_path.iterdir())
        with pytest.raises(SystemExit) as exc:
            main(["evaluate", "--controller", "zero", *GRID, "--out", str(out)])
        err = capsys.readouterr().err.strip()
        assert exc.value.code == 2 and len(err.splitlines()) == 1, err
        assert f"out: {str(out)!r} is in use by another process (pid {first.pid} holds its .lock)" in err, err
        assert sorted(p.name for p in tmp_path.iterdir()) == staged  # no staging folder of its own
        assert [p.name for p in out.iterdir()] == [".lock"]
    finally:
        release.touch()
        _, first_err = first.communicate(timeout=300)
    assert first.returncode == 0, first_err[-2000:]
    assert "held" in (out / "episodes.csv").read_text()  # the first evaluation's results, whole
    assert not (out / ".lock").exists() and sorted(p.name for p in tmp_path.iterdir()) == ["eval", "release"]


def test_export_refuses_a_run_folder_a_resumed_training_is_writing(tmp_path, capsys):
    from sphere_env.training.config import resolve_config
    from sphere_env.training.trainer import train

    run = tmp_path / "run"
    tiny = {**TINY_PPO, "n_timesteps": 128, "env_kwargs": {"shell_model": "point"}}
    cfg = resolve_config("sphere_env/RampDescent-v3", "ppo", overrides=tiny, eval_freq=0)
    train(cfg, run, progress_bar=False)
    resumed = subprocess.Popen(
        [sys.executable, "-m", "sphere_env.training.train", "--resume", str(run), "-n", "1000000", "--no-progress"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=as_from_a_terminal,
    )
    try:
        _holds(resumed, run / ".lock")
        with pytest.raises(SystemExit) as exc:
            main(["export", str(run), "--format", "torchscript"])
        err = capsys.readouterr().err.strip()
        assert exc.value.code == 2 and len(err.splitlines()) == 1, err
        assert f"run: {str(run)!r} is in use by another process (pid {resumed.pid} holds its .lock)" in err, err
        assert not (run / "export").exists()
    finally:
        resumed.send_signal(signal.SIGINT)
        _, resumed_err = resumed.communicate(timeout=300)
    assert resumed.returncode == 130, resumed_err[-2000:]
    # the training has ended: its last save is complete and exports
    main(["export", str(run), "--format", "torchscript"])
    assert (run / "export" / "policy.pt").exists()
    capsys.readouterr()
