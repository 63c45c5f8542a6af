"""Train a stable-baselines3 agent (PPO or SAC) on a sphere_env id; one self-describing run folder.

    python -m training.train --env sphere_env/RampDescent-v2 --algo ppo
    python -m training.train --env sphere_env/Roll-v1 --algo sac -n 2e5 --seed 3
    python -m training.train --env sphere_env/RampDescent-v2 --algo ppo -conf my.yml \\
        --hyperparams n_envs:4 learning_rate:lin_3e-4 \\
        --env-kwargs shell_model:"'hydroelastic'" randomization:"{'pressure_kpa': [3, 10]}"
    python -m training.train -i runs/<run>/model.zip -n 1e5      # a new run from a trained model
    python -m training.train --resume runs/<run> -n 1e6           # continue from the last checkpoint
    python -m training.train --seeds 0 1 2 --ray-address auto     # a sweep (sphere_env.training.sweep)

The flags are rl-zoo3's (``-conf/--conf-file``, ``-params/--hyperparams key:value``,
``--env-kwargs``, ``--eval-env-kwargs``, ``-n``, ``--seed``, ``--eval-freq``, ``--eval-episodes``,
``--save-freq``, ``-f/--log-folder``, ``-tb/--tensorboard-log``, ``-i/--trained-agent``), and the
hyperparameter files are rl-zoo3 files (:mod:`sphere_env.training.config`). ``key:value`` values
are Python literals as in rl-zoo3; text that is not one stays a string. ``--env-kwargs`` (as in
``evaluate`` and ``enjoy``: ``key:value`` items or one YAML mapping ``'{shell_model: point}'``) are
merged key by key over the file's ``env_kwargs`` (rl-zoo3 replaces the mapping). Everything is validated
before a file is written.

The best model is chosen on fixed evaluation episodes: randomization off (``--eval-env-kwargs``
changes the evaluation env), the pressures ``--eval-pressures-kpa`` (default the calibration's low,
nominal and high) in turn, episode k with seed ``seed + 10000 + k`` (:class:`EvaluationEpisodes`).

A run folder holds::

    config.yaml              resolved config: env kwargs (randomization spec as given and resolved),
                             evaluation env kwargs and pressures, hyperparameters, seeds, versions
                             (drake, torch, sb3, sphere_env, ...) and the command
    model.zip                final model          vecnormalize.pkl   its VecNormalize statistics
    best/best_model.zip      best on the evaluation episodes, best/vecnormalize.pkl
    checkpoints/             rl_model_<steps>_steps.zip (+ _vecnormalize_, SAC: _replay_buffer_)
    learning_curve.csv/.png  training episodes and evaluations against env steps
    monitor/                 Monitor CSVs (info keywords: pressure_kpa, is_success)
    eval/evaluations.npz     EvalCallback log          tb/  TensorBoard logs (or -tb)
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import json
import math
import re
import sys
import time
from datetime import UTC, datetime
from functools import partial
from pathlib import Path
from typing import Any, Mapping, Sequence

import gymnasium as gym
import numpy as np
import yaml

from sphere_env.cli import parse_env_kwargs, parse_key_values
from sphere_env.schemas.training import check_sweep_options
from sphere_env.training.config import MONITOR_KEYWORDS, TrainConfig, algo_class, resolve_config
from sphere_env.training.run_folder import (
    CHECKPOINT_PREFIX,
    RUNS,
    _ckpt_file,
    _clear_outputs,
    _is_interrupted_run,
    _truncate_history,
    default_run_dir,
    latest_checkpoint,
    load_config,
    run_lock,
    write_config,
    write_learning_curves,
)

# ---- env factories (module level: picklable for SubprocVecEnv) -------------------------------------
_ENV_MONITOR = None


def _monitor_class():
    """SB3's ``Monitor`` that passes assignments to settable properties of the wrapped env (such as
    ``SphereEnv.randomization``) through, so ``venv.set_attr("randomization", spec)`` reaches the env,
    validated, on every VecEnv (SB3's ``set_attr`` assigns on the outermost wrapper, where the value
    would otherwise be stored and ignored). Built on first use: stable-baselines3 is an extra."""
    global _ENV_MONITOR
    if _ENV_MONITOR is None:
        from stable_baselines3.common.monitor import Monitor

        class EnvMonitor(Monitor):
            def __setattr__(self, name: str, value: Any) -> None:
                env = self.__dict__.get("env")
                if env is not None and name not in self.__dict__ and not hasattr(type(self), name) \
                        and isinstance(getattr(type(env.unwrapped), name, None), property):
                    env.set_wrapper_attr(name, value)
                else:
                    super().__setattr__(name, value)

        _ENV_MONITOR = EnvMonitor
    return _ENV_MONITOR


class EvaluationEpisodes(gym.Wrapper):
    """Fixed evaluation episodes: the k-th reset since :meth:`restart_evaluation` runs at pressure
    ``pressures_kpa[k % len]`` (a reset option, so no randomization moves it) with seed
    ``seed + k`` (fixing the command), whatever seed the caller passes. Every evaluation round thus
    plays the same episodes, and best-model selection compares policies on them. An empty
    ``pressures_kpa`` keeps the seeds and leaves the pressure to the env."""

    def __init__(self, env: gym.Env, pressures_kpa: Sequence[float], seed: int):
        super().__init__(env)
        self.pressures_kpa = [float(p) for p in pressures_kpa]
        self.first_seed = int(seed)
        self.episode = 0

    def restart_evaluation(self) -> None:
        """The next reset plays the first evaluation episode again."""
        self.episode = 0

    def reset(self, *, seed: int | None = None, options: Mapping[str, Any] | None = None):
        k = self.episode
        self.episode += 1
        opts = dict(options or {})
        if self.pressures_kpa:
            opts.setdefault("pressure_kpa", self.pressures_kpa[k % len(self.pressures_kpa)])
        return self.env.reset(seed=self.first_seed + k, options=opts or None)


def make_env(env_id: str, env_kwargs: Mapping[str, Any], seed: int, monitor_file: str | None = None,
             torch_threads: int = 1, eval_pressures_kpa: Sequence[float] | None = None,
             env_wrapper: Sequence[Mapping[str, Mapping[str, Any]]] = ()):
    """Build one Monitor-wrapped env seeded with ``seed`` (called inside the worker), inside the
    ``env_wrapper`` entries (``TrainConfig.env_wrapper``). ``eval_pressures_kpa`` (a list, possibly
    empty) makes it an evaluation env (:class:`EvaluationEpisodes`)."""
    import sphere_env  # noqa: F401 - registers the ids

    try:
        import torch

        torch.set_num_threads(torch_threads)
    except ImportError:  # pragma: no cover
        pass
    from sphere_env.training.config import apply_env_wrappers

    env = apply_env_wrappers(gym.make(env_id, **dict(env_kwargs)), env_wrapper)
    if eval_pressures_kpa is not None:
        env = EvaluationEpisodes(env, eval_pressures_kpa, seed)
    # A new file gets SB3's header (what stable_baselines3.common.monitor.load_results reads); a
    # resumed run appends to its file.
    fresh = monitor_file is None or not Path(monitor_file + ".monitor.csv").exists()
    env = _monitor_class()(env, filename=monitor_file, info_keywords=MONITOR_KEYWORDS, override_existing=fresh)
    if not fresh:  # the episode times continue from the file's last one, without the time the run was stopped
        env.t_start = time.time() - _last_monitor_time_s(Path(monitor_file + ".monitor.csv"))
    env.reset(seed=seed)
    env.action_space.seed(seed)
    return env


def _last_monitor_time_s(path: Path) -> float:
    """The ``t`` [s] of a Monitor CSV's last episode (0 without one)."""
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(line for line in f if not line.startswith("#"))]
    if len(rows) < 2:
        return 0.0
    return float(rows[-1][rows[0].index("t")])


