"""One training session: the model built, loaded from a checkpoint or from a trained agent, trained
up to the configuration's step count and saved; and what stops it early.

:func:`train_session` runs ``model.learn`` with the run's callbacks and saves ``model.zip``, its
VecNormalize statistics, a final checkpoint and ``timing.json``. Ctrl-C, and SIGTERM inside
:func:`sphere_env.parallel.sigterm_as_interrupt`, end the session the same way: the rollout in progress is dropped,
everything trained so far is saved as a resumable checkpoint, and :class:`TrainingInterrupted` says
where and how to continue. :func:`unchecked_distributions` turns off torch's per-call distribution
argument checks while learning (measured 8-18 % of PPO's rollout collection).
"""

from __future__ import annotations

import contextlib
import json
import sys
import time
from pathlib import Path

from sphere_env.training import training_state
from sphere_env.training.callbacks import build_callbacks, save_checkpoint
from sphere_env.training.config import TrainConfig
from sphere_env.training.env_factory import make_vec_env, wrap_normalize
from sphere_env.training.run_folder import _ckpt_file
from sphere_env.training.saved import load_model, load_replay_buffer, save_stats, stats_path


class TrainingInterrupted(Exception):
    """Training stopped by Ctrl-C or SIGTERM after saving the model, its VecNormalize statistics and a
    resumable checkpoint; the message says where and how to continue."""


def say(msg: str) -> None:
    """A note of the trainer on stderr (a fallback taken, a file missing)."""
    print(f"sphere-env train: {msg}", file=sys.stderr, flush=True)


@contextlib.contextmanager
def unchecked_distributions():
    """torch.distributions without argument validation inside the block (restored after). The checks
    (finite mean and scale, samples in the support) run at every policy call and cost 8–18% of PPO's
    rollout collection here (measured); SB3's Gaussian policies give them finite network outputs. A
    non-finite action still fails loudly: the envs refuse NaN/inf actions by name."""
    import torch

    previous = torch.distributions.Distribution._validate_args
    torch.distributions.Distribution.set_default_validate_args(False)
    try:
        yield
    finally:
        torch.distributions.Distribution.set_default_validate_args(previous)


def save_model(model, run_dir: Path, cfg: TrainConfig, callbacks=()) -> None:
    """``model.zip``, its VecNormalize statistics (``vecnormalize.json``) and a checkpoint at its step
    count, with the run's random state (that of ``callbacks`` included)."""
    model.save(run_dir / "model.zip")
    vn = model.get_vec_normalize_env()
    if vn is not None:
        save_stats(vn, run_dir / "vecnormalize.json")
    save_checkpoint(model, run_dir, cfg, callbacks)


