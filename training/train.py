"""Train a stable-baselines3 agent (PPO or SAC) on a sphere_env id; one self-describing run folder.

    python -m training.train --env sphere_env/RampDescent-v2 --algo ppo
    python -m training.train --env sphere_env/Roll-v1 --algo sac --n-timesteps 2e5 --seed 3
    python -m training.train --env sphere_env/RampDescent-v2 --algo ppo \\
        --params n_envs:2 learning_rate:lin_3e-4 "randomization:{pressure_kpa: [3, 10]}"
    python -m training.train --resume runs/ppo_RampDescent-v2_...   # continue from the last checkpoint

A run folder holds::

    config.yaml              resolved config: env kwargs, randomization spec, hyperparameters,
                             seeds, versions (drake, torch, sb3, sphere_env, ...) and the command
    model.zip                final model          vecnormalize.pkl   its VecNormalize statistics
    best/best_model.zip      best on the eval env best/vecnormalize.pkl
    checkpoints/             rl_model_<steps>_steps.zip (+ _vecnormalize_, SAC: _replay_buffer_)
    learning_curve.csv/.png  training episodes and evaluations against env steps
    monitor/                 Monitor CSVs (info keywords: pressure_kpa, is_success)
    eval/evaluations.npz     EvalCallback log          tb/  TensorBoard logs
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import re
import sys
import time
from datetime import datetime, timezone
from functools import partial
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import yaml

from sphere_env.provenance import software_versions
from sphere_env.training.config import MONITOR_KEYWORDS, TrainConfig, _int, algo_class, resolve_config
from sphere_env.files import write_text_atomic

RUNS = Path("runs")
CHECKPOINT_PREFIX = "rl_model"
EVAL_SEED_OFFSET = 10_000


# ---- env factories (module level: picklable for SubprocVecEnv) -------------------------------------
def make_env(env_id: str, env_kwargs: Mapping[str, Any], seed: int, monitor_file: str | None = None,
             torch_threads: int = 1):
    """Build one Monitor-wrapped env seeded with ``seed`` (called inside the worker)."""
    import gymnasium as gym
    from stable_baselines3.common.monitor import Monitor

    import sphere_env  # noqa: F401 - registers the ids

    try:
        import torch

        torch.set_num_threads(torch_threads)
    except ImportError:  # pragma: no cover
        pass
    env = gym.make(env_id, **dict(env_kwargs))
    env = Monitor(env, filename=monitor_file, info_keywords=MONITOR_KEYWORDS, override_existing=False)
    env.reset(seed=seed)
    env.action_space.seed(seed)
    return env


def make_vec_env(cfg: TrainConfig, run_dir: Path | None, evaluation: bool = False):
    """Training or evaluation (one in-process env) VecEnv. Training: ``ThreadedVecEnv`` when
    ``n_threads`` is set (``auto``: the usable cores, at most ``n_envs``), ``BatchedSubprocVecEnv``
    when ``n_workers`` < ``n_envs``, else ``SubprocVecEnv`` (``DummyVecEnv`` for one env)."""
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    kwargs = cfg.make_kwargs(evaluation)
    mon = None if run_dir is None else run_dir / "monitor"
    if mon is not None:
        mon.mkdir(parents=True, exist_ok=True)
    if evaluation:
        fns = [partial(make_env, cfg.env_id, kwargs, cfg.eval_seed,
                       None if mon is None else str(mon / "eval"), cfg.torch_threads)]
        return DummyVecEnv(fns)
    fns = [partial(make_env, cfg.env_id, kwargs, s, None if mon is None else str(mon / f"train_{rank}"),
                   cfg.torch_threads) for rank, s in enumerate(cfg.worker_seeds)]
    if cfg.n_threads is not None and cfg.n_envs > 1:
        from sphere_env.training.vec_env import ThreadedVecEnv

        venv = ThreadedVecEnv(fns, None if cfg.n_threads == "auto" else cfg.n_threads)
    elif cfg.n_envs == 1:
        venv = DummyVecEnv(fns)
    elif cfg.n_workers is not None and cfg.n_workers < cfg.n_envs:
        from sphere_env.training.vec_env import BatchedSubprocVecEnv

        venv = BatchedSubprocVecEnv(fns, cfg.n_workers)
    else:
        venv = SubprocVecEnv(fns)
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
                self._w.writerow(["timesteps", "return", "length", "is_success", "pressure_kpa"])

        def _on_step(self) -> bool:
            for info in self.locals.get("infos", ()):
                ep = info.get("episode")
                if ep is not None:
                    self._w.writerow([self.num_timesteps, f"{ep['r']:.6g}", ep["l"], int(bool(info.get("is_success"))),
                                      f"{info.get('pressure_kpa', float('nan')):.4g}"])
                    self._f.flush()
            return True

        def _on_training_end(self) -> None:
            self._f.close()

    n = cfg.n_envs
    ckpt = CheckpointCallback(save_freq=max(cfg.checkpoint_freq // n, 1), save_path=str(run_dir / "checkpoints"),
                              name_prefix=CHECKPOINT_PREFIX, save_vecnormalize=cfg.normalize is not None,
                              save_replay_buffer=cfg.algo == "sac")
    ev = EvalCallback(eval_env, callback_on_new_best=SaveVecNormalize(), n_eval_episodes=cfg.eval_episodes,
                      eval_freq=max(cfg.eval_freq // n, 1), log_path=str(run_dir / "eval"),
                      best_model_save_path=str(run_dir / "best"), deterministic=True, verbose=0)
    old = run_dir / "eval" / "evaluations.npz"
    if old.exists():  # resume: keep earlier evaluations in the log
        d = np.load(old)
        ev.evaluations_timesteps = list(d["timesteps"])
        ev.evaluations_results = [list(r) for r in d["results"]]
        ev.evaluations_length = [list(r) for r in d["ep_lengths"]]
        if "successes" in d:
            ev.evaluations_successes = [list(r) for r in d["successes"]]
        ev.best_mean_reward = float(np.max(np.mean(d["results"], axis=1))) if len(d["results"]) else -np.inf
    return CallbackList([ckpt, ev, EpisodeLog()])


# ---- checkpoints -----------------------------------------------------------------------------------
def latest_checkpoint(run_dir: Path) -> tuple[int, Path] | None:
    """(steps, path) of the newest ``checkpoints/rl_model_<steps>_steps.zip``."""
    best = None
    for p in (run_dir / "checkpoints").glob(f"{CHECKPOINT_PREFIX}_*_steps.zip"):
        m = re.fullmatch(rf"{CHECKPOINT_PREFIX}_(\d+)_steps\.zip", p.name)
        if m and (best is None or int(m.group(1)) > best[0]):
            best = (int(m.group(1)), p)
    return best


def _ckpt_file(run_dir: Path, kind: str, steps: int) -> Path:
    return run_dir / "checkpoints" / f"{CHECKPOINT_PREFIX}_{kind}_{steps}_steps.pkl"


def save_checkpoint(model, run_dir: Path, cfg: TrainConfig) -> None:
    """Checkpoint at the model's current step count (same names as CheckpointCallback)."""
    n = model.num_timesteps
    (run_dir / "checkpoints").mkdir(parents=True, exist_ok=True)
    model.save(run_dir / "checkpoints" / f"{CHECKPOINT_PREFIX}_{n}_steps.zip")
    vn = model.get_vec_normalize_env()
    if vn is not None:
        vn.save(str(_ckpt_file(run_dir, "vecnormalize", n)))
    if cfg.algo == "sac":
        model.save_replay_buffer(_ckpt_file(run_dir, "replay_buffer", n))


