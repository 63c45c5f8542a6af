"""Is it the observation normalization or the policy that loses a run's grid success after its peak?

Two checkpoints of one training run, an earlier good one and a later worse one, are evaluated on the
demo grid with their own VecNormalize statistics and with each other's. If the later policy wins
back its success with the earlier statistics (or the earlier policy loses it with the later ones),
the normalization moved under the policy; if the policy carries its result whichever statistics it
reads, the loss is in the policy's weights. The statistics' drift between the two checkpoints is
reported beside it (means in units of the earlier standard deviation, the ratio of the standard
deviations).

    python -m evaluation.experiments.normalization_swap RUN_DIR EARLY_STEPS LATE_STEPS

writes ``evaluation/results/learning/normalization_swap.json`` (through a temporary file).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sphere_env.evaluation.experiments import RESULTS
from sphere_env.files import write_text_atomic

OUT = RESULTS / "learning" / "normalization_swap.json"


def _grid(ctrl: Any, spec: str) -> dict[str, Any]:
    from sphere_env.evaluation.cells import rollout
    from sphere_env.evaluation.controller_specs import env_kwargs_of
    from sphere_env.evaluation.experiments.learning import ENV_ID, grid_figures
    from sphere_env.evaluation.faults import grid_jobs

    rows = [rollout(job, controller=ctrl)[0] for job in grid_jobs("policy", spec, ENV_ID, env_kwargs_of(spec))]
    fig = grid_figures(rows)
    return {"wins": round(fig["success_rate"] * len(rows)), "episodes": len(rows), **fig}


def swap(run_dir: Path, early: int, late: int) -> dict[str, Any]:
    """The four (policy, statistics) pairs of two checkpoints on the grid, and the statistics' drift."""
    from sphere_env.evaluation.controller_specs import PolicyController

    ctrl = {n: PolicyController(run_dir, str(n)) for n in (early, late)}
    for n, c in ctrl.items():
        if c.vecnormalize is None:
            raise ValueError(f"run_dir: {str(run_dir)!r} checkpoint {n} has no VecNormalize statistics to swap")
    rms = {n: ctrl[n].vecnormalize.obs_rms for n in (early, late)}
    sd_early = np.sqrt(rms[early].var + 1e-8)
    sd_ratio = np.sqrt(rms[late].var + 1e-8) / sd_early
    drift = {
        "max_abs_mean_shift_in_early_sd": float(np.max(np.abs(rms[late].mean - rms[early].mean) / sd_early)),
        "sd_ratio_range": [float(np.min(sd_ratio)), float(np.max(sd_ratio))],
    }
    cases = {}
    for policy in (early, late):
        for stats in (early, late):
            c = PolicyController(run_dir, str(policy))  # a fresh controller per case: its own statistics object
            c.vecnormalize = ctrl[stats].vecnormalize if stats != policy else c.vecnormalize
            cases[f"policy_{policy}_stats_{stats}"] = _grid(c, f"{run_dir}@{policy}")
            print(
                f"policy {policy} with the statistics of {stats}: {cases[f'policy_{policy}_stats_{stats}']['wins']} wins",
                flush=True,
            )
    run = "/".join(run_dir.resolve().parts[-2:])  # <recipe>/seed<k>
    return {"run": run, "early_steps": early, "late_steps": late, "cases": cases, "statistics_drift": drift}


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("early_steps", type=int)
    ap.add_argument("late_steps", type=int)
    ap.add_argument("--out", type=Path, default=OUT)
    a = ap.parse_args(argv)
    if a.early_steps >= a.late_steps:
        ap.error(f"early_steps: {a.early_steps} must be below late_steps ({a.late_steps})")
    import torch

    torch.set_num_threads(1)
    write_text_atomic(a.out, json.dumps(swap(a.run_dir, a.early_steps, a.late_steps), indent=1) + "\n")
    print(a.out)


if __name__ == "__main__":
    main()
