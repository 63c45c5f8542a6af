"""The callbacks of a training run and its checkpoints: what is logged and saved while SB3 learns.

:func:`build_callbacks` gives periodic checkpoints (``checkpoints/``), the evaluations on fixed
episodes that choose ``best/`` (with its VecNormalize statistics), the run's own callbacks
(``callback`` in the hyperparameters, e.g. :class:`sphere_env.training.curriculum.SuccessCurriculum`)
and the log of every finished training episode (``learning_curve_train.csv``); on resume, earlier evaluations stay in the log.
:func:`save_checkpoint` writes a checkpoint at the model's current step count, named as the
checkpoint callback names them, for the end of a session or an interrupted one. Every checkpoint
keeps the run's random state beside it (:mod:`sphere_env.training.training_state`), taken after
every other callback has seen the step.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, CallbackList, CheckpointCallback, EvalCallback

from sphere_env.training import training_state
from sphere_env.training.config import TrainConfig, make_callbacks
from sphere_env.training.run_folder import CHECKPOINT_PREFIX, _ckpt_file
from sphere_env.training.saved import STATS_SUFFIX, save_stats

EPISODE_COLUMNS = ["timesteps", "return", "length", "is_success", "pressure_kpa", "shell_model", "params", "env"]


class Checkpoint(CheckpointCallback):
    """SB3's checkpoint, with the run's random state (that of the envs, the process and the
    callbacks ``own`` that keep one) and its VecNormalize statistics (JSON) beside it."""

    def __init__(self, run_dir: Path, own, **kwargs):
        super().__init__(**kwargs)
        self.run_dir = run_dir
        self.own = own

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq == 0:
            training_state.save(self.model, self.own, self.run_dir)
            vn = self.model.get_vec_normalize_env()
            if vn is not None:
                save_stats(vn, _ckpt_file(self.run_dir, "vecnormalize", self.num_timesteps, STATS_SUFFIX))
        return super()._on_step()


class FixedEpisodesEvalCallback(EvalCallback):
    """EvalCallback whose every evaluation plays the same episodes (:class:`EvaluationEpisodes`)."""

    def _on_step(self) -> bool:
        if self.eval_freq > 0 and self.n_calls % self.eval_freq == 0:
            self.eval_env.env_method("restart_evaluation")
        return super()._on_step()

    def keep_earlier(self, path: Path) -> None:
        """Continue the log of an earlier session (``evaluations.npz``): its evaluations and best
        mean reward."""
        d = np.load(path)
        self.evaluations_timesteps = list(d["timesteps"])
        self.evaluations_results = [list(r) for r in d["results"]]
        self.evaluations_length = [list(r) for r in d["ep_lengths"]]
        if "successes" in d:
            self.evaluations_successes = [list(r) for r in d["successes"]]
        self.best_mean_reward = float(np.max(np.mean(d["results"], axis=1))) if len(d["results"]) else -np.inf


class SaveVecNormalize(BaseCallback):
    """On a new best evaluation: save the VecNormalize statistics beside best_model.zip."""

    def __init__(self, run_dir: Path):
        super().__init__()
        self.run_dir = run_dir

    def _on_step(self) -> bool:
        vn = self.model.get_vec_normalize_env()
        if vn is not None:
            save_stats(vn, self.run_dir / "best" / f"vecnormalize{STATS_SUFFIX}")
        return True


class EpisodeLog(BaseCallback):
    """Append every finished training episode (exact global step) to learning_curve_train.csv."""

    def __init__(self, run_dir: Path):
        super().__init__()
        self.run_dir = run_dir

    def _on_training_start(self) -> None:
        path = self.run_dir / "learning_curve_train.csv"
        new = not path.exists()
        self._f = open(path, "a", newline="")
        self._w = csv.writer(self._f)
        if new:
            self._w.writerow(EPISODE_COLUMNS)

    def _on_step(self) -> bool:
        for rank, info in enumerate(self.locals.get("infos", ())):
            ep = info.get("episode")
            if ep is not None:
                self._w.writerow(_episode_row(self.num_timesteps, rank, ep, info))
                self._f.flush()
        return True

    def _on_training_end(self) -> None:
        self._f.close()


def _episode_row(timesteps: int, rank: int, ep: dict, info: dict) -> list:
    """One row of learning_curve_train.csv (:data:`EPISODE_COLUMNS`): with the episode's sampled
    parameters (pressure, faults, ...), so that training success can be split by them."""
    params = {k: (list(v) if isinstance(v, tuple) else v) for k, v in (info.get("params") or {}).items()}
    return [
        timesteps,
        f"{ep['r']:.6g}",
        ep["l"],
        int(bool(info.get("is_success"))),
        f"{info.get('pressure_kpa', float('nan')):.4g}",
        info.get("shell_model", ""),
        json.dumps(params, default=float),
        rank,
    ]


def build_callbacks(cfg: TrainConfig, run_dir: Path, eval_env) -> CallbackList:
    """The run's callbacks: its own (``callback``), evaluations that choose ``best/`` (with an
    ``eval_env``), the training-episode log and periodic checkpoints (``checkpoint_freq`` > 0), in
    that order: a checkpoint holds what every other callback made of its step."""
    n = cfg.n_envs
    # the run's own callbacks (hyperparams ``callback``) see each step before the episode log
    own = make_callbacks(cfg)
    callbacks: list[BaseCallback] = [*own, EpisodeLog(run_dir)]
    if cfg.checkpoint_freq > 0:
        callbacks.append(
            Checkpoint(
                run_dir,
                own,
                save_freq=max(cfg.checkpoint_freq // n, 1),
                save_path=str(run_dir / "checkpoints"),
                name_prefix=CHECKPOINT_PREFIX,
                save_vecnormalize=False,  # saved as JSON by Checkpoint
                save_replay_buffer=cfg.algo == "sac" and cfg.save_replay_buffer,
            ),
        )
    if eval_env is None:
        return CallbackList(callbacks)
    ev = FixedEpisodesEvalCallback(
        eval_env,
        callback_on_new_best=SaveVecNormalize(run_dir),
        n_eval_episodes=cfg.eval_episodes,
        eval_freq=max(cfg.eval_freq // n, 1),
        log_path=str(run_dir / "eval"),
        best_model_save_path=str(run_dir / "best"),
        deterministic=True,
        verbose=0,
    )
    callbacks.insert(len(own), ev)
    old = run_dir / "eval" / "evaluations.npz"
    if old.exists():  # resume: keep earlier evaluations in the log
        ev.keep_earlier(old)
    return CallbackList(callbacks)


def save_checkpoint(model, run_dir: Path, cfg: TrainConfig, callbacks=()) -> None:
    """Checkpoint at the model's current step count (same names as CheckpointCallback), with the
    run's random state (its envs', the process's and that of ``callbacks`` that keep one)."""
    n = model.num_timesteps
    (run_dir / "checkpoints").mkdir(parents=True, exist_ok=True)
    training_state.save(model, callbacks, run_dir)
    model.save(run_dir / "checkpoints" / f"{CHECKPOINT_PREFIX}_{n}_steps.zip")
    vn = model.get_vec_normalize_env()
    if vn is not None:
        save_stats(vn, _ckpt_file(run_dir, "vecnormalize", n, STATS_SUFFIX))
    if cfg.algo == "sac" and cfg.save_replay_buffer:
        model.save_replay_buffer(_ckpt_file(run_dir, "replay_buffer", n))
