"""Train into a run folder: a new run, a run restarted in its folder, or one resumed from its newest
usable checkpoint.

:func:`train` decides, under the folder's lock and before anything in the folder changes, what the
folder holds and where training starts: a fresh folder, a folder whose run stopped before its first
checkpoint (cleared and started over), or a resume from the newest checkpoint that loads (newer
unreadable ones skipped, saying so; the learning-curve history cut back to it). A checkpoint at the
step budget of a run stopped before its final save is saved as the run's model with no more
training (a session of zero steps, its rate unknown). It then writes
``config.yaml`` (a resume keeps the original command and lists its own), runs one
:func:`~sphere_env.training.session.train_session` and writes the learning curves. A fresh run that
fails before its first checkpoint removes the folder it created.
"""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Sequence

import yaml

from sphere_env import safe_yaml
from sphere_env.training.config import TrainConfig, algo_class
from sphere_env.training.run_folder import (
    _clear_outputs,
    _is_interrupted_run,
    _truncate_history,
    default_run_dir,
    latest_checkpoint,
    run_lock,
    usable_checkpoint,
    write_config,
    write_learning_curves,
)
from sphere_env.training.session import TrainingInterrupted, say, train_session


def train(
    cfg: TrainConfig,
    run_dir: str | Path | None = None,
    resume: bool = False,
    progress_bar: bool = True,
    verbose: int = 0,
    command: Sequence[str] | None = None,
    return_model: bool = False,
):
    """Train per ``cfg`` into ``run_dir`` (new), or continue ``run_dir`` from its newest usable
    checkpoint (``resume``) up to ``cfg.n_timesteps`` total steps. Returns the run folder (and the
    in-memory model, whose ``get_vec_normalize_env()`` holds the statistics, with ``return_model``).

    Resume falls back past unreadable checkpoints (truncated zip, missing VecNormalize file) to the
    newest good one, saying so; a run stopped before its first checkpoint is restarted from scratch
    in the same folder. Both are decided before anything in the folder changes. A fresh run that
    fails before its first checkpoint removes the folder it created."""
    import torch

    torch.set_num_threads(cfg.torch_threads)
    cls = algo_class(cfg.algo)
    run_dir = Path(run_dir) if run_dir is not None else default_run_dir(cfg)
    if resume and not (run_dir / "config.yaml").exists():
        raise ValueError(f"resume: {str(run_dir)!r} has no config.yaml (not a training run folder)")
    created = False
    if not resume:
        try:
            run_dir.mkdir(parents=True)  # exclusive: a folder that exists is judged under its lock below
            created = True
        except FileExistsError:
            if not run_dir.is_dir():
                raise ValueError(f"run_dir: {str(run_dir)!r} exists and is not a folder") from None
    with run_lock(run_dir):
        return _train_locked(cfg, cls, run_dir, resume, created, progress_bar, verbose, command, return_model)


def _saved_steps(run_dir: Path) -> int:
    """The step count of the run's last finished session (its ``timing.json``); -1 when no session
    finished: a run stopped after its last checkpoint and before its final save has none at that
    checkpoint's count."""
    try:
        return int(json.loads((run_dir / "timing.json").read_text())["num_timesteps"])
    except (OSError, ValueError, KeyError, TypeError):
        return -1


def _train_locked(
    cfg: TrainConfig,
    cls,
    run_dir: Path,
    resume: bool,
    created: bool,
    progress_bar: bool,
    verbose: int,
    command: Sequence[str] | None,
    return_model: bool,
):
    start_steps = 0
    ckpt = None
    previous: dict[str, Any] = {}
    if resume:  # train() checked that config.yaml exists; gone since (another process): cannot be read
        try:
            previous = safe_yaml.load_file((run_dir / "config.yaml")) or {}
        except (OSError, yaml.YAMLError) as err:
            raise ValueError(
                f"resume: {str(run_dir / 'config.yaml')!r} cannot be read: " + " ".join(str(err).split())
            ) from None
        ckpt, skipped = usable_checkpoint(cls, cfg, run_dir)
        if ckpt is None and skipped:
            raise ValueError(
                f"resume: no usable checkpoint in {str(run_dir / 'checkpoints')!r}: "
                + "; ".join(skipped)
                + ". Start a new run (another --run-dir)"
            )
        if ckpt is not None:
            start_steps = ckpt[0]
            if start_steps >= cfg.n_timesteps and _saved_steps(run_dir) >= start_steps:
                raise ValueError(
                    f"n_timesteps: {cfg.n_timesteps} already reached (checkpoint at {start_steps}); "
                    "pass a larger --n-timesteps to continue"
                )
            if start_steps >= cfg.n_timesteps:
                say(
                    f"resume: the checkpoint at {start_steps} steps reaches n_timesteps ({cfg.n_timesteps}) but the "
                    "run stopped before its final save; saving the model from it, with no more training"
                )
            for problem in skipped:
                say(f"resume: skipping a checkpoint: {problem}")
            if skipped:
                say(f"resume: falling back to the checkpoint at {start_steps} steps")
            _truncate_history(run_dir, start_steps)
        else:
            say(
                f"resume: {str(run_dir)!r} has no checkpoint (stopped before the first one); "
                "restarting from scratch in the same folder"
            )
            _clear_outputs(run_dir)
            resume = False
    else:
        if (run_dir / "config.yaml").exists():
            if not _is_interrupted_run(run_dir):
                raise ValueError(f"run_dir: {str(run_dir)!r} already holds a run; use --resume or another folder")
            say(f"run_dir: {str(run_dir)!r} holds a run stopped before its first checkpoint; starting over in it")
            _clear_outputs(run_dir)
    extra: dict[str, Any] = {}
    if previous:  # keep the original command; list the resume commands
        extra["command"] = previous.get("command", [])
        extra["created_utc"] = previous.get("created_utc")
        extra["resume_commands"] = [
            *previous.get("resume_commands", []),
            {
                "command": list(command) if command is not None else [],
                "from_steps": start_steps,
                "utc": datetime.now(UTC).isoformat(timespec="seconds"),
            },
        ]
        extra["resumed_from_steps"] = start_steps
    try:
        write_config(cfg, run_dir, command, extra=extra or None)
        result = train_session(cfg, cls, run_dir, ckpt, start_steps, progress_bar, verbose)
    except TrainingInterrupted:
        write_learning_curves(run_dir)
        raise
    except BaseException:
        if created and latest_checkpoint(run_dir) is None:
            import shutil

            shutil.rmtree(run_dir, ignore_errors=True)
        raise
    write_learning_curves(run_dir)
    return (run_dir, result) if return_model else run_dir
