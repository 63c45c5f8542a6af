"""Held-out figures: controllers on the test set, nominal, under every graded fault and under every
shipped calibration.

The test set (``evaluation/episode_sets.yml``) is used for reported figures only: no choice reads
it. For every finished run of the learning study this adds ``test`` to its result file: its
validation-chosen checkpoint (``selected``) and its final model on the test set, the chosen one
also under each fault of :data:`~sphere_env.evaluation.faults.GRADED_FAULTS` and under each
calibration of :data:`~sphere_env.evaluation.demo.CALIBRATIONS` (the nominal figures are the
default calibration's), and the final model's validation figures (how far a run fell
from its best validation checkpoint by the end). For the PD, zero torque and the shipped policy it
adds the same to ``baselines.json``. Every episode runs with deterministic actions under the
reference physics (SAP: a policy trained with the TAMSI solver is evaluated without it,
:func:`~sphere_env.evaluation.controller_specs.env_kwargs_of`). Each figure is cached in the run
folder as it finishes, so an interrupted pass continues.

    python -m evaluation.experiments.held_out runs [--recipe NAME ...] [--seeds N ...]
    python -m evaluation.experiments.held_out baselines
    python -m evaluation.experiments.held_out summary     # held_out.json: per recipe, the aims it meets
    python -m evaluation.experiments.held_out screen RUN@STEPS [pd ...] [--faults NAME ...] [--calibrations NAME ...]

``screen`` is the validation set's counterpart for choosing a recipe: a controller (``pd``, ``zero``
or a run's checkpoint) on the validation set nominally, under the faults and under the calibrations
given (by default the joint-friction faults that a recipe must survive and every shipped
calibration), each figure cached in the run folder (``grid_eval/screen_<steps>/``; the PD's and
zero torque's under ``<runs>/baselines/``) as it finishes.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, Mapping, Sequence

from sphere_env.evaluation.demo import CALIBRATIONS  # the shipped calibrations that are other physics
from sphere_env.evaluation.episode_sets import episodes
from sphere_env.evaluation.experiments.learning import (
    ENV_ID,
    RESULTS,
    RUNS,
    checkpoint_steps,
    grid_figures,
    phase_offset,
    validation_figures,
)
from sphere_env.evaluation.faults import GRADED_FAULTS, episode_jobs, fault_episodes
from sphere_env.evaluation.schemas import CalibrationName, FaultName
from sphere_env.files import write_text_atomic
from sphere_env.schemas import Schema, validate


def set_figures(
    spec: str,
    controller: Any,
    set_name: str,
    env_kwargs: Mapping[str, Any],
    fault: str | None = None,
    cache: Path | None = None,
) -> dict[str, Any]:
    """``controller`` (``pd``, ``zero`` or a loaded policy of run ``spec``) on the episodes of
    ``set_name``, under ``fault`` (a name of :data:`GRADED_FAULTS`) or none: :func:`grid_figures`
    with the episodes' outcomes, cached as ``cache`` when given."""
    from sphere_env.evaluation.cells import rollout

    if cache is not None and cache.exists():
        return json.loads(cache.read_text())
    eps = list(episodes(set_name))
    kind = "policy" if controller is not None else spec
    if fault is None:
        jobs = episode_jobs(kind, spec, ENV_ID, env_kwargs, eps)
    else:
        f = GRADED_FAULTS[fault]
        jobs = episode_jobs(
            kind, spec, ENV_ID, {**env_kwargs, **f.env_kwargs}, fault_episodes(f, eps), randomization=f.randomization
        )
    rows = [rollout(job, controller=controller)[0] for job in jobs]
    out = {
        "set": set_name,
        **grid_figures(rows),
        "episodes_detail": [
            {k: r[k] for k in ("shell_model", "pressure_kpa", "seed", "is_success", "tracking_rmse_rad_s")}
            for r in rows
        ],
    }
    if cache is not None:
        cache.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(cache, json.dumps(out) + "\n")
    return out


