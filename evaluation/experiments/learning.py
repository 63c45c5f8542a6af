"""Learning study: training recipes over seeds, each checkpoint evaluated on the demo's grid.

A *recipe* is a named set of overrides of a hyperparameter file (``recipes.yml`` beside this file).
One job = one recipe × one training seed: it trains into ``<runs>/<recipe>/seed<k>/`` with a
checkpoint every ``eval_every`` env steps, then evaluates every checkpoint with deterministic actions
on the demo's grid (3 shell models × 3, 8.5, 14 kPa × evaluation seeds 0, 1, 2: 27 episodes,
randomization off) and writes ``<results>/runs/<recipe>/seed<k>.json`` atomically. A job whose result
file exists is skipped, so an interrupted study continues where it stopped (``--jobs`` runs that
many jobs at once, each training on one core).

    python -m evaluation.experiments.learning run --recipe asym_mix --seeds 0 1 2 3 4 [--jobs 2]
    python -m evaluation.experiments.learning pd            # the PD and zero-torque baselines on the grid
    python -m evaluation.experiments.learning summary       # summary.json, tables and plots
    python -m evaluation.experiments.learning ship --recipe shipped --seed 2   # -> assets/policies/

The result of a run holds its learning curve (grid success, per shell and tracking RMSE at every
checkpoint), the final checkpoint's figures, the env steps and training wall-clock at which the grid
success first reached the PD's minus 3 points, and the recipe as resolved.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import yaml

from sphere_env.files import write_text_atomic

ENV_ID = "sphere_env/RampDescent-v3"
HERE = Path(__file__).resolve().parent
RECIPES = HERE / "recipes.yml"
RESULTS = HERE.parent / "results" / "learning"
RUNS = Path("runs") / "learning"
SHELLS = ("point", "injected", "hydroelastic")
PRESSURES_KPA = (3.0, 8.5, 14.0)
EVAL_SEEDS = (0, 1, 2)
PD_MARGIN = 0.03  # "PD level": grid success ≥ the PD's − 3 points


def load_recipes(path: Path = RECIPES) -> dict[str, dict[str, Any]]:
    with open(path) as f:
        return yaml.safe_load(f)["recipes"]


def grid_jobs(controller: str, spec: str, env_kwargs: Mapping[str, Any], env_id: str = ENV_ID) -> list[dict[str, Any]]:
    """The demo grid's episodes as :func:`sphere_env.evaluation.evaluate.rollout` jobs."""
    return [dict(controller=controller, spec=spec, env_id=env_id, shell_model=m, friction="majd",
                 pressure_kpa=p, seed=s, env_kwargs=dict(env_kwargs))
            for m in SHELLS for p in PRESSURES_KPA for s in EVAL_SEEDS]


