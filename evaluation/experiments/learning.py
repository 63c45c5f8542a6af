"""Learning study: training recipes over seeds, each checkpoint evaluated on the demo's grid.

A *recipe* is a named set of overrides of a hyperparameter file (``recipes.yml`` beside this file).
One job = one recipe × one training seed: it trains into ``<runs>/<recipe>/seed<k>/`` with a
checkpoint every ``eval_every`` env steps, then evaluates every checkpoint with deterministic actions
on the demo's grid (3 shell models × 3, 8.5, 14 kPa × evaluation seeds 0, 1, 2: 27 episodes,
randomization off) and writes ``<results>/runs/<recipe>/seed<k>.json`` atomically. A job whose result
file exists is skipped, so an interrupted study continues where it stopped (``--jobs`` runs that
many jobs at once through :func:`sphere_env.parallel.run_parallel`, each training on one core;
``--ray-address`` runs them on a Ray cluster; ``--complete`` writes each result with its
validation-chosen checkpoint, fault grid and other calibrations, which ``select``, ``faults`` and
``calibrations`` otherwise add later from the run folders).

    python -m evaluation.experiments.learning run --recipe asym_mix --seeds 0 1 2 3 4 [--jobs 2] [--complete]
    python -m evaluation.experiments.learning pd            # the PD and zero-torque baselines on the grid
    python -m evaluation.experiments.learning select        # each finished run's checkpoint chosen on validation
    python -m evaluation.experiments.learning faults        # PD, zero, pretrained and every run on the fault grid
    python -m evaluation.experiments.learning calibrations  # every run under the other shipped calibrations
    python -m evaluation.experiments.learning summary       # summary.json, tables and plots

The result of a run holds its learning curve (grid success, per shell and tracking RMSE at every
checkpoint), the final checkpoint's figures, the env steps and training wall-clock at which the grid
success first reached the PD's minus 3 points, and the recipe as resolved.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from sphere_env import safe_yaml
from sphere_env.evaluation.episode_sets import check_training_seed, episodes
from sphere_env.evaluation.experiments.run_provenance import from_scratch
from sphere_env.evaluation.faults import PRESSURES_KPA, SHELLS, grid_jobs
from sphere_env.evaluation.faults import SEEDS as EVAL_SEEDS
from sphere_env.files import write_text_atomic

ENV_ID = "sphere_env/RampDescent-v3"
HERE = Path(__file__).resolve().parent
RECIPES = HERE / "recipes.yml"
RESULTS = HERE.parent / "results" / "learning"
RUNS = Path("runs") / "learning"
#: The recipe that RampDescent-v3's section of ``training/hyperparams/ppo.yml`` is: what
#: ``sphere-env train`` and rl-zoo3 train by default.
SECTION_RECIPE = "curriculum_scheduled"
PD_MARGIN = 0.03  # "PD level": grid success ≥ the PD's − 3 points
# the validation set's seeds (evaluation/episode_sets.yml): every choice is made on these
VALIDATION_SEEDS = tuple(sorted({e.seed for e in episodes("validation")}))


def load_recipes(path: Path = RECIPES) -> dict[str, dict[str, Any]]:
    """The recipes of ``recipes.yml``, each with its ``conf``: its own, else the file's default."""
    data = safe_yaml.load_file(path)
    return {name: {"conf": data["conf"], **recipe} for name, recipe in data["recipes"].items()}