def held_out_figures(spec: str, cache: Path, final_spec: str | None = None) -> dict[str, Any]:
    """One controller's held-out figures: nominal, per fault, per calibration on the test set;
    with ``final_spec`` (a run's final model) also that model's test and validation figures."""
    from sphere_env.evaluation.controller_specs import PolicyController, env_kwargs_of, run_folder

    def load(s):
        return None if s in ("pd", "zero") else PolicyController(*run_folder(s))

    ctrl, kw = load(spec), env_kwargs_of(spec)
    out: dict[str, Any] = {"nominal": set_figures(spec, ctrl, "test", kw, cache=cache / "test.json")}
    out["faults"] = {}
    for name in GRADED_FAULTS:
        fig = set_figures(spec, ctrl, "test", kw, fault=name, cache=cache / f"test_fault_{name}.json")
        out["faults"][name] = {k: v for k, v in fig.items() if k != "episodes_detail"}
        print(f"  {spec} test {name}: {fig['success_rate']:.0%}", flush=True)
    out["calibrations"] = {}
    for cal in CALIBRATIONS:
        fig = set_figures(spec, ctrl, "test", {**kw, "calibration": cal}, cache=cache / f"test_calibration_{cal}.json")
        out["calibrations"][cal] = {k: v for k, v in fig.items() if k != "episodes_detail"}
    if final_spec is not None:
        fctrl, fkw = load(final_spec), env_kwargs_of(final_spec)
        out["final"] = set_figures(final_spec, fctrl, "test", fkw, cache=cache / "final_test.json")
        out["final_validation"] = set_figures(
            final_spec, fctrl, "validation", fkw, cache=cache / "final_validation.json"
        )
    return out


def validation_curve(run_dir: Path, offset: int = 0) -> list[dict[str, Any]]:
    """Every checkpoint of a run on the validation set (the checkpoint choice's own cache,
    :func:`~sphere_env.evaluation.experiments.learning.validation_figures`): env steps (from zero of
    a first phase, ``offset``), success, tracking RMSE and per-shell success. The PD-level crossing
    is read on it."""
    curve = []
    for n in checkpoint_steps(run_dir):
        val = validation_figures(run_dir, n)
        curve.append(
            {"env_steps": offset + n, **{k: val[k] for k in ("success_rate", "tracking_rmse_rad_s", "per_shell")}}
        )
    return curve


def add_to_runs(
    recipes: Sequence[str] | None = None,
    runs_root: Path = RUNS,
    results: Path = RESULTS,
    seeds: Sequence[int] | None = None,
) -> None:
    """Add ``test`` to every finished run's result file that has a validation-chosen checkpoint
    and a run folder, and lacks it (``recipes``, ``seeds``: only these, so that two passes can share
    a study without doing the same run twice)."""
    import torch

    torch.set_num_threads(1)
    for f in sorted((results / "runs").glob("*/seed*.json")):
        if (recipes and f.parent.name not in recipes) or (seeds and f.stem not in {f"seed{n}" for n in seeds}):
            continue
        res = json.loads(f.read_text())
        run_dir = runs_root / f.parent.name / f.stem
        if "test" in res or "selected" not in res or not run_dir.is_dir():
            continue
        n = res["selected"]["checkpoint_steps"]
        res["validation_curve"] = validation_curve(run_dir, phase_offset(res["recipe"]))
        res["test"] = held_out_figures(f"{run_dir}@{n}", run_dir / "grid_eval" / f"held_out_{n}", str(run_dir))
        write_text_atomic(f, json.dumps(res, indent=1) + "\n")
        print(f"{f}: test added", flush=True)


def add_to_baselines(results: Path = RESULTS) -> None:
    """Add ``test`` to the PD's, zero torque's and the shipped policy's entries of ``baselines.json``."""
    import torch

    from sphere_env.resources import shipped_policy_path

    torch.set_num_threads(1)
    path = results / "baselines.json"
    base = json.loads(path.read_text())
    specs = {"pd": "pd", "zero": "zero", "pretrained": str(shipped_policy_path("pretrained"))}
    for name, spec in specs.items():
        if "test" in base.get(name, {}):
            continue
        base.setdefault(name, {})["test"] = held_out_figures(spec, RUNS / "baselines" / f"held_out_{name}")
        write_text_atomic(path, json.dumps(base, indent=1) + "\n")
        print(f"{name}: test added", flush=True)