def make_vec_env(cfg: TrainConfig, run_dir: Path | None, evaluation: bool = False):
    """Training or evaluation (one in-process env) VecEnv. Training: ``BatchedSubprocVecEnv`` when
    ``n_workers`` is set (``auto``: the usable cores, at most ``n_envs``), ``ThreadedVecEnv`` when
    ``n_threads`` is, else SB3's ``SubprocVecEnv`` whose bad calls raise in the caller
    (``SafeSubprocVecEnv``; ``DummyVecEnv`` for one env)."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    kwargs = cfg.make_kwargs(evaluation)
    mon = None if run_dir is None else run_dir / "monitor"
    if mon is not None:
        mon.mkdir(parents=True, exist_ok=True)
    if evaluation:
        fns = [partial(make_env, cfg.env_id, kwargs, cfg.eval_seed,
                       None if mon is None else str(mon / "eval"), cfg.torch_threads, cfg.eval_pressures_kpa or [],
                       cfg.env_wrapper)]
        return DummyVecEnv(fns)
    fns = [partial(make_env, cfg.env_id, kwargs, s, None if mon is None else str(mon / f"train_{rank}"),
                   cfg.torch_threads, None, cfg.env_wrapper) for rank, s in enumerate(cfg.worker_seeds)]
    if cfg.n_envs == 1:
        venv = DummyVecEnv(fns)
    elif cfg.n_workers is not None:
        from sphere_env.training.vec_env import BatchedSubprocVecEnv, usable_cores

        n_workers = min(usable_cores(), cfg.n_envs) if cfg.n_workers == "auto" else cfg.n_workers
        venv = BatchedSubprocVecEnv(fns, n_workers)
    elif cfg.n_threads is not None:
        from sphere_env.training.vec_env import ThreadedVecEnv

        venv = ThreadedVecEnv(fns, None if cfg.n_threads == "auto" else cfg.n_threads)
    else:
        from sphere_env.training.vec_env import SafeSubprocVecEnv

        venv = SafeSubprocVecEnv(fns)
    venv.seed(cfg.seed)
    return venv


def wrap_normalize(cfg: TrainConfig, venv, evaluation: bool = False, stats: Path | None = None):
    """VecNormalize per ``cfg.normalize`` (loaded from ``stats`` when given)."""
    from stable_baselines3.common.vec_env import VecNormalize

    if cfg.normalize is None:
        return venv
    if stats is not None:
        venv = VecNormalize.load(str(stats), venv)
    else:
        venv = VecNormalize(venv, **cfg.normalize)
    if evaluation:
        venv.training = False
        venv.norm_reward = False
    return venv


# ---- callbacks ---------------------------------------------------------------------------------------
def _callbacks(cfg: TrainConfig, run_dir: Path, eval_env):
    from stable_baselines3.common.callbacks import BaseCallback, CallbackList, CheckpointCallback, EvalCallback

    class FixedEpisodesEvalCallback(EvalCallback):
        """EvalCallback whose every evaluation plays the same episodes (:class:`EvaluationEpisodes`)."""

        def _on_step(self) -> bool:
            if self.eval_freq > 0 and self.n_calls % self.eval_freq == 0:
                self.eval_env.env_method("restart_evaluation")
            return super()._on_step()

    class SaveVecNormalize(BaseCallback):
        """On a new best evaluation: save the VecNormalize statistics beside best_model.zip."""

        def _on_step(self) -> bool:
            vn = self.model.get_vec_normalize_env()
            if vn is not None:
                vn.save(str(run_dir / "best" / "vecnormalize.pkl"))
            return True

    class EpisodeLog(BaseCallback):
        """Append every finished training episode (exact global step) to learning_curve_train.csv."""

        def _on_training_start(self) -> None:
            path = run_dir / "learning_curve_train.csv"
            new = not path.exists()
            self._f = open(path, "a", newline="")
            self._w = csv.writer(self._f)
            if new:
                self._w.writerow(["timesteps", "return", "length", "is_success", "pressure_kpa", "shell_model", "params",
                                  "env"])

        def _on_step(self) -> bool:
            for rank, info in enumerate(self.locals.get("infos", ())):
                ep = info.get("episode")
                if ep is not None:
                    # the episode's sampled parameters (pressure, faults, ...), so training success
                    # can be split by them
                    params = {k: (list(v) if isinstance(v, tuple) else v) for k, v in (info.get("params") or {}).items()}
                    self._w.writerow([self.num_timesteps, f"{ep['r']:.6g}", ep["l"], int(bool(info.get("is_success"))),
                                      f"{info.get('pressure_kpa', float('nan')):.4g}", info.get("shell_model", ""),
                                      json.dumps(params, default=float), rank])
                    self._f.flush()
            return True

        def _on_training_end(self) -> None:
            self._f.close()

    n = cfg.n_envs
    callbacks: list[BaseCallback] = [EpisodeLog()]
    if cfg.checkpoint_freq > 0:
        callbacks.insert(0, CheckpointCallback(
            save_freq=max(cfg.checkpoint_freq // n, 1), save_path=str(run_dir / "checkpoints"),
            name_prefix=CHECKPOINT_PREFIX, save_vecnormalize=cfg.normalize is not None,
            save_replay_buffer=cfg.algo == "sac" and cfg.save_replay_buffer))
    if eval_env is None:
        return CallbackList(callbacks)
    ev = FixedEpisodesEvalCallback(
        eval_env, callback_on_new_best=SaveVecNormalize(), n_eval_episodes=cfg.eval_episodes,
        eval_freq=max(cfg.eval_freq // n, 1), log_path=str(run_dir / "eval"),
        best_model_save_path=str(run_dir / "best"), deterministic=True, verbose=0)
    callbacks.insert(len(callbacks) - 1, ev)
    old = run_dir / "eval" / "evaluations.npz"
    if old.exists():  # resume: keep earlier evaluations in the log
        d = np.load(old)
        ev.evaluations_timesteps = list(d["timesteps"])
        ev.evaluations_results = [list(r) for r in d["results"]]
        ev.evaluations_length = [list(r) for r in d["ep_lengths"]]
        if "successes" in d:
            ev.evaluations_successes = [list(r) for r in d["successes"]]
        ev.best_mean_reward = float(np.max(np.mean(d["results"], axis=1))) if len(d["results"]) else -np.inf
    return CallbackList(callbacks)


# ---- checkpoints -----------------------------------------------------------------------------------
def save_checkpoint(model, run_dir: Path, cfg: TrainConfig) -> None:
    """Checkpoint at the model's current step count (same names as CheckpointCallback)."""
    n = model.num_timesteps
    (run_dir / "checkpoints").mkdir(parents=True, exist_ok=True)
    model.save(run_dir / "checkpoints" / f"{CHECKPOINT_PREFIX}_{n}_steps.zip")
    vn = model.get_vec_normalize_env()
    if vn is not None:
        vn.save(str(_ckpt_file(run_dir, "vecnormalize", n)))
    if cfg.algo == "sac" and cfg.save_replay_buffer:
        model.save_replay_buffer(_ckpt_file(run_dir, "replay_buffer", n))