def grid_figures(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Success rate, tracking RMSE (mean over episodes with judged samples) and per-shell success."""
    succ = [bool(r["is_success"]) for r in rows]
    rmse = [r["tracking_rmse_rad_s"] for r in rows if np.isfinite(r["tracking_rmse_rad_s"])]
    per_shell = {m: float(np.mean([bool(r["is_success"]) for r in rows if r["shell_model"] == m])) for m in SHELLS}
    return {
        "success_rate": float(np.mean(succ)),
        "tracking_rmse_rad_s": float(np.mean(rmse)) if rmse else math.nan,
        "per_shell": per_shell,
        "episodes": len(rows),
    }


def evaluate_policy(spec: str, env_id: str = ENV_ID, seeds: Sequence[int] = EVAL_SEEDS) -> dict:
    """A run's model (``<run>``, ``<run>@<checkpoint steps>``) on the grid, deterministic actions, in
    an env built with the run's own kwargs."""
    from sphere_env.evaluation.cells import rollout
    from sphere_env.evaluation.controller_specs import PolicyController, env_kwargs_of, run_folder

    ctrl = PolicyController(*run_folder(spec))
    rows = [
        rollout(job, controller=ctrl)[0] for job in grid_jobs("policy", spec, env_id, env_kwargs_of(spec), seeds=seeds)
    ]
    return {
        **grid_figures(rows),
        "episodes_detail": [
            {
                k: r[k]
                for k in ("shell_model", "pressure_kpa", "seed", "is_success", "tracking_rmse_rad_s", "reached_runout")
            }
            for r in rows
        ],
    }


def _figures_per_condition(spec: str, conditions: Mapping[str, Any], cache: Path | None) -> dict[str, dict[str, Any]]:
    """A controller (``pd``, ``zero``, or a run spec of a policy) under each of ``conditions``
    (``name -> (file stem, jobs factory)``, the factory taking the controller kind): grid figures per
    condition, each cached as ``<cache>/<file stem>.json`` so an interrupted evaluation continues."""
    from sphere_env.evaluation.cells import rollout
    from sphere_env.evaluation.controller_specs import PolicyController, run_folder

    ctrl = None if spec in ("pd", "zero") else PolicyController(*run_folder(spec))
    out = {}
    for name, (stem, make_jobs) in conditions.items():
        done = cache / f"{stem}.json" if cache is not None else None
        if done is not None and done.exists():
            out[name] = json.loads(done.read_text())
            continue
        rows = [rollout(job, controller=ctrl)[0] for job in make_jobs("policy" if ctrl else spec)]
        out[name] = grid_figures(rows)
        if done is not None:
            done.parent.mkdir(parents=True, exist_ok=True)
            write_text_atomic(done, json.dumps(out[name]) + "\n")
        print(f"  {spec} {name}: {out[name]['success_rate']:.0%}", flush=True)
    return out


def fault_figures(
    spec: str, env_kwargs: Mapping[str, Any], cache: Path | None = None, env_id: str = ENV_ID
) -> dict[str, dict[str, Any]]:
    """A controller (``pd``, ``zero``, or a run spec of a policy) on every fault of
    :data:`sphere_env.evaluation.faults.FAULTS`: grid figures per fault, each cached as
    ``<cache>/fault_<name>.json``."""
    from sphere_env.evaluation.faults import FAULTS, fault_jobs

    conditions = {
        name: (f"fault_{name}", lambda kind, name=name: fault_jobs(name, kind, spec, env_id, env_kwargs))
        for name in FAULTS
    }
    return _figures_per_condition(spec, conditions, cache)


def calibration_figures(
    spec: str, env_kwargs: Mapping[str, Any], cache: Path | None = None, env_id: str = ENV_ID
) -> dict[str, dict[str, Any]]:
    """A controller on the development grid in the twin built with each other shipped calibration
    (:data:`sphere_env.evaluation.demo.CALIBRATIONS`): grid figures per calibration, each cached as
    ``<cache>/calibration_<name>.json``."""
    from sphere_env.evaluation.demo import CALIBRATIONS

    conditions = {
        cal: (
            f"calibration_{cal}",
            lambda kind, cal=cal: grid_jobs(kind, spec, env_id, {**env_kwargs, "calibration": cal}),
        )
        for cal in CALIBRATIONS
    }
    return _figures_per_condition(spec, conditions, cache)


SELECT_FROM = 0.5  # the validation choice looks at checkpoints from this fraction of the budget on


def checkpoint_steps(run_dir: Path) -> list[int]:
    """The env steps of a run folder's checkpoints, in order."""
    from sphere_env.training.run_folder import CHECKPOINT_PREFIX

    return sorted(
        int(p.stem.split("_")[-2]) for p in (run_dir / "checkpoints").glob(f"{CHECKPOINT_PREFIX}_*_steps.zip")
    )


def validation_figures(run_dir: Path, n: int, env_id: str = ENV_ID) -> dict[str, Any]:
    """Checkpoint ``n`` of a run on the validation set, cached as ``grid_eval/val_<n>.json``."""
    done = run_dir / "grid_eval" / f"val_{n}.json"
    if done.exists():
        return json.loads(done.read_text())
    val = evaluate_policy(f"{run_dir}@{n}", env_id, seeds=VALIDATION_SEEDS)
    val.pop("episodes_detail")
    done.parent.mkdir(exist_ok=True)
    write_text_atomic(done, json.dumps(val) + "\n")
    return val


def select_checkpoint(run_dir: Path, env_id: str = ENV_ID, from_steps: int = 0) -> dict[str, Any]:
    """The run's checkpoint (from ``from_steps`` on) with the highest success on the validation
    grid (seeds 100-102; ties: lower tracking RMSE, then the later checkpoint), and its figures on
    the reported grid: the model an rl-zoo3 user keeps as ``best_model``, chosen on episodes the
    reported figures never use (:func:`validation_figures`)."""
    scored = []
    for n in (c for c in checkpoint_steps(run_dir) if c >= from_steps):
        val = validation_figures(run_dir, n, env_id)
        scored.append((val["success_rate"], -val["tracking_rmse_rad_s"], n, val))
    if not scored:
        raise ValueError(f"{run_dir}: no checkpoint from {from_steps} env steps on")
    _, _, n, val = max(scored, key=lambda x: x[:3])
    cache = run_dir / "grid_eval"
    grid = json.loads((cache / f"{n}.json").read_text()) if (cache / f"{n}.json").exists() else None
    if grid is None:
        grid = evaluate_policy(f"{run_dir}@{n}", env_id)
        grid.pop("episodes_detail")
    return {
        "checkpoint_steps": n,
        "validation": val,
        "candidates": [x[2] for x in scored],
        **{k: grid[k] for k in ("success_rate", "tracking_rmse_rad_s", "per_shell")},
    }


def augment(kind: str, runs_root: Path = RUNS, results: Path = RESULTS, recipes: Sequence[str] | None = None) -> None:
    """Add ``selected`` (:func:`select_checkpoint`), ``faults`` (the selected checkpoint's
    :func:`fault_figures`) or ``calibrations`` (its :func:`calibration_figures`) to every finished
    run's result file (of ``recipes``, or of every recipe) that lacks it, and (faults) the PD's, zero
    torque's and the pretrained policy's to ``baselines.json``."""
    import torch

    from sphere_env.evaluation.controller_specs import env_kwargs_of
    from sphere_env.resources import shipped_policy_path

    torch.set_num_threads(1)
    if kind == "faults":
        base_path = results / "baselines.json"
        base = json.loads(base_path.read_text())
        for name in ("pd", "zero"):
            if "faults" not in base[name]:
                base[name]["faults"] = fault_figures(name, {}, RUNS / "baselines" / name)
                write_text_atomic(base_path, json.dumps(base, indent=1) + "\n")
        if "faults" not in base.get("pretrained", {}):
            spec = str(shipped_policy_path("pretrained"))
            grid = evaluate_policy(spec)
            grid.pop("episodes_detail")
            base["pretrained"] = {
                **grid,
                "faults": fault_figures(spec, env_kwargs_of(spec), RUNS / "baselines" / "pretrained"),
            }
            write_text_atomic(base_path, json.dumps(base, indent=1) + "\n")
    for f in sorted((results / "runs").glob("*/seed*.json")):
        if recipes is not None and f.parent.name not in recipes:
            continue
        res = json.loads(f.read_text())
        run_dir = runs_root / f.parent.name / f.stem
        if kind in res or not run_dir.is_dir() or (kind != "selected" and "selected" not in res):
            continue
        {"selected": add_selection, "faults": add_faults, "calibrations": add_calibrations}[kind](res, run_dir)
        write_text_atomic(f, json.dumps(res, indent=1) + "\n")
        print(f"{f}: {kind} added", flush=True)


def add_selection(res: dict[str, Any], run_dir: Path) -> None:
    """``res["selected"]``: the run's :func:`select_checkpoint` from :data:`SELECT_FROM` of its
    budget on."""
    # a continuation's checkpoints count from the start of its own phase; env_steps from zero
    offset = phase_offset(res["recipe"])
    from_steps = max(0, int(SELECT_FROM * res["env_steps"]) - offset)
    res["selected"] = select_checkpoint(run_dir, res.get("env_id", ENV_ID), from_steps)
    res["selected"]["env_steps"] = offset + res["selected"]["checkpoint_steps"]


def add_faults(res: dict[str, Any], run_dir: Path) -> None:
    """``res["faults"]``: the run's reported model, its validation-chosen checkpoint, on the fault
    grid."""
    from sphere_env.evaluation.controller_specs import env_kwargs_of

    n = res["selected"]["checkpoint_steps"]
    sel = f"{run_dir}@{n}"
    res["faults"] = fault_figures(sel, env_kwargs_of(sel), run_dir / "grid_eval" / f"at_{n}")


def add_calibrations(res: dict[str, Any], run_dir: Path) -> None:
    """``res["calibrations"]``: the run's validation-chosen checkpoint on the development grid under
    every other shipped calibration."""
    from sphere_env.evaluation.controller_specs import env_kwargs_of

    n = res["selected"]["checkpoint_steps"]
    sel = f"{run_dir}@{n}"
    res["calibrations"] = calibration_figures(sel, env_kwargs_of(sel), run_dir / "grid_eval" / f"at_{n}")


def pd_level() -> float:
    base = json.loads((RESULTS / "baselines.json").read_text())
    return base["pd"]["success_rate"] - PD_MARGIN


def phase_offset(recipe: Mapping[str, Any]) -> int:
    """Env steps before a recipe's own run: a continuation's ``continue_at`` (its checkpoints count
    from the start of its own phase), else 0."""
    return int(float(recipe["continue_at"])) if recipe.get("continue_from") else 0


def recipe_config(recipe: dict[str, Any], seed: int, trained_agent: Path | None = None):
    """The training configuration of one ``recipe`` (an entry of ``recipes.yml``) and ``seed``,
    validated like any training configuration (its env built, its callbacks checked against it);
    ``trained_agent``: the checkpoint a continuation starts from."""
    from sphere_env.resources import hyperparams_path
    from sphere_env.training.config import resolve_config

    overrides = {"n_timesteps": int(float(recipe["n_timesteps"])), "n_workers": 1, **(recipe.get("hyperparams") or {})}
    return resolve_config(
        recipe.get("env", ENV_ID),
        recipe.get("algo", "ppo"),
        hyperparams_path(recipe["conf"]),
        overrides=overrides,
        env_kwargs=recipe.get("env_kwargs") or {},
        seed=seed,
        eval_freq=0,
        checkpoint_freq=int(float(recipe.get("eval_every", 100_000))),
        trained_agent=trained_agent,
    )


def train_job(recipe_name: str, seed: int, runs_root: Path = RUNS) -> Path:
    """Train one recipe × seed into its run folder, resuming an interrupted run, and evaluate
    nothing (``run`` evaluates it later: a run at its budget is not trained again); returns the run
    folder."""
    import torch

    from sphere_env.training.run_folder import latest_checkpoint
    from sphere_env.training.trainer import train

    torch.set_num_threads(1)
    recipe = load_recipes()[recipe_name]
    if recipe.get("continue_from"):
        raise ValueError(f"--recipe {recipe_name}: a continuation; train it with run")
    run_dir = runs_root / recipe_name / f"seed{seed}"
    resume = (run_dir / "config.yaml").exists()
    done = latest_checkpoint(run_dir) if resume else None
    if done is not None and done[0] >= int(float(recipe["n_timesteps"])) and (run_dir / "timing.json").exists():
        return run_dir
    cfg = recipe_config(recipe, seed)
    check_training_seed(seed, cfg.n_envs)
    train(cfg, run_dir, resume=resume, progress_bar=False, command=["evaluation.experiments.learning", recipe_name])
    return run_dir


def run_job(
    recipe_name: str, seed: int, runs_root: Path = RUNS, results: Path = RESULTS, complete: bool = False
) -> Path:
    """Train one recipe × seed and evaluate its checkpoints; returns the result file. ``complete``:
    also choose its checkpoint on validation and run that on the fault grid before the file is
    written, so a result that exists needs nothing from the run folder (``runs/`` is a scratch
    area: a study carried over to a fresh checkout keeps only its result files)."""
    import torch

    from sphere_env.training.run_folder import CHECKPOINT_PREFIX
    from sphere_env.training.trainer import train

    torch.set_num_threads(1)
    out = results / "runs" / recipe_name / f"seed{seed}.json"
    if out.exists():
        return out
    recipe = load_recipes()[recipe_name]
    steps = int(float(recipe["n_timesteps"]))
    env_id = recipe.get("env", ENV_ID)
    # a second phase: the same seed's run of another recipe, continued from one of its checkpoints
    # with this recipe's hyperparameters (the trainer's -i); steps and wall-clock count from zero
    # of the first phase
    offset, agent = 0, None
    offset_wall: float | None = 0.0  # None: the first phase was not timed
    if recipe.get("continue_from"):
        offset = phase_offset(recipe)
        first = runs_root / recipe["continue_from"] / f"seed{seed}"
        agent = first / "checkpoints" / f"{CHECKPOINT_PREFIX}_{offset}_steps.zip"
        if not agent.is_file():
            raise ValueError(f"continue_from: {agent} is missing (run {recipe['continue_from']} seed {seed} first)")
        t = json.loads((first / "timing.json").read_text()) if (first / "timing.json").exists() else None
        offset_wall = offset * (t["wall_s"] / t["steps_this_session"]) if t and t["steps_this_session"] > 0 else None
    cfg = recipe_config(recipe, seed, trained_agent=agent)
    check_training_seed(seed, cfg.n_envs)
    run_dir = runs_root / recipe_name / f"seed{seed}"
    resume = (run_dir / "config.yaml").exists()
    t0 = time.perf_counter()
    load_start = os.getloadavg()[0]  # the machine's 1-min load average: what else was running
    from sphere_env.training.run_folder import latest_checkpoint

    done = latest_checkpoint(run_dir) if resume else None
    if not (done is not None and done[0] >= steps and (run_dir / "timing.json").exists()):  # trained: evaluate
        train(cfg, run_dir, resume=resume, progress_bar=False, command=["evaluation.experiments.learning", recipe_name])
    timing = json.loads((run_dir / "timing.json").read_text())
    # a session of zero steps (a run saved from its checkpoint at the budget) has no rate: the
    # wall-clock figures of such a run are unknown (None)
    wall_per_step = timing["wall_s"] / timing["steps_this_session"] if timing["steps_this_session"] > 0 else None

    def wall_at(steps: int) -> float | None:
        known = wall_per_step is not None and offset_wall is not None
        return offset_wall + steps * wall_per_step if known else None

    curve = []
    ckpts = checkpoint_steps(run_dir)
    cache = run_dir / "grid_eval"  # one file per evaluated checkpoint: a longer budget re-uses them
    cache.mkdir(exist_ok=True)
    for n in ckpts:
        done = cache / f"{n}.json"
        if done.exists():
            fig = json.loads(done.read_text())
        else:
            fig = evaluate_policy(f"{run_dir}@{n}", env_id)
            fig.pop("episodes_detail")
            write_text_atomic(done, json.dumps(fig) + "\n")
        curve.append({"env_steps": offset + n, "wall_clock_s": wall_at(n), **fig})
    final = evaluate_policy(str(run_dir), env_id)
    level = pd_level()
    reached = next((c for c in curve if c["success_rate"] >= level - 1e-9), None)
    result = {
        "method": recipe_name,
        "condition": recipe.get("condition", "pressure"),
        "from_scratch": from_scratch(recipe, seed),
        "seed": seed,
        "algo": cfg.algo,
        "env_id": env_id,
        "recipe": recipe,
        "success_rate": final["success_rate"],
        "tracking_rmse_rad_s": final["tracking_rmse_rad_s"],
        "per_shell": final["per_shell"],
        "episodes": final["episodes_detail"],
        "curve": curve,
        "pd_level": level,
        "env_steps_to_pd_level": reached["env_steps"] if reached else None,
        "wall_clock_to_pd_level_s": reached["wall_clock_s"] if reached else None,
        # the last training session's rate over the whole run: a resumed run's earlier sessions are
        # not timed (timing.json is per session), so its own wall time would count the last one only
        "wall_clock_s": wall_at(timing["num_timesteps"]),
        "env_steps": offset + timing["num_timesteps"],
        "steps_per_s": timing["steps_per_s"],
        "job_wall_s": time.perf_counter() - t0,
        "load_avg_1min": {"start": load_start, "end": os.getloadavg()[0]},
        "commit": _commit(),
        "cores": os.cpu_count(),
    }
    if complete:
        add_selection(result, run_dir)
        add_faults(result, run_dir)
        add_calibrations(result, run_dir)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out, json.dumps(result, indent=1) + "\n")
    return out