#: The robust recipe's aims on the test set (points of success against the PD's, fractions).
AIMS = {"pd_margin": 0.03, "worst_run": 0.85, "every_shell": 0.80, "max_env_steps": 4_000_000, "stable_within": 0.05}


def summarize(results: Path = RESULTS) -> dict[str, Any]:
    """Per recipe with held-out figures: each run's test-set scores (its validation-chosen
    checkpoint), the mean with a bootstrap interval over whole runs, the worst run, per shell,
    per fault and per calibration against the PD's on the same episodes, stability (final model
    against the chosen checkpoint on the validation set) and the first validation-set crossing of
    the PD's level; and which aims (:data:`AIMS`) hold."""
    from sphere_env.evaluation.experiments.intervals import SHELLS, interval_estimates

    base = json.loads((results / "baselines.json").read_text())
    pd = base.get("pd", {}).get("test")
    val_pd = json.loads((results / "baselines_validation.json").read_text())["pd"]["success_rate"]
    out: dict[str, Any] = {"set": "test", "aims": AIMS, "baselines": {}, "recipes": {}}
    for name in ("pd", "zero", "pretrained"):
        t = base.get(name, {}).get("test")
        if t:
            out["baselines"][name] = {
                "success_rate": t["nominal"]["success_rate"],
                "per_shell": t["nominal"]["per_shell"],
                "faults": {k: v["success_rate"] for k, v in t["faults"].items()},
                "calibrations": {k: v["success_rate"] for k, v in t["calibrations"].items()},
            }
    by_recipe: dict[str, list[dict[str, Any]]] = {}
    for f in sorted((results / "runs").glob("*/seed*.json")):
        r = json.loads(f.read_text())
        if "test" in r:
            by_recipe.setdefault(f.parent.name, []).append(r)
    for name, runs in by_recipe.items():
        runs.sort(key=lambda r: r["seed"])
        nominal = [r["test"]["nominal"]["success_rate"] for r in runs]
        ci = interval_estimates({name: nominal})[name]
        faults = {
            k: float(sum(r["test"]["faults"][k]["success_rate"] for r in runs) / len(runs)) for k in GRADED_FAULTS
        }
        cals = {
            k: float(sum(r["test"]["calibrations"][k]["success_rate"] for r in runs) / len(runs)) for k in CALIBRATIONS
        }
        drops = [
            r["selected"]["validation"]["success_rate"] - r["test"]["final_validation"]["success_rate"] for r in runs
        ]
        crossings = [
            next(
                (
                    c["env_steps"]
                    for c in r.get("validation_curve", [])
                    if c["success_rate"] >= val_pd - AIMS["pd_margin"]
                ),
                None,
            )
            for r in runs
        ]
        row = {
            "seeds": [r["seed"] for r in runs],
            "runs": len(runs),
            "success_rate": nominal,
            "mean": ci["mean"],
            "mean_ci": ci["mean_ci"],
            "worst_run": min(nominal),
            "per_shell_mean": {
                m: float(sum(r["test"]["nominal"]["per_shell"][m] for r in runs) / len(runs)) for m in SHELLS
            },
            "faults_mean": faults,
            "calibrations_mean": cals,
            "final_below_chosen_on_validation": drops,
            "env_steps": [r["env_steps"] for r in runs],
            "validation_pd_level_crossing_env_steps": crossings,
        }
        if pd:
            row["aims"] = {
                "nominal_mean": row["mean"] >= pd["nominal"]["success_rate"] - AIMS["pd_margin"],
                "worst_run": row["worst_run"] >= AIMS["worst_run"],
                "every_shell": min(row["per_shell_mean"].values()) >= AIMS["every_shell"],
                "every_fault": all(
                    faults[k] >= pd["faults"][k]["success_rate"] - AIMS["pd_margin"] for k in GRADED_FAULTS
                ),
                "every_calibration": all(
                    cals[k] >= pd["calibrations"][k]["success_rate"] - AIMS["pd_margin"] for k in CALIBRATIONS
                ),
                "budget": max(row["env_steps"]) <= AIMS["max_env_steps"],
                "stable_to_the_end": max(drops) <= AIMS["stable_within"],
                "runs": len(runs) >= 10,
            }
        out["recipes"][name] = row
    return out


#: The faults a recipe is screened under by default: where the pure policies lost to the PD.
SCREEN_FAULTS = ("friction_low", "friction_drive_50pct", "friction_high")


