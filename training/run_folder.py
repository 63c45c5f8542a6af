"""A training run's folder: its name, lock, config, checkpoints, logs and learning curves.

    <run>/config.yaml                 the resolved configuration, the command, resumes
    <run>/.lock                       held by the one process writing the folder
    <run>/checkpoints/                rl_model_<steps>_steps.zip (+ VecNormalize, SAC replay buffer,
                                      the run's random state: rl_model_training_state_<steps>_steps.json)
    <run>/monitor/                    SB3 Monitor CSVs, one per training env
    <run>/learning_curve_train.csv    every training episode at its exact global step
    <run>/learning_curve.csv, .png    training and evaluation curves

:func:`sphere_env.training.trainer.train` writes it; a resume restores the newest usable checkpoint
(:func:`usable_checkpoint`) and drops the history logged after it (:func:`_truncate_history`), so
every episode is listed once.
"""

from __future__ import annotations

import contextlib
import csv
import math
import re
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import yaml

from sphere_env import safe_yaml
from sphere_env.files import folder_lock, write_text_atomic
from sphere_env.provenance import software_versions
from sphere_env.schemas import shown, validate
from sphere_env.training import training_state
from sphere_env.training.config import MONITOR_KEYWORDS, TrainConfig, plain_data
from sphere_env.training.run_options import RunConfigFile
from sphere_env.training.saved import load_model, read_stats, stats_path

RUNS = Path("runs")
CHECKPOINT_PREFIX = "rl_model"


def latest_checkpoint(run_dir: Path) -> tuple[int, Path] | None:
    """(steps, path) of the newest ``checkpoints/rl_model_<steps>_steps.zip``."""
    best = None
    for p in (run_dir / "checkpoints").glob(f"{CHECKPOINT_PREFIX}_*_steps.zip"):
        m = re.fullmatch(rf"{CHECKPOINT_PREFIX}_(\d+)_steps\.zip", p.name)
        if m and (best is None or int(m.group(1)) > best[0]):
            best = (int(m.group(1)), p)
    return best


def _checkpoint_problem(cls, cfg: TrainConfig, run_dir: Path, steps: int, path: Path) -> str | None:
    """Why the checkpoint at ``steps`` cannot be resumed from (None: it can)."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as z:
            bad = z.testzip()
        if bad is not None:
            return f"{path.name} is corrupt ({bad})"
        load_model(cls, path, cfg.algo_kwargs(), device="cpu")
    except Exception as err:  # noqa: BLE001 - any failure to read means "not usable"
        return f"{path.name} cannot be read ({type(err).__name__}: {err})"
    if cfg.normalize is not None:
        vn = stats_path(_ckpt_file(run_dir, "vecnormalize", steps, ""))
        if not vn.exists():
            return f"{vn.name} (its VecNormalize statistics) is missing"
        try:
            read_stats(vn)
        except ValueError as err:
            return f"{vn.name} cannot be read ({err})"
    state = training_state.state_path(run_dir, steps)
    if state.exists():  # absent in folders written before it was saved: the streams then restart
        try:
            training_state.read(state)
        except ValueError as err:
            return str(err)
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


def _ckpt_file(run_dir: Path, kind: str, steps: int, suffix: str = ".pkl") -> Path:
    return run_dir / "checkpoints" / f"{CHECKPOINT_PREFIX}_{kind}_{steps}_steps{suffix}"


LEARNING_CURVE_COLUMNS = [
    "kind",
    "timesteps",
    "return_mean",
    "return_std",
    "length_mean",
    "success_rate",
    "pressure_kpa",
]


def write_learning_curves(run_dir: Path) -> tuple[Path, Path]:
    """learning_curve.csv (kind = train episode / eval mean) and learning_curve.png."""
    rows = _train_rows(run_dir / "learning_curve_train.csv") + _eval_rows(run_dir / "eval" / "evaluations.npz")
    rows.sort(key=lambda r: (r["timesteps"], r["kind"]))
    csv_path = run_dir / "learning_curve.csv"
    with open(csv_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=LEARNING_CURVE_COLUMNS)
        w.writeheader()
        w.writerows(rows)
    png = run_dir / "learning_curve.png"
    _plot_learning_curve(rows, png, run_dir.name)
    return csv_path, png


def _train_rows(path: Path) -> list[dict[str, Any]]:
    """One learning-curve row per finished training episode of learning_curve_train.csv (none
    without the file)."""
    if not path.exists():
        return []
    with open(path) as f:
        return [
            dict(
                kind="train",
                timesteps=int(r["timesteps"]),
                return_mean=float(r["return"]),
                return_std=0.0,
                length_mean=float(r["length"]),
                success_rate=float(r["is_success"]),
                pressure_kpa=float(r["pressure_kpa"]),
            )
            for r in csv.DictReader(f)
        ]


def _eval_rows(path: Path) -> list[dict[str, Any]]:
    """One learning-curve row per evaluation of evaluations.npz (mean and std over its episodes;
    none without the file)."""
    if not path.exists():
        return []
    d = np.load(path)
    rows = []
    for i, t in enumerate(d["timesteps"]):
        succ = float(np.mean(d["successes"][i])) if "successes" in d and len(d["successes"]) > i else math.nan
        rows.append(
            dict(
                kind="eval",
                timesteps=int(t),
                return_mean=float(np.mean(d["results"][i])),
                return_std=float(np.std(d["results"][i])),
                length_mean=float(np.mean(d["ep_lengths"][i])),
                success_rate=succ,
                pressure_kpa=math.nan,
            )
        )
    return rows


def _plot_learning_curve(rows: Sequence[Mapping[str, Any]], png: Path, title: str) -> None:
    """Training episodes' returns (dots and a running mean of a twentieth of them) and the
    evaluations' mean ± std against environment steps."""
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
            ax.plot(
                t[k - 1 :], np.convolve(y, np.ones(k) / k, mode="valid"), color="C0", label=f"training (mean of {k})"
            )
    evr = [r for r in rows if r["kind"] == "eval"]
    if evr:
        t = np.array([r["timesteps"] for r in evr])
        m = np.array([r["return_mean"] for r in evr])
        s = np.array([r["return_std"] for r in evr])
        ax.errorbar(t, m, yerr=s, color="C3", marker="o", capsize=3, label="evaluation (deterministic)")
    ax.set_xlabel("environment steps")
    ax.set_ylabel("episode return")
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:  # a tiny run may have neither a finished episode nor an evaluation
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