def _commit() -> str:
    from sphere_env.provenance import software_versions

    return software_versions()["git_commit"] or "unknown"


def _job(job: Mapping[str, Any]) -> str:
    name, seed = job["recipe"], job["seed"]
    try:
        if job.get("train_only"):
            out = str(train_job(name, seed))
        else:
            out = str(run_job(name, seed, complete=job.get("complete", False)))
    except Exception as err:  # noqa: BLE001 - one failed job is reported, the others go on
        out = f"FAILED {name} seed {seed}: {type(err).__name__}: {err}"
    print(out, flush=True)
    return out


def baselines(results: Path = RESULTS) -> Path:
    """The PD and zero-torque controllers on the grid: ``baselines.json``."""
    from sphere_env.evaluation.cells import rollout

    out = {}
    for name in ("pd", "zero"):
        rows = [rollout(job)[0] for job in grid_jobs(name, name, ENV_ID, {})]
        out[name] = grid_figures(rows)
    out.update(
        grid={
            "shells": list(SHELLS),
            "pressures_kpa": list(PRESSURES_KPA),
            "seeds": list(EVAL_SEEDS),
            "episodes": len(SHELLS) * len(PRESSURES_KPA) * len(EVAL_SEEDS),
        },
        commit=_commit(),
    )
    path = results / "baselines.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, json.dumps(out, indent=1) + "\n")
    return path