def train_session(
    cfg: TrainConfig,
    cls,
    run_dir: Path,
    ckpt: tuple[int, Path] | None,
    start_steps: int,
    progress_bar: bool,
    verbose: int,
):
    """Train ``cls`` per ``cfg`` from ``start_steps`` to ``cfg.n_timesteps`` in ``run_dir``: from the
    checkpoint ``ckpt`` = (steps, path) when given, else from the trained agent (``-i``) or a new
    model; saved at the end (:func:`save_model`, ``timing.json``) or on an interrupt
    (:class:`TrainingInterrupted`). Returns the model."""
    resume = ckpt is not None
    venv = make_vec_env(cfg, run_dir)
    try:
        stats = None
        if resume and cfg.normalize is not None:
            stats = stats_path(_ckpt_file(run_dir, "vecnormalize", start_steps, ""))
        agent = None
        if not resume and cfg.trained_agent is not None:
            from sphere_env.training.trained_agent import trained_agent_files

            agent, stats = trained_agent_files(cfg)
        venv = wrap_normalize(cfg, venv, stats=stats)
        eval_env = None
        if cfg.eval_freq > 0:
            eval_env = wrap_normalize(cfg, make_vec_env(cfg, run_dir, evaluation=True), evaluation=True)
        tb = cfg.tensorboard_log or str(run_dir / "tb")
        callbacks = build_callbacks(cfg, run_dir, eval_env)
        own = training_state.stateful(callbacks.callbacks)
        model = _model(cfg, cls, venv, run_dir, ckpt, start_steps, agent, own, verbose, tb)
        t0 = time.perf_counter()
        try:
            with unchecked_distributions():
                model.learn(
                    total_timesteps=cfg.n_timesteps - start_steps,
                    callback=callbacks,
                    progress_bar=progress_bar,
                    reset_num_timesteps=not resume,
                    tb_log_name=cfg.algo,
                )
        except KeyboardInterrupt:
            # the rollout in progress is dropped; everything trained so far is saved and resumable
            save_model(model, run_dir, cfg, own)
            raise TrainingInterrupted(
                f"interrupted at {model.num_timesteps} env steps; saved model.zip, vecnormalize.json and a "
                f"checkpoint in {run_dir}; continue with --resume {run_dir}"
            ) from None
        wall = time.perf_counter() - t0
        save_model(model, run_dir, cfg, own)
        steps = model.num_timesteps - start_steps
        (run_dir / "timing.json").write_text(
            json.dumps(
                {
                    "num_timesteps": model.num_timesteps,
                    "steps_this_session": steps,
                    "wall_s": wall,
                    "steps_per_s": steps / wall if steps > 0 and wall > 0 else None,  # None: no step trained
                },
                indent=2,
            )
        )
    finally:
        venv.close()
    return model


def _model(cfg: TrainConfig, cls, venv, run_dir: Path, ckpt, start_steps: int, agent, own, verbose: int, tb: str):
    """The model a session trains: resumed from the checkpoint ``ckpt`` (with its replay buffer and
    random state, ``own``: the stateful callbacks), from the trained agent ``agent`` (``-i``), or new."""
    if ckpt is not None:
        model = load_model(cls, ckpt[1], cfg.algo_kwargs(), env=venv, device=cfg.device, tensorboard_log=tb)
        rb = _ckpt_file(run_dir, "replay_buffer", start_steps)
        if cfg.algo == "sac" and rb.exists():
            load_replay_buffer(model, rb)
        elif cfg.algo == "sac":
            say(f"resume: {rb.name} is missing; SAC continues with an empty replay buffer")
        _restore_random_state(model, run_dir, start_steps, own)
    elif agent is not None:
        # As rl-zoo3's -i: the saved network with the configuration's other hyperparameters
        # (schedules, batch sizes, ...), and a fresh step count up to n_timesteps.
        kwargs = {k: v for k, v in cfg.algo_kwargs().items() if k != "policy_kwargs"}
        model = load_model(
            cls,
            agent,
            cfg.algo_kwargs(),
            env=venv,
            device=cfg.device,
            verbose=verbose,
            tensorboard_log=tb,
            **kwargs,
        )
        model.set_random_seed(cfg.seed)
        rb = agent.parent / "replay_buffer.pkl"
        if cfg.algo == "sac" and rb.exists():
            load_replay_buffer(model, rb)
    else:
        model = cls(
            cfg.policy,
            venv,
            seed=cfg.seed,
            device=cfg.device,
            verbose=verbose,
            tensorboard_log=tb,
            **cfg.algo_kwargs(),
        )
    return model


def _restore_random_state(model, run_dir: Path, steps: int, callbacks) -> None:
    """The random state saved with the checkpoint at ``steps``, back in ``model``, its envs and
    ``callbacks`` (:mod:`sphere_env.training.training_state`); a checkpoint without one (written by
    an older version) resumes with the streams restarted, saying so."""
    path = training_state.state_path(run_dir, steps)
    if not path.exists():
        say(
            f"resume: {path.name} is missing (a checkpoint written before random states were saved); "
            "the envs' and the callbacks' random streams restart from the run's seeds"
        )
        return
    training_state.restore(model, training_state.read(path), callbacks)