# ---- training ----------------------------------------------------------------------------------------
def default_run_dir(cfg: TrainConfig, root: Path = RUNS) -> Path:
    """``<root>/<algo>_<env>_<UTC time>_s<seed>_<6 random hex digits>``: two runs started in the same
    second get different folders (and :func:`train` creates a new folder exclusively)."""
    import secrets

    stamp = datetime.now(UTC).strftime("%Y%m%d-%H%M%S")
    return root / f"{cfg.algo}_{cfg.env_id.split('/')[-1]}_{stamp}_s{cfg.seed}_{secrets.token_hex(3)}"


@contextlib.contextmanager
def run_lock(run_dir: Path):
    """Hold an exclusive lock on a run folder for the whole training (``<run>/.lock``,
    :func:`sphere_env.files.folder_lock`: released by the system when the process ends, however it
    ends). A second writer on the same folder is refused with a ValueError naming the folder and the
    holder's pid, before it reads or changes anything there."""
    with folder_lock(run_dir, "run_dir", "wait for it to end or use another folder"):
        yield


def write_config(
    cfg: TrainConfig, run_dir: Path, command: Sequence[str] | None = None, extra: Mapping[str, Any] | None = None
) -> Path:
    """config.yaml: the resolved config, the resolved randomization, versions, command, seeds."""
    from sphere_env.models.shell import ShellCalibration
    from sphere_env.tasks.randomization import RandomizationSpec

    data = cfg.as_dict()
    cal = ShellCalibration.load(cfg.env_kwargs.get("calibration"))
    ramp = "Ramp" in cfg.env_id
    spec = RandomizationSpec.parse(cfg.randomization, ramp=ramp).resolved(cal.parameter_space())
    data["randomization_resolved"] = spec.as_data()  # the mapping form: it parses back to the spec
    data["seeds"] = {"seed": cfg.seed, "workers": cfg.worker_seeds, "eval": cfg.eval_seed}
    data["monitor_info_keywords"] = list(MONITOR_KEYWORDS)
    data["versions"] = software_versions()
    data["command"] = list(command) if command is not None else []
    data["created_utc"] = datetime.now(UTC).isoformat(timespec="seconds")
    data.update(extra or {})
    return write_text_atomic(run_dir / "config.yaml", yaml.safe_dump(plain_data(data), sort_keys=False))