def main(argv: Sequence[str] | None = None) -> None:
    p = argparse.ArgumentParser(
        prog="python -m evaluation.experiments.learning",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="train and evaluate recipe x seeds (skips finished jobs)")
    r.add_argument("--recipe", nargs="+", required=True)
    r.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    r.add_argument("--jobs", type=int, default=2, help="jobs at once, one core each")
    r.add_argument(
        "--complete",
        action="store_true",
        help="also choose each run's checkpoint on validation and evaluate it on the fault grid and under the"
        " other calibrations before its result file is written (what select, faults and calibrations add"
        " later, while the run folder still exists)",
    )
    r.add_argument(
        "--ray-address",
        default=None,
        help="run the jobs on a Ray cluster (auto, ray://host:10001, or local); needs the ray extra",
    )
    t = sub.add_parser("train", help="train recipe x seeds only (resumable); run evaluates them later")
    t.add_argument("--recipe", nargs="+", required=True)
    t.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    t.add_argument("--jobs", type=int, default=2, help="jobs at once, one core each")
    t.add_argument("--ray-address", default=None, help="run the jobs on a Ray cluster")
    sub.add_parser("pd", help="evaluate the PD and zero torque on the grid")
    sub.add_parser("summary", help="write summary.json, the tables and the plots")
    for name, text in (
        ("select", "add each finished run's checkpoint chosen on the validation grid"),
        ("faults", "evaluate PD, zero, the pretrained policy and every finished run on the fault grid"),
        ("calibrations", "evaluate every finished run under the other shipped calibrations"),
    ):
        a = sub.add_parser(name, help=text)
        a.add_argument("--recipe", nargs="+", default=None, help="these recipes' runs only (default: every recipe)")
    args = p.parse_args(argv)
    if args.cmd == "pd":
        print(baselines())
        return
    if args.cmd in ("select", "faults", "calibrations"):
        bad = [n for n in args.recipe or [] if n not in load_recipes()]
        if bad:
            p.error(f"--recipe: unknown {bad}; allowed: {sorted(load_recipes())}")
        augment({"select": "selected"}.get(args.cmd, args.cmd), recipes=args.recipe)
        return
    if args.cmd == "summary":
        from sphere_env.evaluation.experiments.learning_summary import write_summary

        print(write_summary(RESULTS))
        return
    known = load_recipes()
    bad = [n for n in args.recipe if n not in known]
    if bad:
        p.error(f"--recipe: unknown {bad}; allowed: {sorted(known)}")
    if args.jobs < 1:
        p.error(f"--jobs: value {args.jobs} must be >= 1")
    from sphere_env.parallel import run_parallel

    # seed by seed, each seed's recipes side by side, one job per worker at a time: a study stopped
    # part-way (a session's end) has its conditions at the same number of seeds
    todo = [
        {"recipe": n, "seed": s, "complete": getattr(args, "complete", False), "train_only": args.cmd == "train"}
        for s in args.seeds
        for n in args.recipe
    ]
    run_parallel(_job, todo, workers=args.jobs, ray_address=args.ray_address, chunksize=1)


if __name__ == "__main__":
    main(sys.argv[1:])
