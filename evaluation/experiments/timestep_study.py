"""Plant time-step accuracy study against a 0.5 ms reference.

Writes ``evaluation/results/timestep_study.{md,json}``. For each shell model and time step it runs
  * ramp: 6 s from rest down the 16° ramp (4 m, flat run-out), Majd friction on both joints:
    RMSE of ω_d against the reference, relative to the reference's peak |ω_d|;
  * rock: locked-steer free decay from φ = 0.05 rad: ω_n and ζ relative errors;
and for the stand fixture (Majd steer friction, θ0 = 0.4 rad) the θ RMSE against the reference.

    python -m evaluation.experiments.timestep_study [--steps-ms 0.5 1 2 5 10]
"""

from __future__ import annotations

import argparse
import json
from datetime import datetime, timezone

import numpy as np

from sphere_env.analysis.decay import fit_free_decay
from sphere_env.evaluation.experiments import RESULTS
from sphere_env.files import write_text_atomic
from sphere_env.params import SHELL_MODELS
from sphere_env.physics import InitialState, Twin, TwinConfig
from sphere_env.provenance import machine_info
from sphere_env.reporting import markdown_table

CHUNK_S = 0.02


def trace(config: TwinConfig, initial: InitialState, seconds: float, field: str) -> np.ndarray:
    twin = Twin(config)
    twin.reset(initial)
    out = []
    for _ in range(int(round(seconds / CHUNK_S))):
        twin.advance(CHUNK_S)
        out.append(getattr(twin.state(), field))
    return np.array(out)


def study(steps_s: list[float]) -> list[dict]:
    ref_dt = min(steps_s)
    rows = []
    for model in SHELL_MODELS:
        ramp = {
            dt: trace(
                TwinConfig(shell_model=model, incline_deg=16, ramp_length_m=4.0, time_step_s=dt),
                InitialState(),
                6.0,
                "omega_d",
            )
            for dt in steps_s
        }
        rock = {}
        for dt in steps_s:
            phi = trace(
                TwinConfig(fixture="locked_steer", shell_model=model, time_step_s=dt),
                InitialState(roll=0.05),
                6.0,
                "phi",
            )
            rock[dt] = fit_free_decay(CHUNK_S * np.arange(1, len(phi) + 1), phi)
        for dt in steps_s:
            err = ramp[dt] - ramp[ref_dt]
            rows.append(
                dict(
                    case=model,
                    dt_ms=dt * 1e3,
                    ramp_omega_d_rmse_pct=100 * np.sqrt(np.mean(err**2)) / np.max(np.abs(ramp[ref_dt])),
                    rock_omega_n_err_pct=100 * (rock[dt].omega_n / rock[ref_dt].omega_n - 1),
                    rock_zeta_err_pct=100 * (rock[dt].zeta / rock[ref_dt].zeta - 1) if rock[ref_dt].zeta > 1e-3 else "",
                )
            )
    stand = {
        dt: trace(TwinConfig(fixture="stand", time_step_s=dt), InitialState(theta=0.4), 5.0, "theta") for dt in steps_s
    }
    for dt in steps_s:
        rows.append(
            dict(
                case="stand (majd steer)",
                dt_ms=dt * 1e3,
                stand_theta_rmse_rad=float(np.sqrt(np.mean((stand[dt] - stand[ref_dt]) ** 2))),
            )
        )
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps-ms", type=float, nargs="+", default=[0.5, 1.0, 2.0, 5.0, 10.0])
    args = parser.parse_args(argv)
    rows = study([s * 1e-3 for s in args.steps_ms])
    info = machine_info()
    cols = [
        ("case", "model", ""),
        ("dt_ms", "step ms", "{:g}"),
        ("ramp_omega_d_rmse_pct", "ramp ω_d RMSE % of peak", "{:.2f}"),
        ("rock_omega_n_err_pct", "rock ω_n err %", "{:+.2f}"),
        ("rock_zeta_err_pct", "rock ζ err %", "{:+.1f}"),
        ("stand_theta_rmse_rad", "stand θ RMSE rad", "{:.4f}"),
    ]
    text = "\n".join(
        [
            "# Plant time-step study",
            "",
            f"Generated {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC "
            f"by `python -m evaluation.experiments.timestep_study` "
            f"(commit {info['commit']}, drake {info['drake']}). Reference: the {min(args.steps_ms):g} ms run of the same case.",
            "",
            markdown_table(rows, cols),
            "",
        ]
    )
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "timestep_study.md").write_text(text)
    write_text_atomic(
        RESULTS / "timestep_study.json",
        json.dumps({"machine": info, "reference_ms": min(args.steps_ms), "rows": rows}, indent=2, default=float) + "\n",
    )
    print(text)


if __name__ == "__main__":
    main()
