"""The ramp task before and after the drive fit: the PD and the shipped policy on RampDescent-v3
(the paper's drive direction) and RampDescent-v4 (each calibration's fitted ``drive_law``).

Both controllers run the development grid (``evaluation/episode_sets.yml``: 3, 8.5 and 14 kPa ×
every shell model × evaluation seeds 0-2) on each env with the default calibration, deterministic
actions and randomization off, as the learning study's baselines do
(:func:`~sphere_env.evaluation.experiments.held_out.set_figures`). The shipped policy (``pretrained``)
was trained on v3; on v4 it meets physics it never saw. Writes one JSON, by env id and controller:
the grid's success rate, tracking RMSE, per shell model success, tracking RMSE, mean ω_d on the
ramp and time on the ramp, and every episode's outcome.

    python -m evaluation.experiments.drive_fit_envs [--out evaluation/results/drive_fit_envs.json]
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import time
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from sphere_env.files import write_text_atomic

ENV_IDS = ("sphere_env/RampDescent-v3", "sphere_env/RampDescent-v4")
CONTROLLERS = ("pd", "pretrained")
SET_NAME = "development"
OUT = Path(__file__).resolve().parents[1] / "results" / "drive_fit_envs.json"
#: What each episode's outcome keeps.
DETAIL = ("shell_model", "pressure_kpa", "seed", "is_success", "tracking_rmse_rad_s", "mean_omega_d_rad_s", "return")


def _mean(xs: Sequence[float]) -> float:
    xs = [x for x in xs if math.isfinite(x)]
    return float(np.mean(xs)) if xs else math.nan


def figures(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The grid's figures (:func:`~sphere_env.evaluation.experiments.learning.grid_figures`), the mean
    return, and per shell model the tracking RMSE, mean ω_d on the ramp and time on the ramp."""
    from sphere_env.evaluation.experiments.learning import SHELLS, grid_figures

    out = grid_figures(rows)
    out["mean_return"] = _mean([r["return"] for r in rows])
    out["per_shell_detail"] = {
        m: {
            "success_rate": out["per_shell"][m],
            "tracking_rmse_rad_s": _mean([r["tracking_rmse_rad_s"] for r in rows if r["shell_model"] == m]),
            "mean_omega_d_rad_s": _mean([r["mean_omega_d_rad_s"] for r in rows if r["shell_model"] == m]),
            "time_on_ramp_s": _mean([r["time_on_ramp_s"] for r in rows if r["shell_model"] == m]),
        }
        for m in SHELLS
    }
    out["episodes_detail"] = [{k: r[k] for k in DETAIL} for r in rows]
    return out


def controller_figures(env_id: str, spec: str) -> dict[str, Any]:
    """``spec`` (``pd`` or a policy) on the development grid of ``env_id``."""
    from sphere_env.evaluation.cells import rollout
    from sphere_env.evaluation.controller_specs import PolicyController, env_kwargs_of, run_folder
    from sphere_env.evaluation.episode_sets import episodes
    from sphere_env.evaluation.faults import episode_jobs

    ctrl = None if spec == "pd" else PolicyController(*run_folder(spec))
    kind = spec if ctrl is None else "policy"
    jobs = episode_jobs(kind, spec, env_id, env_kwargs_of(spec), list(episodes(SET_NAME)))
    return figures([rollout(job, controller=ctrl)[0] for job in jobs])


def _commit() -> str:
    try:
        return subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True, cwd=OUT.parent
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def study(env_ids: Sequence[str] = ENV_IDS, controllers: Sequence[str] = CONTROLLERS) -> dict[str, Any]:
    """Every controller on every env's development grid (module docstring)."""
    import torch

    torch.set_num_threads(1)
    t0 = time.time()
    out: dict[str, Any] = {"set": SET_NAME, "calibration": "default", "commit": _commit(), "envs": {}}
    for env_id in env_ids:
        out["envs"][env_id] = {}
        for spec in controllers:
            fig = out["envs"][env_id][spec] = controller_figures(env_id, spec)
            print(
                f"{env_id} {spec}: success {fig['success_rate']:.0%}, tracking RMSE "
                f"{fig['tracking_rmse_rad_s']:.3f} rad/s, per shell {fig['per_shell']}",
                flush=True,
            )
    out["runtime_s"] = time.time() - t0
    return out


def main(argv: Sequence[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=OUT, help="the results JSON")
    args = p.parse_args(argv)
    res = study()
    write_text_atomic(args.out, json.dumps(res, indent=1) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