class ScreenArgs(Schema):
    """The names :func:`screen` takes, checked as ``sphere-env evaluate`` checks its own."""

    faults: list[FaultName]
    calibrations: list[CalibrationName]


def screen_cache(spec: str, runs_root: Path = RUNS) -> Path:
    """Where :func:`screen` caches the figures of ``spec``."""
    if spec in ("pd", "zero"):
        return runs_root / "baselines" / f"screen_{spec}"
    run, _, steps = spec.partition("@")
    return Path(run) / "grid_eval" / f"screen_{steps or 'final'}"


def screen(
    specs: Sequence[str],
    faults: Sequence[str] = SCREEN_FAULTS,
    calibrations: Sequence[str] = CALIBRATIONS,
    runs_root: Path = RUNS,
) -> dict[str, dict[str, dict[str, Any]]]:
    """Each controller of ``specs`` on the validation set: nominal, under each of ``faults`` and
    under each of ``calibrations`` (success, tracking RMSE, per shell), cached as they finish.
    Every name is checked as ``sphere-env evaluate`` checks its ``--faults`` (``all``: the graded
    grid) and ``--calibrations``, before any episode runs (``ValueError`` naming the field)."""
    from sphere_env.evaluation.controller_specs import PolicyController, env_kwargs_of, run_folder

    args = validate(ScreenArgs, {"faults": list(faults), "calibrations": list(calibrations)}, "held_out screen")
    faults = list(GRADED_FAULTS) if "all" in args.faults else args.faults
    loaded = {}
    for spec in specs:
        ctrl = None if spec in ("pd", "zero") else PolicyController(*run_folder(spec))  # refuses a bad spec
        loaded[spec] = (ctrl, env_kwargs_of(spec))
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for spec, (ctrl, kw) in loaded.items():
        cache = screen_cache(spec, runs_root)
        conditions = [("nominal", kw, None)]
        conditions += [(f, kw, f) for f in faults]
        conditions += [(f"calibration_{c}", {**kw, "calibration": c}, None) for c in args.calibrations]
        out[spec] = {}
        for name, env_kwargs, fault in conditions:
            fig = set_figures(
                spec, ctrl, "validation", env_kwargs, fault=fault, cache=cache / f"validation_{name}.json"
            )
            out[spec][name] = {k: v for k, v in fig.items() if k != "episodes_detail"}
            shells = ", ".join(f"{m} {v:.0%}" for m, v in fig["per_shell"].items())
            print(f"{spec} validation {name}: {fig['success_rate']:.0%} ({shells})", flush=True)
    return out


def main(argv: Sequence[str] | None = None) -> None:
    p = argparse.ArgumentParser(
        prog="python -m evaluation.experiments.held_out",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("runs", help="add the test-set figures to every finished run's result file")
    r.add_argument("--recipe", nargs="+", default=None)
    r.add_argument("--seeds", nargs="+", type=int, default=None, help="only these seeds' runs")
    sub.add_parser("baselines", help="add the test-set figures of the PD, zero torque and the shipped policy")
    sub.add_parser("summary", help="write held_out.json: the test-set figures per recipe and the aims they meet")
    sc = sub.add_parser("screen", help="controllers on the validation set, nominal, under faults and calibrations")
    sc.add_argument("specs", nargs="+", help="pd, zero, or a run folder [@checkpoint steps]")
    sc.add_argument("--faults", nargs="*", default=list(SCREEN_FAULTS), help="graded faults (default: %(default)s)")
    sc.add_argument("--calibrations", nargs="*", default=list(CALIBRATIONS), help="shipped calibrations")
    args = p.parse_args(argv)
    if args.cmd == "screen":
        try:
            screen(args.specs, args.faults, args.calibrations)
        except ValueError as err:
            sys.exit(str(err))
        return
    if args.cmd == "runs":
        add_to_runs(args.recipe, seeds=args.seeds)
    elif args.cmd == "baselines":
        add_to_baselines()
    else:
        path = RESULTS / "held_out.json"
        write_text_atomic(path, json.dumps(summarize(), indent=1) + "\n")
        print(path)


if __name__ == "__main__":
    main(sys.argv[1:])