# ---- learning curves -------------------------------------------------------------------------------
class TrainingInterrupted(Exception):
    """Training stopped by Ctrl-C or SIGTERM after saving the model, its VecNormalize statistics and a
    resumable checkpoint; the message says where and how to continue."""


def _say(msg: str) -> None:
    print(f"training.train: {msg}", file=sys.stderr, flush=True)


def _checkpoint_problem(cls, cfg: TrainConfig, run_dir: Path, steps: int, path: Path) -> str | None:
    """Why the checkpoint at ``steps`` cannot be resumed from (None: it can)."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as z:
            bad = z.testzip()
        if bad is not None:
            return f"{path.name} is corrupt ({bad})"
        cls.load(path, device="cpu")
    except Exception as err:  # noqa: BLE001 - any failure to read means "not usable"
        return f"{path.name} cannot be read ({type(err).__name__}: {err})"
    if cfg.normalize is not None:
        vn = _ckpt_file(run_dir, "vecnormalize", steps)
        if not vn.exists():
            return f"{vn.name} (its VecNormalize statistics) is missing"
        try:
            import pickle

            with open(vn, "rb") as f:
                pickle.load(f)
        except Exception as err:  # noqa: BLE001
            return f"{vn.name} cannot be read ({type(err).__name__}: {err})"
    return None


def usable_checkpoint(cls, cfg: TrainConfig, run_dir: Path) -> tuple[tuple[int, Path] | None, list[str]]:
    """The newest checkpoint that loads (model and, with normalization, its VecNormalize file) and
    the reasons the newer ones were skipped."""
    found = []
    for p in (run_dir / "checkpoints").glob(f"{CHECKPOINT_PREFIX}_*_steps.zip"):
        m = re.fullmatch(rf"{CHECKPOINT_PREFIX}_(\d+)_steps\.zip", p.name)
        if m:
            found.append((int(m.group(1)), p))
    skipped = []
    for steps, path in sorted(found, reverse=True):
        problem = _checkpoint_problem(cls, cfg, run_dir, steps, path)
        if problem is None:
            return (steps, path), skipped
        skipped.append(problem)
    return None, skipped


def train(cfg: TrainConfig, run_dir: str | Path | None = None, resume: bool = False, progress_bar: bool = True,
          verbose: int = 0, command: Sequence[str] | None = None, return_model: bool = False):
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


def _train_locked(cfg: TrainConfig, cls, run_dir: Path, resume: bool, created: bool, progress_bar: bool,
                  verbose: int, command: Sequence[str] | None, return_model: bool):
    start_steps = 0
    ckpt = None
    previous: dict[str, Any] = {}
    if resume:
        if not (run_dir / "config.yaml").exists():
            raise ValueError(f"resume: {str(run_dir)!r} has no config.yaml (not a training run folder)")
        try:
            previous = yaml.safe_load((run_dir / "config.yaml").read_text()) or {}
        except yaml.YAMLError as err:
            raise ValueError(f"resume: {str(run_dir / 'config.yaml')!r} cannot be read: "
                             + " ".join(str(err).split())) from None
        ckpt, skipped = usable_checkpoint(cls, cfg, run_dir)
        if ckpt is None and skipped:
            raise ValueError(f"resume: no usable checkpoint in {str(run_dir / 'checkpoints')!r}: "
                             + "; ".join(skipped) + ". Start a new run (another --run-dir)")
        if ckpt is not None:
            start_steps = ckpt[0]
            if start_steps >= cfg.n_timesteps:
                raise ValueError(f"n_timesteps: {cfg.n_timesteps} already reached (checkpoint at {start_steps}); "
                                 "pass a larger --n-timesteps to continue")
            for problem in skipped:
                _say(f"resume: skipping a checkpoint: {problem}")
            if skipped:
                _say(f"resume: falling back to the checkpoint at {start_steps} steps")
            _truncate_history(run_dir, start_steps)
        else:
            _say(f"resume: {str(run_dir)!r} has no checkpoint (stopped before the first one); "
                 "restarting from scratch in the same folder")
            _clear_outputs(run_dir)
            resume = False
    else:
        if (run_dir / "config.yaml").exists():
            if not _is_interrupted_run(run_dir):
                raise ValueError(f"run_dir: {str(run_dir)!r} already holds a run; use --resume or another folder")
            _say(f"run_dir: {str(run_dir)!r} holds a run stopped before its first checkpoint; "
                 "starting over in it")
            _clear_outputs(run_dir)
    extra: dict[str, Any] = {}
    if previous:  # keep the original command; list the resume commands
        extra["command"] = previous.get("command", [])
        extra["created_utc"] = previous.get("created_utc")
        extra["resume_commands"] = [*previous.get("resume_commands", []),
                                    {"command": list(command) if command is not None else [],
                                     "from_steps": start_steps,
                                     "utc": datetime.now(UTC).isoformat(timespec="seconds")}]
        extra["resumed_from_steps"] = start_steps
    try:
        write_config(cfg, run_dir, command, extra=extra or None)
        result = _train_session(cfg, cls, run_dir, ckpt, start_steps, progress_bar, verbose)
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


def _train_session(cfg: TrainConfig, cls, run_dir: Path, ckpt: tuple[int, Path] | None, start_steps: int,
                   progress_bar: bool, verbose: int):
    resume = ckpt is not None
    venv = make_vec_env(cfg, run_dir)
    try:
        stats = _ckpt_file(run_dir, "vecnormalize", start_steps) if resume and cfg.normalize is not None else None
        agent = None
        if not resume and cfg.trained_agent is not None:
            from sphere_env.training.trained_agent import trained_agent_files

            agent, stats = trained_agent_files(cfg)
        venv = wrap_normalize(cfg, venv, stats=stats)
        eval_env = None
        if cfg.eval_freq > 0:
            eval_env = wrap_normalize(cfg, make_vec_env(cfg, run_dir, evaluation=True), evaluation=True)
        tb = cfg.tensorboard_log or str(run_dir / "tb")
        if resume:
            model = cls.load(ckpt[1], env=venv, device=cfg.device, tensorboard_log=tb)
            rb = _ckpt_file(run_dir, "replay_buffer", start_steps)
            if cfg.algo == "sac" and rb.exists():
                model.load_replay_buffer(rb)
            elif cfg.algo == "sac":
                _say(f"resume: {rb.name} is missing; SAC continues with an empty replay buffer")
        elif agent is not None:
            # As rl-zoo3's -i: the saved network with the configuration's other hyperparameters
            # (schedules, batch sizes, ...), and a fresh step count up to n_timesteps.
            kwargs = {k: v for k, v in cfg.algo_kwargs().items() if k != "policy_kwargs"}
            model = cls.load(agent, env=venv, device=cfg.device, verbose=verbose, tensorboard_log=tb, **kwargs)
            model.set_random_seed(cfg.seed)
            rb = agent.parent / "replay_buffer.pkl"
            if cfg.algo == "sac" and rb.exists():
                model.load_replay_buffer(rb)
        else:
            model = cls(cfg.policy, venv, seed=cfg.seed, device=cfg.device, verbose=verbose,
                        tensorboard_log=tb, **cfg.algo_kwargs())
        t0 = time.perf_counter()
        try:
            with unchecked_distributions():
                model.learn(total_timesteps=cfg.n_timesteps - start_steps, callback=_callbacks(cfg, run_dir, eval_env),
                            progress_bar=progress_bar, reset_num_timesteps=not resume, tb_log_name=cfg.algo)
        except KeyboardInterrupt:
            # the rollout in progress is dropped; everything trained so far is saved and resumable
            model.save(run_dir / "model.zip")
            vn = model.get_vec_normalize_env()
            if vn is not None:
                vn.save(str(run_dir / "vecnormalize.pkl"))
            save_checkpoint(model, run_dir, cfg)
            raise TrainingInterrupted(
                f"interrupted at {model.num_timesteps} env steps; saved model.zip, vecnormalize.pkl and a "
                f"checkpoint in {run_dir}; continue with --resume {run_dir}") from None
        wall = time.perf_counter() - t0
        model.save(run_dir / "model.zip")
        vn = model.get_vec_normalize_env()
        if vn is not None:
            vn.save(str(run_dir / "vecnormalize.pkl"))
        save_checkpoint(model, run_dir, cfg)
        steps = model.num_timesteps - start_steps
        (run_dir / "timing.json").write_text(json.dumps(
            {"num_timesteps": model.num_timesteps, "steps_this_session": steps, "wall_s": wall,
             "steps_per_s": steps / wall if wall > 0 else math.nan}, indent=2))
    finally:
        venv.close()
    return model


class StoreDict(argparse.Action):
    """rl-zoo3's ``key:value ...`` arguments as a dict: each value is read as a Python literal
    (``ast.literal_eval``: numbers, strings in quotes, True/False/None, lists, tuples, dicts); text
    that is not a literal stays a string (``learning_rate:lin_5e-4``, ``policy_kwargs:"dict(...)"``),
    as rl-zoo3 users write it. A value that opens a mapping or list but is not a Python literal
    (YAML flow style ``{base: full}``) is refused: write ``{'base': 'full'}``."""

    def __call__(self, parser, namespace, values, option_string=None):
        try:
            parse = parse_env_kwargs if self.dest.endswith("env_kwargs") else parse_key_values
            setattr(namespace, self.dest, {**(getattr(namespace, self.dest) or {}), **parse(values, self.dest)})
        except ValueError as err:
            parser.exit(2, f"{parser.prog}: error: {err}\n")


def build_parser() -> argparse.ArgumentParser:
    """The command line: rl-zoo3's ``train.py`` flags for what this trainer does, plus its own."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default="sphere_env/RampDescent-v3", help="registered env id")
    parser.add_argument("--algo", default="ppo", help="ppo or sac")
    parser.add_argument("-conf", "--conf-file", type=Path, default=None,
                        help="hyperparameter YAML (default: the shipped training/hyperparams/<algo>.yml)")
    parser.add_argument("-params", "--hyperparams", "--params", dest="hyperparams", nargs="+", action=StoreDict,
                        default={}, metavar="KEY:VALUE",
                        help="override hyperparameters, e.g. n_envs:4 learning_rate:1e-3 (values as Python literals)")
    parser.add_argument("--env-kwargs", nargs="+", action=StoreDict, default={}, metavar="KEY:VALUE",
                        help="env kwargs merged over the YAML's env_kwargs, e.g. shell_model:'hydroelastic' "
                             "randomization:\"{'base': 'full'}\"")
    parser.add_argument("--eval-env-kwargs", nargs="+", action=StoreDict, default={}, metavar="KEY:VALUE",
                        help="evaluation env kwargs over the training ones (default randomization:'off')")
    parser.add_argument("-n", "--n-timesteps", type=float, default=None, help="total env steps (overrides the YAML)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (-1: draw one, as rl-zoo3)")
    parser.add_argument("--seeds", type=int, nargs="+", default=None,
                        help="train one run per seed (a sweep: one folder per trial, aggregate learning curve)")
    parser.add_argument("--trial", action="append", default=None, metavar="'KEY:VALUE ...'",
                        help="a sweep configuration: --hyperparams overrides in one quoted string; repeat for more")
    parser.add_argument("--ray-address", default=None,
                        help="run the sweep's trials as Ray tasks: 'local' (start one), 'auto', or ray://host:port")
    parser.add_argument("-f", "--log-folder", type=Path, default=RUNS, help="folder of the run folders (default runs/)")
    parser.add_argument("--run-dir", type=Path, default=None,
                        help="exact run (or sweep) folder (default <log-folder>/<algo>_<env>_<time>_s<seed>)")
    parser.add_argument("--resume", type=Path, default=None, help="continue this run folder from its last checkpoint")
    parser.add_argument("-i", "--trained-agent", type=Path, default=None,
                        help="start from this model.zip (with its VecNormalize statistics) in a new run folder")
    parser.add_argument("--eval-freq", type=int, default=None, help="env steps between evaluations (<= 0: none)")
    parser.add_argument("--eval-episodes", type=int, default=6,
                        help="episodes per evaluation, cycling over --eval-pressures-kpa (default 6)")
    parser.add_argument("--eval-pressures-kpa", type=float, nargs="*", default=None,
                        help="evaluation pressures (default: the calibration's low, nominal, high; "
                             "none given: the eval env's randomization draws them)")
    parser.add_argument("--save-freq", "--checkpoint-freq", dest="save_freq", type=int, default=None,
                        help="env steps between checkpoints (<= 0: only the final one)")
    parser.add_argument("-tb", "--tensorboard-log", type=Path, default=None, help="TensorBoard folder (default <run>/tb)")
    parser.add_argument("--torch-threads", "--num-threads", dest="torch_threads", type=int, default=1)
    parser.add_argument("--device", default="cpu", help="torch device (default cpu)")
    parser.add_argument("--save-replay-buffer", action="store_true",
                        help="SAC: keep the replay buffer in every checkpoint (hundreds of MB); without it a "
                             "resumed run starts with an empty buffer")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("-v", "--verbose", type=int, default=0)
    return parser