def grid_figures(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Success rate, tracking RMSE (mean over episodes with judged samples) and per-shell success."""
    succ = [bool(r["is_success"]) for r in rows]
    rmse = [r["tracking_rmse_rad_s"] for r in rows if np.isfinite(r["tracking_rmse_rad_s"])]
    per_shell = {m: float(np.mean([bool(r["is_success"]) for r in rows if r["shell_model"] == m])) for m in SHELLS}
    return {"success_rate": float(np.mean(succ)), "tracking_rmse_rad_s": float(np.mean(rmse)) if rmse else math.nan,
            "per_shell": per_shell, "episodes": len(rows)}


class _Checkpoint:
    """A checkpoint's policy and VecNormalize statistics as a deterministic controller."""

    def __init__(self, zip_path: Path, vecnormalize_path: Path | None, algo: str):
        import pickle

        from sphere_env.training.config import algo_class

        self.model = algo_class(algo).load(zip_path, device="cpu")
        self.vn = None
        if vecnormalize_path is not None and vecnormalize_path.exists():
            with open(vecnormalize_path, "rb") as f:
                self.vn = pickle.load(f)
            self.vn.training = False

    def reset(self) -> None:
        pass

    def __call__(self, obs, info=None):
        o = np.asarray(obs, dtype=np.float32)
        if self.vn is not None:
            o = self.vn.normalize_obs(o)
        return self.model.predict(o, deterministic=True)[0]


def evaluate_checkpoint(zip_path: Path, vn_path: Path | None, algo: str, env_kwargs: Mapping[str, Any],
                        env_id: str = ENV_ID) -> dict:
    from sphere_env.evaluation.evaluate import rollout

    ctrl = _Checkpoint(zip_path, vn_path, algo)
    rows = [rollout(job, controller=ctrl)[0] for job in grid_jobs("policy", "policy", env_kwargs, env_id)]
    return {**grid_figures(rows), "episodes_detail": [
        {k: r[k] for k in ("shell_model", "pressure_kpa", "seed", "is_success", "tracking_rmse_rad_s",
                           "reached_runout")} for r in rows]}


def eval_env_kwargs(cfg) -> dict[str, Any]:
    kw = dict(cfg.env_kwargs)
    for k in ("shell_model", "friction_model", "randomization", "render_mode", "record_replay", "meshcat"):
        kw.pop(k, None)
    return kw


def pd_level() -> float:
    base = json.loads((RESULTS / "baselines.json").read_text())
    return base["pd"]["success_rate"] - PD_MARGIN


def run_job(recipe_name: str, seed: int, runs_root: Path = RUNS, results: Path = RESULTS) -> Path:
    """Train one recipe × seed and evaluate its checkpoints; returns the result file."""
    import torch

    from sphere_env.resources import hyperparams_path
    from sphere_env.training.config import resolve_config
    from sphere_env.training.train import CHECKPOINT_PREFIX, train

    torch.set_num_threads(1)
    out = results / "runs" / recipe_name / f"seed{seed}.json"
    if out.exists():
        return out
    recipe = load_recipes()[recipe_name]
    steps = int(float(recipe["n_timesteps"]))
    every = int(float(recipe.get("eval_every", 100_000)))
    overrides = {"n_timesteps": steps, "n_workers": 1, **(recipe.get("hyperparams") or {})}
    env_id = recipe.get("env", ENV_ID)
    cfg = resolve_config(env_id, recipe.get("algo", "ppo"), hyperparams_path(recipe.get("conf", "ppo")),
                         overrides=overrides, env_kwargs=recipe.get("env_kwargs") or {}, seed=seed,
                         eval_freq=0, checkpoint_freq=every)
    run_dir = runs_root / recipe_name / f"seed{seed}"
    resume = (run_dir / "config.yaml").exists()
    t0 = time.perf_counter()
    train(cfg, run_dir, resume=resume, progress_bar=False, command=["evaluation.experiments.learning", recipe_name])
    timing = json.loads((run_dir / "timing.json").read_text())
    wall_per_step = timing["wall_s"] / max(timing["steps_this_session"], 1)
    kw = eval_env_kwargs(cfg)
    curve = []
    ckpts = sorted((int(p.stem.split("_")[-2]), p) for p in (run_dir / "checkpoints").glob(f"{CHECKPOINT_PREFIX}_*_steps.zip"))
    cache = run_dir / "grid_eval"  # one file per evaluated checkpoint: a longer budget re-uses them
    cache.mkdir(exist_ok=True)
    for n, zp in ckpts:
        done = cache / f"{n}.json"
        if done.exists():
            fig = json.loads(done.read_text())
        else:
            vn = run_dir / "checkpoints" / f"{CHECKPOINT_PREFIX}_vecnormalize_{n}_steps.pkl"
            fig = evaluate_checkpoint(zp, vn, cfg.algo, kw, env_id)
            fig.pop("episodes_detail")
            write_text_atomic(done, json.dumps(fig) + "\n")
        curve.append({"env_steps": n, "wall_clock_s": n * wall_per_step, **fig})
    final = evaluate_checkpoint(run_dir / "model.zip", run_dir / "vecnormalize.pkl", cfg.algo, kw, env_id)
    level = pd_level()
    reached = next((c for c in curve if c["success_rate"] >= level - 1e-9), None)
    result = {
        "method": recipe_name, "condition": recipe.get("condition", "pressure"), "from_scratch": True,
        "seed": seed, "algo": cfg.algo, "env_id": env_id, "recipe": recipe, "success_rate": final["success_rate"],
        "tracking_rmse_rad_s": final["tracking_rmse_rad_s"], "per_shell": final["per_shell"],
        "episodes": final["episodes_detail"], "curve": curve, "pd_level": level,
        "env_steps_to_pd_level": reached["env_steps"] if reached else None,
        "wall_clock_to_pd_level_s": reached["wall_clock_s"] if reached else None,
        "wall_clock_s": timing["wall_s"], "env_steps": timing["num_timesteps"],
        "steps_per_s": timing["steps_per_s"], "job_wall_s": time.perf_counter() - t0,
        "commit": _commit(), "cores": os.cpu_count(),
    }
    out.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out, json.dumps(result, indent=1) + "\n")
    return out


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              cwd=HERE, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _job(args: tuple[str, int]) -> str:
    name, seed = args
    try:
        return str(run_job(name, seed))
    except Exception as err:  # noqa: BLE001 - one failed job is reported, the others go on
        return f"FAILED {name} seed {seed}: {type(err).__name__}: {err}"


