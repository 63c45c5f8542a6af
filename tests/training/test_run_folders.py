"""Run folders never collide: default names are unique within a second, a new folder is created
exclusively, and a folder in use by another training is refused before anything in it changes."""

from __future__ import annotations

import multiprocessing as mp

import pytest

from sphere_env.training.config import resolve_config
from sphere_env.training.run_folder import default_run_dir, run_lock
from sphere_env.training.trainer import train
from tests.conftest import TINY_PPO

ENV = "sphere_env/RampDescent-v2"
TINY = {**TINY_PPO, "n_timesteps": 32, "env_kwargs": {"shell_model": "point"}}


def test_default_run_folders_started_in_the_same_second_differ(tmp_path):
    cfg = resolve_config(ENV, "ppo", overrides=TINY, build_env=False)
    names = {default_run_dir(cfg, tmp_path).name for _ in range(50)}
    assert len(names) == 50


def _hold_lock(folder, ready, release):
    from pathlib import Path

    with run_lock(Path(folder)):
        ready.set()
        release.wait(60)


def test_a_second_writer_on_a_folder_in_use_is_refused_and_changes_nothing(tmp_path):
    run = tmp_path / "run"
    cfg = resolve_config(ENV, "ppo", overrides=TINY, eval_freq=0)
    train(cfg, run, progress_bar=False)
    before = {p.relative_to(run): p.stat().st_mtime_ns for p in run.rglob("*") if p.is_file()}
    ctx = mp.get_context("spawn")
    ready, release = ctx.Event(), ctx.Event()
    holder = ctx.Process(target=_hold_lock, args=(str(run), ready, release))
    holder.start()
    try:
        assert ready.wait(60)
        longer = resolve_config(ENV, "ppo", overrides={**TINY, "n_timesteps": 64}, eval_freq=0)
        with pytest.raises(ValueError, match="in use by another process"):
            train(longer, run, resume=True, progress_bar=False)
        with pytest.raises(ValueError, match="in use by another process"):
            train(cfg, run, progress_bar=False)
    finally:
        release.set()
        holder.join(60)
    after = {p.relative_to(run): p.stat().st_mtime_ns for p in run.rglob("*") if p.is_file()}
    assert {k: v for k, v in after.items() if k.name != ".lock"} == {
        k: v for k, v in before.items() if k.name != ".lock"
    }
    # released with its process: the run continues
    train(
        resolve_config(ENV, "ppo", overrides={**TINY, "n_timesteps": 64}, eval_freq=0),
        run,
        resume=True,
        progress_bar=False,
    )
    assert (run / "model.zip").exists()