def main(argv: Sequence[str] | None = None) -> Path:
    parser = build_parser()
    args = parser.parse_args(argv)
    command = [sys.executable, "-m", "sphere_env.training.train",
               *(argv if argv is not None else sys.argv[1:])]
    import signal

    def _terminate(signum, frame):  # SIGTERM ends a training as Ctrl-C does: saved, then exit
        raise KeyboardInterrupt

    previous_term = signal.signal(signal.SIGTERM, _terminate)
    try:
        if args.resume is not None:
            run = _resume(args, command)
        elif args.seeds is not None or args.trial is not None or args.ray_address is not None:
            from sphere_env.training.sweep import run_sweep

            run = run_sweep(sweep_configs(args), args.run_dir or default_sweep_dir(args), ray_address=args.ray_address,
                            command=command)
        else:
            cfg = _config_from_args(args, args.hyperparams, args.seed)
            run = train(cfg, args.run_dir or default_run_dir(cfg, args.log_folder),
                        progress_bar=not args.no_progress, verbose=args.verbose, command=command)
    except ValueError as err:
        parser.exit(2, f"{parser.prog}: error: {err}\n")
    except TrainingInterrupted as err:
        parser.exit(130, f"{parser.prog}: {err}\n")
    except KeyboardInterrupt:
        parser.exit(130, f"{parser.prog}: interrupted before training started; nothing saved\n")
    finally:
        signal.signal(signal.SIGTERM, previous_term)
    print(f"run folder: {run.resolve()}")
    return run