#: The keys of a run's ``config.yaml`` besides a ``TrainConfig``'s fields: what :func:`write_config`
#: and a resume record (``randomization``: folders written before it moved into ``env_kwargs``).
RUN_RECORD_KEYS = (
    "randomization_resolved",
    "seeds",
    "monitor_info_keywords",
    "versions",
    "command",
    "created_utc",
    "resume_commands",
    "resumed_from_steps",
    "randomization",
)


def load_config(run_dir: str | Path) -> TrainConfig:
    """The TrainConfig stored in ``run_dir/config.yaml``; a top-level key that is neither a
    configuration field nor one of :data:`RUN_RECORD_KEYS` is refused by name."""
    run_dir = Path(run_dir)
    path = run_dir / "config.yaml"
    if not path.exists():
        raise ValueError(f"run: {str(run_dir)!r} has no config.yaml (not a training run folder)")
    try:
        data = safe_yaml.load_file(path)
    except (OSError, yaml.YAMLError) as err:
        raise ValueError(f"run: {str(path)!r} cannot be read: " + " ".join(str(err).split())) from None
    validate(RunConfigFile, data, f"run: {str(path)!r}")  # a mapping holding env_id and algo
    fields = TrainConfig.__dataclass_fields__
    unknown = sorted(str(k) for k in data if k not in fields and k not in RUN_RECORD_KEYS)
    if unknown:
        raise ValueError(
            f"run: {str(path)!r}: unknown top-level key {shown(unknown[0])}; allowed: the fields of a training "
            f"configuration and the records the trainer writes ({', '.join(RUN_RECORD_KEYS[:-1])})"
        )
    data = dict(data)
    if "randomization" in data and "randomization" not in (data.get("env_kwargs") or {}):
        # run folders written before randomization moved into env_kwargs
        data["env_kwargs"] = {**(data.get("env_kwargs") or {}), "randomization": data["randomization"]}
    return TrainConfig(**{k: v for k, v in data.items() if k in fields})


#: What a run writes into its folder (cleared when an interrupted run is restarted from scratch).
RUN_OUTPUTS = (
    "checkpoints",
    "monitor",
    "eval",
    "best",
    "tb",
    "learning_curve_train.csv",
    "learning_curve.csv",
    "learning_curve.png",
    "model.zip",
    "vecnormalize.json",
    "vecnormalize.pkl",
    "timing.json",
)


def _truncate_monitor(path: Path, episodes: int) -> None:
    """Keep a Monitor CSV's header lines and its first ``episodes`` episodes (atomic replace)."""
    lines = path.read_text().splitlines(keepends=True)
    head = 2 if len(lines) > 1 and lines[0].startswith("#") else 1  # SB3's JSON comment, then the columns
    if len(lines) - head > episodes:
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_text("".join(lines[: head + episodes]))
        tmp.replace(path)


def _is_interrupted_run(run_dir: Path) -> bool:
    """A folder with config.yaml but no model and no checkpoint: a run stopped before its first checkpoint."""
    return (
        (run_dir / "config.yaml").exists()
        and not (run_dir / "model.zip").exists()
        and latest_checkpoint(run_dir) is None
    )


def _clear_outputs(run_dir: Path) -> None:
    import shutil

    for name in RUN_OUTPUTS:
        p = run_dir / name
        if p.is_dir():
            shutil.rmtree(p)
        elif p.exists():
            p.unlink()


def _truncate_history(run_dir: Path, steps: int) -> None:
    """Drop training episodes and evaluations logged after ``steps`` (past the restored checkpoint):
    from ``learning_curve_train.csv``, the evaluations, and each training env's Monitor CSV (it keeps
    as many episodes as ``learning_curve_train.csv`` has of that env up to ``steps``), so a resumed
    run lists every episode once."""
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
        if rows and "env" in rows[0]:
            col = rows[0].index("env")
            per_env: dict[str, int] = {}
            for r in keep[1:]:
                per_env[r[col]] = per_env.get(r[col], 0) + 1
            for mon in (run_dir / "monitor").glob("train_*.monitor.csv"):
                _truncate_monitor(mon, per_env.get(mon.name.split(".")[0].removeprefix("train_"), 0))
    ev = run_dir / "eval" / "evaluations.npz"
    if ev.exists():
        d = dict(np.load(ev))
        mask = np.asarray(d["timesteps"]) <= steps
        if not mask.all():
            tmp = ev.with_name("evaluations.tmp.npz")
            np.savez(tmp, **{k: np.asarray(v)[mask] if len(v) == len(mask) else v for k, v in d.items()})
            tmp.replace(ev)
