"""The paper's uncontrolled ramp descent (§IV) on the twin: one run per shell model and pressure.

python -m evaluation.experiments.uncontrolled_descent [--pressures 3 4.6 14] [--replay out/ramp.html]
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sphere_env.params import SHELL_MODELS
from sphere_env.physics import InitialState, Twin, TwinConfig, start_meshcat
from sphere_env.reporting import markdown_table

CHUNK_S = 0.02


@dataclass
class Descent:
    """Time series of one zero-torque descent (SI units) and whether each sample is on the ramp."""

    shell_model: str
    pressure_kpa: float
    t_s: np.ndarray
    omega_d: np.ndarray
    on_ramp: np.ndarray
    x_m: np.ndarray


def descend(
    shell_model: str,
    pressure_kpa: float | None,
    incline_deg: float = 16.0,
    ramp_length_m: float = 4.0,
    seconds: float = 5.0,
    twin: Twin | None = None,
) -> Descent:
    twin = twin or Twin(TwinConfig(shell_model=shell_model, incline_deg=incline_deg, ramp_length_m=ramp_length_m))
    twin.reset(InitialState(), pressure_kpa=pressure_kpa)
    x_end = float(twin.terrain.ramp_end_W[0])
    ts, wd, xs = [], [], []
    for _ in range(int(round(seconds / CHUNK_S))):
        twin.advance(CHUNK_S)
        s = twin.state()
        ts.append(s.time_s)
        wd.append(s.omega_d)
        xs.append(s.position_m[0])
    xs = np.array(xs)
    return Descent(shell_model, twin.pressure_kpa, np.array(ts), np.array(wd), xs < x_end, xs)


def summary_rows(pressures: list[float | None], seconds: float = 5.0) -> list[dict]:
    rows = []
    for model in SHELL_MODELS:
        twin = Twin(TwinConfig(shell_model=model, incline_deg=16.0, ramp_length_m=4.0))
        for p in pressures:
            d = descend(model, p, seconds=seconds, twin=twin)
            on = d.on_ramp
            t_exit = float(d.t_s[~on][0]) if (~on).any() else float("nan")
            rows.append(
                dict(
                    shell_model=model,
                    pressure_kpa=d.pressure_kpa,
                    mean_omega_d=float(d.omega_d[on].mean()),
                    peak_omega_d=float(d.omega_d.max()),
                    t_exit_s=t_exit,
                    x_final_m=float(d.x_m[-1]),
                )
            )
    return rows


COLUMNS = [
    ("shell_model", "shell model", ""),
    ("pressure_kpa", "pressure kPa", "{:.1f}"),
    ("mean_omega_d", "mean ω_d on ramp rad/s", "{:.2f}"),
    ("peak_omega_d", "peak ω_d rad/s", "{:.2f}"),
    ("t_exit_s", "time to run-out s", "{:.2f}"),
    ("x_final_m", "x after 5 s m", "{:.2f}"),
]


def save_replay(path: Path, shell_model: str = "hydroelastic", pressure_kpa: float | None = None) -> Path:
    twin = Twin(TwinConfig(shell_model=shell_model, incline_deg=16.0, ramp_length_m=4.0), meshcat=start_meshcat())
    twin.reset(InitialState(), pressure_kpa=pressure_kpa)
    twin.start_recording()
    for _ in range(200):
        twin.advance(CHUNK_S)
    return twin.save_recording(path)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument(
        "--pressures",
        type=float,
        nargs="+",
        default=None,
        help="gauge pressures in kPa (default: low end, nominal, high end of the calibration)",
    )
    parser.add_argument("--replay", type=Path, default=Path("out/ramp_descent.html"))
    args = parser.parse_args(argv)
    from sphere_env.models.shell import ShellCalibration

    cal = ShellCalibration.load()
    pressures = args.pressures or [cal.pressure_range_kpa[0], cal.nominal_pressure_kpa, cal.pressure_range_kpa[1]]
    print("Zero-torque descent of the 16° ramp (4 m, then flat), Majd friction on both joints:\n")
    print(markdown_table(summary_rows(pressures), COLUMNS))
    path = save_replay(args.replay)
    print(f"\nMeshcat replay (hydroelastic, nominal pressure): {path.resolve()}")


if __name__ == "__main__":
    main()