def _seed(seed: int) -> int:
    """rl-zoo3's ``--seed -1``: draw a seed."""
    return int(np.random.default_rng().integers(2**31 - 1)) if seed < 0 else seed


def _config_from_args(args: argparse.Namespace, hyperparams: Mapping[str, Any], seed: int) -> TrainConfig:
    overrides = dict(hyperparams)
    if args.n_timesteps is not None:
        overrides["n_timesteps"] = args.n_timesteps
    return resolve_config(
        args.env, args.algo, args.conf_file, overrides, seed=_seed(seed), eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes, eval_env_kwargs=args.eval_env_kwargs,
        eval_pressures_kpa=args.eval_pressures_kpa, checkpoint_freq=args.save_freq, device=args.device,
        torch_threads=args.torch_threads, env_kwargs=args.env_kwargs, tensorboard_log=args.tensorboard_log,
        trained_agent=args.trained_agent, save_replay_buffer=args.save_replay_buffer)


def sweep_configs(args: argparse.Namespace) -> list[TrainConfig]:
    """One validated config per trial: every ``--trial`` (or the plain overrides) × every seed."""
    opts = check_sweep_options(seeds=args.seeds if args.seeds is not None else [args.seed],
                               trained_agent=args.trained_agent, tensorboard_log=args.tensorboard_log)
    trials = [dict(args.hyperparams)] if not args.trial else [
        {**args.hyperparams, **parse_key_values(t.split(), "trial")} for t in args.trial]
    return [_config_from_args(args, h, s) for h in trials for s in opts.seeds]


