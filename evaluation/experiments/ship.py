"""Ship a policy of the learning study as the package's ``pretrained`` policy, with its model card.

Among ``--candidates`` (``recipe:seed`` for a run's final model, ``recipe:seed:steps`` for one of its
checkpoints) the one with the highest success on the validation set is chosen (ties: the lower
tracking RMSE); the test set is then read for the card only, never for the choice. The card
(``card.json`` beside the model) holds the recipe as resolved, the seed, the checkpoint's env steps,
the commit, every candidate's validation figures, and the chosen policy's held-out figures
(:func:`~sphere_env.evaluation.experiments.held_out.held_out_figures`: the test set nominal, under
every graded fault and under every shipped calibration) beside its development-grid figures.

    python -m evaluation.experiments.ship --candidates robust_residual:0:1500000 robust_residual:3:1800000
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path
from typing import Any, Sequence

from sphere_env.evaluation.experiments.held_out import held_out_figures
from sphere_env.evaluation.experiments.learning import (
    ENV_ID,
    RUNS,
    VALIDATION_SEEDS,
    _commit,
    evaluate_policy,
    load_recipes,
    phase_offset,
    validation_figures,
)
from sphere_env.evaluation.faults import PRESSURES_KPA, SHELLS
from sphere_env.evaluation.faults import SEEDS as EVAL_SEEDS


def parse_candidate(spec: str) -> dict[str, Any]:
    """``recipe:seed`` (final model) or ``recipe:seed:steps`` (a checkpoint) -> its description,
    refused by name unless the form and the recipe are right."""
    parts = spec.split(":")
    if len(parts) not in (2, 3) or not all(p.isdigit() for p in parts[1:]):
        raise ValueError(f"candidates: {spec!r}; allowed: recipe:seed or recipe:seed:steps")
    recipes = load_recipes()
    if parts[0] not in recipes:
        raise ValueError(f"candidates: recipe {parts[0]!r} of {spec!r} is unknown; allowed: {sorted(recipes)}")
    steps = int(parts[2]) if len(parts) == 3 else None
    return {
        "recipe": parts[0],
        "seed": int(parts[1]),
        "checkpoint_steps": steps,
        "env_steps": None if steps is None else phase_offset(recipes[parts[0]]) + steps,
    }


def run_spec(desc: dict[str, Any], runs_root: Path = RUNS) -> str:
    """The run spec of :mod:`sphere_env.evaluation.controller_specs` of a parsed candidate."""
    at = f"@{desc['checkpoint_steps']}" if desc["checkpoint_steps"] is not None else ""
    return str(runs_root / desc["recipe"] / f"seed{desc['seed']}") + at


def _validation(run: str, desc: dict[str, Any], runs_root: Path) -> dict[str, Any]:
    if desc["checkpoint_steps"] is not None:  # the checkpoint choice's own cache
        folder = runs_root / desc["recipe"] / f"seed{desc['seed']}"
        return validation_figures(folder, desc["checkpoint_steps"])
    val = evaluate_policy(run, seeds=VALIDATION_SEEDS)
    val.pop("episodes_detail")
    return val


def ship(candidates: Sequence[str], runs_root: Path = RUNS) -> Path:
    """Choose among ``candidates`` on the validation set, evaluate the chosen one on the development
    grid and the test set, and copy it into the package as the ``pretrained`` policy:
    ``assets/policies/<folder>/`` with the run's config, the model, its normalization statistics
    (JSON) and ``card.json``, through a staging folder that replaces the previous one whole."""
    from importlib import resources

    import torch

    from sphere_env.evaluation.controller_specs import model_files, run_folder
    from sphere_env.files import staged_folder
    from sphere_env.resources import ASSETS_PACKAGE, SHIPPED_POLICIES
    from sphere_env.training.saved import read_stats, save_stats

    torch.set_num_threads(1)
    from sphere_env.evaluation.controller_specs import check_spec

    # refuse a bad list before any work: every form first, then every model
    descs = [parse_candidate(c) for c in candidates]
    runs = [(run_spec(d, runs_root), d) for d in descs]
    for run, _ in runs:
        check_spec(run, ENV_ID)
    scores = []
    for c, (run, desc) in zip(candidates, runs):
        val = _validation(run, desc, runs_root)
        scores.append({"candidate": c, **desc, "validation": val})
        print(f"{c}: validation success {val['success_rate']:.0%}", flush=True)
    best = max(
        range(len(scores)),
        key=lambda i: (scores[i]["validation"]["success_rate"], -scores[i]["validation"]["tracking_rmse_rad_s"]),
    )
    run, desc = runs[best]
    folder, which = run_folder(run)
    at = desc["checkpoint_steps"] if desc["checkpoint_steps"] is not None else "final"
    test = held_out_figures(run, folder / "grid_eval" / f"held_out_{at}")
    grid = evaluate_policy(run)
    model, stats = model_files(folder, which)
    target = Path(str(resources.files(ASSETS_PACKAGE))) / "policies" / SHIPPED_POLICIES["pretrained"]

    def replace(work: Path, old: Path) -> None:
        aside = old.with_name(f".{old.name}.old")
        shutil.rmtree(aside, ignore_errors=True)
        old.rename(aside)
        work.rename(old)
        shutil.rmtree(aside)

    with staged_folder(target, replace) as stage:
        shutil.copy2(folder / "config.yaml", stage / "config.yaml")
        shutil.copy2(model, stage / "model.zip")
        save_stats(read_stats(stats), stage / "vecnormalize.json")  # JSON, whatever the run wrote
        card = {
            "env_id": ENV_ID,
            "algo": "ppo",
            **desc,
            "test": test,
            "success_rate": grid["success_rate"],
            "tracking_rmse_rad_s": grid["tracking_rmse_rad_s"],
            "per_shell": grid["per_shell"],
            "episodes": grid["episodes_detail"],
            "grid": {"shells": list(SHELLS), "pressures_kpa": list(PRESSURES_KPA), "seeds": list(EVAL_SEEDS)},
            "chosen_on": {"set": "validation", "seeds": list(VALIDATION_SEEDS), "candidates": scores},
            "recipes": {name: load_recipes()[name] for name in {s["recipe"] for s in scores}},
            "commit": _commit(),
        }
        (stage / "card.json").write_text(json.dumps(card, indent=1) + "\n")
    return target


def main(argv: Sequence[str] | None = None) -> None:
    p = argparse.ArgumentParser(
        prog="python -m evaluation.experiments.ship",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--candidates", nargs="+", required=True, help="recipe:seed (final model) or recipe:seed:steps")
    args = p.parse_args(argv)
    try:
        print(ship(args.candidates))
    except ValueError as err:
        p.exit(2, f"{p.prog}: error: {err}\n")


if __name__ == "__main__":
    main(sys.argv[1:])
