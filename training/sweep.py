"""Many trainings at once: seeds × configurations, one run folder per trial, locally or on Ray,
and a learning curve aggregated over the seeds with bootstrap confidence intervals.

    python -m training.train --seeds 0 1 2 --ray-address auto              # on a Ray cluster
    python -m training.train --seeds 0 1 2 --trial "learning_rate:1e-3" --trial "learning_rate:3e-4"

A sweep folder holds::

    sweep.yaml                        the trials: folder, configuration index, seed, overrides
    config<c>_seed<s>/                one ordinary run folder per trial (see training.train)
    learning_curve_aggregate.csv/.png mean evaluation return per configuration against env steps,
                                      with a 95% bootstrap interval over the seeds

Every trial is an ordinary :func:`sphere_env.training.trainer.train` call in its own folder with its
own seed, so a trial's result does not depend on where it ran: on Ray each trial is one task
(``num_cpus=1``), locally the trials run one after the other in this process. The aggregate is
computed from the run folders afterwards, the same way in both cases.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import yaml
from pydantic import Field

from sphere_env import safe_yaml
from sphere_env.files import write_text_atomic
from sphere_env.schemas import allowed, checker
from sphere_env.training.config import TrainConfig

#: Bootstrap of the across-seed mean: confidence level, resamples, fixed generator seed.
CI_LEVEL = 0.95
CI_RESAMPLES = 2000
CI_SEED = 0


def _config_key(cfg: TrainConfig) -> str:
    d = cfg.as_dict()
    d.pop("seed")
    return json.dumps(d, sort_keys=True, default=str)


#: A sweep's configurations: at least one (each seed × ``--trial``).
_TRIALS = checker(
    Annotated[
        list[Any], Field(min_length=1, json_schema_extra=allowed("at least one configuration (a seed × a --trial)"))
    ]
)


def trial_folders(cfgs: Sequence[TrainConfig]) -> list[tuple[int, str]]:
    """(configuration index, folder name) per trial; trials differing only in seed share an index."""
    keys: dict[str, int] = {}
    out = []
    for cfg in cfgs:
        c = keys.setdefault(_config_key(cfg), len(keys))
        out.append((c, f"config{c}_seed{cfg.seed}"))
    if len({name for _, name in out}) != len(out):
        raise ValueError("seeds: two trials have the same configuration and seed")
    return out


def _run_trial(job: Mapping[str, Any]) -> str:
    """One trial (module level: Ray and process pools pickle it by reference)."""
    from sphere_env.training.trainer import train

    cfg = TrainConfig(**job["cfg"])
    return str(train(cfg, job["run_dir"], progress_bar=False, command=job["command"]))


def run_sweep(
    cfgs: Sequence[TrainConfig],
    sweep_dir: str | Path,
    ray_address: str | None = None,
    command: Sequence[str] | None = None,
    ray_cpus: int | None = None,
) -> Path:
    """Train every (validated) config in ``cfgs`` into ``sweep_dir/config<c>_seed<s>``: as Ray tasks
    with ``ray_address`` (``local`` starts one with ``ray_cpus`` CPUs, default all), else one after
    the other here. Then write the aggregate learning curve. Returns ``sweep_dir``."""
    from sphere_env.parallel import run_parallel

    sweep_dir = Path(sweep_dir)
    taken = ValueError(f"run_dir: {str(sweep_dir)!r} already holds a sweep; use another folder")
    if (sweep_dir / "sweep.yaml").exists():
        raise taken
    cfgs = _TRIALS(list(cfgs), "trials")
    if ray_address is not None:
        try:
            import ray  # noqa: F401
        except ImportError:
            raise ValueError("ray_address: Ray is not installed; pip install 'sphere_env[ray]'") from None
    names = trial_folders(cfgs)
    trials = [
        {
            "folder": name,
            "config": c,
            "seed": cfg.seed,
            "hyperparams": cfg.hyperparams,
            "env_kwargs": cfg.env_kwargs,
            "n_timesteps": cfg.n_timesteps,
        }
        for (c, name), cfg in zip(names, cfgs)
    ]
    try:  # created exclusively: of two sweeps started into one folder, the second is refused
        write_text_atomic(
            sweep_dir / "sweep.yaml",
            yaml.safe_dump(
                {
                    "env_id": cfgs[0].env_id,
                    "algo": cfgs[0].algo,
                    "executor": f"ray at {ray_address}" if ray_address else "local",
                    "command": list(command or []),
                    "trials": trials,
                },
                sort_keys=False,
            ),
            exclusive=True,
        )
    except FileExistsError:
        raise taken from None
    jobs = [
        {"cfg": cfg.as_dict(), "run_dir": str(sweep_dir / name), "command": list(command or [])}
        for (_, name), cfg in zip(names, cfgs)
    ]
    run_parallel(_run_trial, jobs, workers=1 if ray_address is None else ray_cpus, ray_address=ray_address)
    aggregate_learning_curves(sweep_dir)
    return sweep_dir


def _eval_curve(run_dir: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(timesteps, mean return, success rate) of each evaluation of one run, or None."""
    path = run_dir / "eval" / "evaluations.npz"
    if not path.exists():
        return None
    d = np.load(path)
    ret = np.mean(d["results"], axis=1)
    succ = (
        np.mean(d["successes"], axis=1)
        if "successes" in d and len(d["successes"]) == len(ret)
        else np.full(len(ret), np.nan)
    )
    return np.asarray(d["timesteps"]), ret, succ