def default_sweep_dir(args: argparse.Namespace) -> Path:
    stamp = datetime.now(UTC).strftime("%Y%m%d-%H%M%S")
    return args.log_folder / f"sweep_{args.algo}_{args.env.split('/')[-1]}_{stamp}"


def _resume(args: argparse.Namespace, command: Sequence[str]) -> Path:
    cfg = load_config(args.resume)
    if args.n_timesteps is not None:
        cfg.n_timesteps = args.n_timesteps  # checked with the rest by resolve_config
    cfg = resolve_config(cfg.env_id, cfg.algo, cfg.hyperparams_file or None, overrides=_stored_overrides(cfg),
                         seed=cfg.seed, eval_freq=cfg.eval_freq, eval_episodes=cfg.eval_episodes,
                         eval_env_kwargs=cfg.eval_env_kwargs, eval_pressures_kpa=cfg.eval_pressures_kpa,
                         checkpoint_freq=cfg.checkpoint_freq, device=cfg.device, torch_threads=cfg.torch_threads,
                         tensorboard_log=cfg.tensorboard_log)
    return train(cfg, args.resume, resume=True, progress_bar=not args.no_progress, verbose=args.verbose,
                 command=command)


def _stored_overrides(cfg: TrainConfig) -> dict[str, Any]:
    """A stored config as YAML-section overrides (so a resume re-validates exactly what ran)."""
    return {"n_envs": cfg.n_envs, "n_workers": cfg.n_workers, "n_threads": cfg.n_threads, "n_timesteps": cfg.n_timesteps, "policy": cfg.policy,
            "normalize": cfg.normalize if cfg.normalize is not None else False,
            "env_kwargs": cfg.env_kwargs, "env_wrapper": cfg.env_wrapper or None, **cfg.hyperparams}


if __name__ == "__main__":
    # Run the package copy (sphere_env.training.train), also under `python -m training.train`, so
    # that worker processes unpickle this module's functions by a name they can import.
    from sphere_env.training.train import main as _main

    _main()