# ---- learning curves -------------------------------------------------------------------------------
def write_learning_curves(run_dir: Path) -> tuple[Path, Path]:
    """learning_curve.csv (kind = train episode / eval mean) and learning_curve.png."""
    rows: list[dict[str, Any]] = []
    train = run_dir / "learning_curve_train.csv"
    if train.exists():
        with open(train) as f:
            for r in csv.DictReader(f):
                rows.append(dict(kind="train", timesteps=int(r["timesteps"]), return_mean=float(r["return"]),
                                 return_std=0.0, length_mean=float(r["length"]), success_rate=float(r["is_success"]),
                                 pressure_kpa=float(r["pressure_kpa"])))
    ev = run_dir / "eval" / "evaluations.npz"
    if ev.exists():
        d = np.load(ev)
        for i, t in enumerate(d["timesteps"]):
            succ = float(np.mean(d["successes"][i])) if "successes" in d and len(d["successes"]) > i else math.nan
            rows.append(dict(kind="eval", timesteps=int(t), return_mean=float(np.mean(d["results"][i])),
                             return_std=float(np.std(d["results"][i])), length_mean=float(np.mean(d["ep_lengths"][i])),
                             success_rate=succ, pressure_kpa=math.nan))
    rows.sort(key=lambda r: (r["timesteps"], r["kind"]))
    csv_path = run_dir / "learning_curve.csv"
    with open(csv_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["kind", "timesteps", "return_mean", "return_std", "length_mean",
                                          "success_rate", "pressure_kpa"])
        w.writeheader()
        w.writerows(rows)

    from sphere_env.plotting import pyplot

    plt = pyplot()

    fig, ax = plt.subplots(figsize=(7, 4))
    tr = [r for r in rows if r["kind"] == "train"]
    if tr:
        t = np.array([r["timesteps"] for r in tr])
        y = np.array([r["return_mean"] for r in tr])
        ax.plot(t, y, ".", ms=2, alpha=0.3, color="C0", label="training episodes")
        k = max(len(y) // 20, 1)
        if len(y) >= k:
            ax.plot(t[k - 1:], np.convolve(y, np.ones(k) / k, mode="valid"), color="C0", label=f"training (mean of {k})")
    evr = [r for r in rows if r["kind"] == "eval"]
    if evr:
        t = np.array([r["timesteps"] for r in evr])
        m = np.array([r["return_mean"] for r in evr])
        s = np.array([r["return_std"] for r in evr])
        ax.errorbar(t, m, yerr=s, color="C3", marker="o", capsize=3, label="evaluation (deterministic)")
    ax.set_xlabel("environment steps")
    ax.set_ylabel("episode return")
    ax.set_title(run_dir.name, fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    png = run_dir / "learning_curve.png"
    fig.savefig(png, dpi=110)
    plt.close(fig)
    return csv_path, png


# ---- training ----------------------------------------------------------------------------------------
def default_run_dir(cfg: TrainConfig, root: Path = RUNS) -> Path:
    stamp = datetime.now(timezone.utc).strftime("%Y%m%d-%H%M%S")
    return root / f"{cfg.algo}_{cfg.env_id.split('/')[-1]}_{stamp}_s{cfg.seed}"


def write_config(cfg: TrainConfig, run_dir: Path, command: Sequence[str] | None = None,
                 extra: Mapping[str, Any] | None = None) -> Path:
    """config.yaml: the resolved config, the resolved randomization, versions, command, seeds."""
    from sphere_env.models.shell import ShellCalibration
    from sphere_env.tasks.randomization import RandomizationSpec

    data = cfg.as_dict()
    cal = ShellCalibration.load(cfg.env_kwargs.get("calibration"))
    ramp = "Ramp" in cfg.env_id
    spec = RandomizationSpec.parse(cfg.randomization, ramp=ramp).resolved(cal.pressure_range_kpa)
    data["randomization_resolved"] = _plain(spec)
    data["seeds"] = {"seed": cfg.seed, "workers": cfg.worker_seeds, "eval": cfg.eval_seed}
    data["monitor_info_keywords"] = list(MONITOR_KEYWORDS)
    data["versions"] = software_versions()
    data["command"] = list(command) if command is not None else []
    data["created_utc"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
    data.update(extra or {})
    return write_text_atomic(run_dir / "config.yaml", yaml.safe_dump(_plain(data), sort_keys=False))


def _plain(x: Any) -> Any:
    """Dataclasses/tuples/numpy to plain YAML-able types."""
    from dataclasses import asdict, is_dataclass

    if is_dataclass(x) and not isinstance(x, type):
        return _plain(asdict(x))
    if isinstance(x, Mapping):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, Path):
        return str(x)
    return x


def load_config(run_dir: str | Path) -> TrainConfig:
    """The TrainConfig stored in ``run_dir/config.yaml``."""
    run_dir = Path(run_dir)
    path = run_dir / "config.yaml"
    if not path.exists():
        raise ValueError(f"run: {str(run_dir)!r} has no config.yaml (not a training run folder)")
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as err:
        raise ValueError(f"run: {str(path)!r} cannot be read: " + " ".join(str(err).split())) from None
    fields = TrainConfig.__dataclass_fields__
    if not isinstance(data, Mapping) or not {"env_id", "algo"} <= set(data):
        raise ValueError(f"run: {str(path)!r} is not a training config (needs env_id and algo)")
    try:
        return TrainConfig(**{k: v for k, v in data.items() if k in fields})
    except TypeError as err:
        raise ValueError(f"run: {str(path)!r} is not a training config: {err}") from None


#: What a run writes into its folder (cleared when an interrupted run is restarted from scratch).
RUN_OUTPUTS = ("checkpoints", "monitor", "eval", "best", "tb", "learning_curve_train.csv", "learning_curve.csv",
               "learning_curve.png", "model.zip", "vecnormalize.pkl", "timing.json")


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


def _is_interrupted_run(run_dir: Path) -> bool:
    """A folder with config.yaml but no model and no checkpoint: a run stopped before its first checkpoint."""
    return ((run_dir / "config.yaml").exists() and not (run_dir / "model.zip").exists()
            and latest_checkpoint(run_dir) is None)


def _clear_outputs(run_dir: Path) -> None:
    import shutil

    for name in RUN_OUTPUTS:
        p = run_dir / name
        if p.is_dir():
            shutil.rmtree(p)
        elif p.exists():
            p.unlink()


def _truncate_history(run_dir: Path, steps: int) -> None:
    """Drop training episodes and evaluations logged after ``steps`` (past the restored checkpoint)."""
    train_csv = run_dir / "learning_curve_train.csv"
    if train_csv.exists():
        with open(train_csv, newline="") as f:
            rows = list(csv.reader(f))
        keep = rows[:1] + [r for r in rows[1:] if r and int(r[0]) <= steps]
        if len(keep) != len(rows):
            tmp = train_csv.with_suffix(".csv.tmp")
            with open(tmp, "w", newline="") as f:
                csv.writer(f).writerows(keep)
            tmp.replace(train_csv)
    ev = run_dir / "eval" / "evaluations.npz"
    if ev.exists():
        d = dict(np.load(ev))
        mask = np.asarray(d["timesteps"]) <= steps
        if not mask.all():
            tmp = ev.with_name("evaluations.tmp.npz")
            np.savez(tmp, **{k: np.asarray(v)[mask] if len(v) == len(mask) else v for k, v in d.items()})
            tmp.replace(ev)


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
    start_steps = 0
    ckpt = None
    previous: dict[str, Any] = {}
    created = False
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
        elif not run_dir.exists():
            created = True
        run_dir.mkdir(parents=True, exist_ok=True)
    extra: dict[str, Any] = {}
    if previous:  # keep the original command; list the resume commands
        extra["command"] = previous.get("command", [])
        extra["created_utc"] = previous.get("created_utc")
        extra["resume_commands"] = [*previous.get("resume_commands", []),
                                    {"command": list(command) if command is not None else [],
                                     "from_steps": start_steps,
                                     "utc": datetime.now(timezone.utc).isoformat(timespec="seconds")}]
        extra["resumed_from_steps"] = start_steps
    try:
        write_config(cfg, run_dir, command, extra=extra or None)
        result = _train_session(cfg, cls, run_dir, ckpt, start_steps, progress_bar, verbose)
    except BaseException:
        if created and latest_checkpoint(run_dir) is None:
            import shutil

            shutil.rmtree(run_dir, ignore_errors=True)
        raise
    write_learning_curves(run_dir)
    return (run_dir, result) if return_model else run_dir


def _train_session(cfg: TrainConfig, cls, run_dir: Path, ckpt: tuple[int, Path] | None, start_steps: int,
                   progress_bar: bool, verbose: int):
    resume = ckpt is not None
    venv = make_vec_env(cfg, run_dir)
    try:
        stats = _ckpt_file(run_dir, "vecnormalize", start_steps) if resume and cfg.normalize is not None else None
        venv = wrap_normalize(cfg, venv, stats=stats)
        eval_env = wrap_normalize(cfg, make_vec_env(cfg, run_dir, evaluation=True), evaluation=True)
        if resume:
            model = cls.load(ckpt[1], env=venv, device=cfg.device, tensorboard_log=str(run_dir / "tb"))
            rb = _ckpt_file(run_dir, "replay_buffer", start_steps)
            if cfg.algo == "sac" and rb.exists():
                model.load_replay_buffer(rb)
            elif cfg.algo == "sac":
                _say(f"resume: {rb.name} is missing; SAC continues with an empty replay buffer")
        else:
            model = cls(cfg.policy, venv, seed=cfg.seed, device=cfg.device, verbose=verbose,
                        tensorboard_log=str(run_dir / "tb"), **cfg.algo_kwargs())
        t0 = time.perf_counter()
        model.learn(total_timesteps=cfg.n_timesteps - start_steps, callback=_callbacks(cfg, run_dir, eval_env),
                    progress_bar=progress_bar, reset_num_timesteps=not resume, tb_log_name=cfg.algo)
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


def _parse_params(items: Sequence[str]) -> dict[str, Any]:
    """rl-zoo3's ``--params key:value`` (value parsed as YAML)."""
    out = {}
    for item in items:
        if ":" not in item:
            raise ValueError(f"params: {item!r} must be key:value")
        key, val = item.split(":", 1)
        out[key.strip()] = yaml.safe_load(val)
    return out


def main(argv: Sequence[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default="sphere_env/RampDescent-v2", help="registered env id")
    parser.add_argument("--algo", default="ppo", help="ppo or sac")
    parser.add_argument("--hyperparams", type=Path, default=None, help="YAML file (default training/hyperparams/<algo>.yml)")
    parser.add_argument("--params", nargs="*", default=[], help="overrides key:value, e.g. n_envs:2 learning_rate:1e-3")
    parser.add_argument("--n-timesteps", type=float, default=None, help="total env steps (overrides the YAML)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--run-dir", type=Path, default=None, help="run folder (default runs/<algo>_<env>_<time>_s<seed>)")
    parser.add_argument("--resume", type=Path, default=None, help="continue this run folder from its last checkpoint")
    parser.add_argument("--eval-freq", type=int, default=None, help="env steps between evaluations")
    parser.add_argument("--eval-episodes", type=int, default=5)
    parser.add_argument("--checkpoint-freq", type=int, default=None, help="env steps between checkpoints")
    parser.add_argument("--torch-threads", type=int, default=1)
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("-v", "--verbose", type=int, default=0)
    args = parser.parse_args(argv)
    command = [sys.executable, "-m", "sphere_env.training.train",
               *(argv if argv is not None else sys.argv[1:])]
    try:
        if args.resume is not None:
            cfg = load_config(args.resume)
            if args.n_timesteps is not None:
                cfg.n_timesteps = _int("n_timesteps", args.n_timesteps)
            cfg = resolve_config(cfg.env_id, cfg.algo, cfg.hyperparams_file or None, overrides=_stored_overrides(cfg),
                                 seed=cfg.seed, eval_freq=cfg.eval_freq, eval_episodes=cfg.eval_episodes,
                                 eval_randomization=cfg.eval_randomization, checkpoint_freq=cfg.checkpoint_freq,
                                 device=cfg.device, torch_threads=cfg.torch_threads)
            run = train(cfg, args.resume, resume=True, progress_bar=not args.no_progress, verbose=args.verbose,
                        command=command)
        else:
            overrides = _parse_params(args.params)
            if args.n_timesteps is not None:
                overrides["n_timesteps"] = args.n_timesteps
            cfg = resolve_config(args.env, args.algo, args.hyperparams, overrides, seed=args.seed,
                                 eval_freq=args.eval_freq, eval_episodes=args.eval_episodes,
                                 checkpoint_freq=args.checkpoint_freq, torch_threads=args.torch_threads)
            run = train(cfg, args.run_dir, progress_bar=not args.no_progress, verbose=args.verbose, command=command)
    except ValueError as err:
        parser.exit(2, f"training.train: error: {err}\n")
    print(f"run folder: {run.resolve()}")
    return run


def _stored_overrides(cfg: TrainConfig) -> dict[str, Any]:
    """A stored config as YAML-section overrides (so a resume re-validates exactly what ran)."""
    return {"n_envs": cfg.n_envs, "n_workers": cfg.n_workers, "n_threads": cfg.n_threads, "n_timesteps": cfg.n_timesteps, "policy": cfg.policy,
            "normalize": cfg.normalize if cfg.normalize is not None else False,
            "env_kwargs": cfg.env_kwargs, "randomization": cfg.randomization, **cfg.hyperparams}


if __name__ == "__main__":
    # Run the package copy (sphere_env.training.train), also under `python -m training.train`, so
    # that worker processes unpickle this module's functions by a name they can import.
    from sphere_env.training.train import main as _main

    _main()