def baselines(results: Path = RESULTS) -> Path:
    """The PD and zero-torque controllers on the grid: ``baselines.json``."""
    from sphere_env.evaluation.evaluate import rollout

    out = {}
    for name in ("pd", "zero"):
        rows = [rollout(job)[0] for job in grid_jobs(name, name, {})]
        out[name] = grid_figures(rows)
    out.update(grid={"shells": list(SHELLS), "pressures_kpa": list(PRESSURES_KPA), "seeds": list(EVAL_SEEDS),
                     "episodes": len(SHELLS) * len(PRESSURES_KPA) * len(EVAL_SEEDS)}, commit=_commit())
    path = results / "baselines.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, json.dumps(out, indent=1) + "\n")
    return path


SHIP_FILES = ("config.yaml", "model.zip", "vecnormalize.pkl")


def ship(recipe_name: str, seed: int, runs_root: Path = RUNS, results: Path = RESULTS) -> Path:
    """Copy a finished run of the study into the package as the ``pretrained`` policy
    (``assets/policies/<folder>/``: the run's config, final model and VecNormalize statistics, and
    ``card.json`` with its recipe, seed and grid figures), through a staging folder moved into place."""
    import shutil
    import tempfile

    from sphere_env.resources import ASSETS_PACKAGE, SHIPPED_POLICIES

    result_file = results / "runs" / recipe_name / f"seed{seed}.json"
    if not result_file.exists():
        raise ValueError(f"seed: no finished result {result_file} (run the study first)")
    run_dir = runs_root / recipe_name / f"seed{seed}"
    missing = [f for f in SHIP_FILES if not (run_dir / f).is_file()]
    if missing:
        raise ValueError(f"seed: run folder {run_dir} lacks {missing}")
    res = json.loads(result_file.read_text())
    import importlib.resources

    target = Path(str(importlib.resources.files(ASSETS_PACKAGE))) / "policies" / SHIPPED_POLICIES["pretrained"]
    target.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".ship-", dir=target.parent))
    for f in SHIP_FILES:
        shutil.copy2(run_dir / f, stage / f)
    card = {k: res[k] for k in ("method", "seed", "env_id", "algo", "env_steps", "success_rate", "tracking_rmse_rad_s",
                                "per_shell", "env_steps_to_pd_level", "wall_clock_s", "commit")}
    card["grid"] = {"shells": list(SHELLS), "pressures_kpa": list(PRESSURES_KPA), "seeds": list(EVAL_SEEDS)}
    card["trained_by"] = ("python -m training.train --env sphere_env/RampDescent-v3 --algo ppo "
                          f"--seed {seed}  (training/hyperparams/ppo.yml, RampDescent-v3 section)")
    (stage / "card.json").write_text(json.dumps(card, indent=1) + "\n")
    old = None
    if target.exists():
        old = target.with_name(f".{target.name}.old")
        shutil.rmtree(old, ignore_errors=True)
        target.rename(old)
    stage.rename(target)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
    return target


def main(argv: Sequence[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="python -m evaluation.experiments.learning", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="train and evaluate recipe x seeds (skips finished jobs)")
    r.add_argument("--recipe", nargs="+", required=True)
    r.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    r.add_argument("--jobs", type=int, default=2, help="jobs at once, one core each")
    sub.add_parser("pd", help="evaluate the PD and zero torque on the grid")
    sub.add_parser("summary", help="write summary.json, the tables and the plots")
    sp = sub.add_parser("ship", help="copy a finished run into the package as the pretrained policy")
    sp.add_argument("--recipe", default="shipped")
    sp.add_argument("--seed", type=int, required=True)
    args = p.parse_args(argv)
    if args.cmd == "ship":
        try:
            print(ship(args.recipe, args.seed))
        except ValueError as err:
            p.exit(2, f"{p.prog}: error: {err}\n")
        return
    if args.cmd == "pd":
        print(baselines())
        return
    if args.cmd == "summary":
        from sphere_env.evaluation.experiments.learning_summary import write_summary

        print(write_summary(RESULTS))
        return
    known = load_recipes()
    bad = [n for n in args.recipe if n not in known]
    if bad:
        p.error(f"--recipe: unknown {bad}; allowed: {sorted(known)}")
    todo = [(n, s) for n in args.recipe for s in args.seeds]
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        for msg in pool.map(_job, todo):
            print(msg, flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
