"""Ctrl-C or SIGTERM during `train` saves the model, its VecNormalize statistics and a resumable
checkpoint, and ends with exit code 130 and a one-line message; the run then resumes."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest

from sphere_env.training.run_folder import latest_checkpoint
from sphere_env.training.train import main
from tests.conftest import TINY_PPO_PARAMS
from tests.processes import as_from_a_terminal


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupted_training_is_saved_and_resumes(tmp_path, sig):
    run = tmp_path / "run"
    cmd = [
        sys.executable,
        "-m",
        "sphere_env.training.train",
        "--env",
        "sphere_env/RampDescent-v2",
        "--run-dir",
        str(run),
        "-n",
        "1000000",
        "--eval-freq",
        "-1",
        "--no-progress",
        "--hyperparams",
        *TINY_PPO_PARAMS,
        "n_envs:2",
    ]
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=as_from_a_terminal
    )
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:  # wait for the first finished episode: training is under way
        csv = run / "learning_curve_train.csv"
        if csv.exists() and len(csv.read_text().splitlines()) > 1:
            break
        time.sleep(0.5)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 130, err[-2000:]
    lines = [ln for ln in err.splitlines() if ln.strip() and "Warn" not in ln and "logger" not in ln]
    assert len(lines) == 1 and "interrupted at" in lines[0] and "--resume" in lines[0], err[-2000:]
    assert "Traceback" not in err
    assert (run / "model.zip").exists() and (run / "vecnormalize.json").exists()
    steps, _ = latest_checkpoint(run)
    assert steps > 0
    resumed = main(["--resume", str(run), "-n", str(steps + 128), "--no-progress"])
    assert latest_checkpoint(resumed)[0] >= steps + 128