def bootstrap_ci(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """95% percentile-bootstrap interval of the mean over axis 0 (trials), per column; NaN with
    fewer than two trials."""
    from scipy.stats import bootstrap

    values = np.asarray(values, dtype=float)
    if values.shape[0] < 2:
        nan = np.full(values.shape[1:], np.nan)
        return nan, nan
    res = bootstrap(
        (values,),
        np.mean,
        axis=0,
        confidence_level=CI_LEVEL,
        n_resamples=CI_RESAMPLES,
        method="percentile",
        rng=np.random.default_rng(CI_SEED),
    )
    return np.asarray(res.confidence_interval.low), np.asarray(res.confidence_interval.high)


def aggregate_learning_curves(sweep_dir: str | Path) -> tuple[Path, Path] | None:
    """``learning_curve_aggregate.csv`` and ``.png`` from the trials listed in ``sweep.yaml``:
    per configuration and evaluation step, the mean over seeds of the evaluation return, its
    bootstrap interval and the mean success rate. None when no trial evaluated."""
    sweep_dir = Path(sweep_dir)
    trials = safe_yaml.load_file((sweep_dir / "sweep.yaml"))["trials"]
    by_config: dict[int, list[tuple]] = {}
    for t in trials:
        curve = _eval_curve(sweep_dir / t["folder"])
        if curve is not None:
            by_config.setdefault(int(t["config"]), []).append(curve)
    if not by_config:
        return None
    rows = []
    for c, curves in sorted(by_config.items()):
        steps = curves[0][0]
        for other in curves[1:]:  # evaluations every trial made (the same steps for equal budgets)
            steps = np.intersect1d(steps, other[0])
        ret = np.array([cv[1][np.isin(cv[0], steps)] for cv in curves])
        succ = np.array([cv[2][np.isin(cv[0], steps)] for cv in curves])
        low, high = bootstrap_ci(ret)
        for j, t in enumerate(steps):
            rows.append(
                {
                    "config": c,
                    "timesteps": int(t),
                    "n_trials": len(curves),
                    "return_mean": float(np.mean(ret[:, j])),
                    "return_ci_low": float(low[j]),
                    "return_ci_high": float(high[j]),
                    "success_rate_mean": float(np.mean(succ[:, j])),
                }
            )
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    csv_path = write_text_atomic(sweep_dir / "learning_curve_aggregate.csv", buf.getvalue())

    from sphere_env.plotting import pyplot, save_figure

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    for c in sorted(by_config):
        r = [x for x in rows if x["config"] == c]
        t = np.array([x["timesteps"] for x in r])
        ax.plot(
            t, [x["return_mean"] for x in r], marker="o", color=f"C{c}", label=f"config {c} ({r[0]['n_trials']} seeds)"
        )
        ax.fill_between(t, [x["return_ci_low"] for x in r], [x["return_ci_high"] for x in r], color=f"C{c}", alpha=0.2)
    ax.set_xlabel("environment steps")
    ax.set_ylabel("evaluation return (mean over seeds)")
    ax.set_title(f"{sweep_dir.name}: mean and {CI_LEVEL:.0%} bootstrap interval over seeds", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    tmp = sweep_dir / "learning_curve_aggregate.tmp.png"
    save_figure(fig, tmp)
    png = sweep_dir / "learning_curve_aggregate.png"
    tmp.replace(png)
    return csv_path, png
