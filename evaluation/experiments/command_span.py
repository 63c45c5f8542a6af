"""The drive speeds the twin can hold on the RampDescent-v2 ramp: what ω_ref may ask for.

For each shell model and pressure, on the v2 incline (8°) with a long ramp and a wide lane:

* zero torque: the mean ω_d between 3 and 6 s (the rolling resistance of a soft shell settles it;
  a rigid point contact keeps accelerating), and when the robot leaves the v2 lane (|y| > 1 m);
* the PD baseline commanded a constant ω_ref from 0.5 to 7 rad/s: the speeds it holds, i.e. the
  mean |ω_d − ω_ref| between 3 and 8 s is below ``--hold-tolerance`` (0.25 rad/s).

    python -m evaluation.experiments.command_span [--out evaluation/results/command_span.md]

"Held" is what the shipped PD baseline achieves, a lower bound of what the physics allows.
``tests/tasks/test_ramp_descent.py`` checks on the twin that the PD tracks, and zero torque misses,
a profile inside RampDescent-v2's ``omega_ref_range_rad_s``.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from sphere_env.files import write_text_atomic
from sphere_env.params import SHELL_MODELS

ENV_ID = "sphere_env/RampDescent-v2"
REFS_RAD_S = tuple(np.round(np.arange(0.5, 7.01, 0.5), 2))
PRESSURES_KPA = (3.0, 8.5, 14.0)


def held_error(
    shell_model: str, pressure_kpa: float, omega_ref: float | None, seconds: float = 8.0, lane_half_width_m: float = 1.0
) -> dict[str, float]:
    """One constant-command run on a 20 m ramp with a 9 m lane: mean ω_d over [3, 6] s, mean |ω_d −
    ω_ref| over [3, ``seconds``] s (PD; NaN for zero torque) and the time the robot first leaves a
    lane of ``lane_half_width_m`` [s] (NaN if never)."""
    import gymnasium as gym

    import sphere_env  # noqa: F401
    from sphere_env.controllers import controller_for

    steps = int(round(seconds * 50))
    env = gym.make(
        ENV_ID,
        shell_model=shell_model,
        ramp_length_m=20.0,
        lane_half_width_m=9.0,
        randomization={"pressure_kpa": pressure_kpa},
        omega_ref_change_min_rad_s=None,
        max_episode_steps=steps,
    )
    ctrl = controller_for(env, "zero" if omega_ref is None else "pd")
    ctrl.reset()
    obs, info = env.reset(seed=0, options={} if omega_ref is None else {"omega_ref": omega_ref})
    t, w, y = [], [], []
    for _ in range(steps):
        obs, _, terminated, truncated, info = env.step(ctrl(obs, info))
        if "omega_d" not in info:  # a physics failure ends the run
            break
        t.append(info["time_s"])
        w.append(info["omega_d"])
        y.append(info["position_m"][1])
        if terminated or truncated:
            break
    env.close()
    t, w, y = np.array(t), np.array(w), np.array(y)
    sel = (t >= 3.0) & (t <= 6.0)
    late = t >= 3.0
    out_of_lane = np.flatnonzero(np.abs(y) > lane_half_width_m)
    return {
        "mean_omega_d_rad_s": float(np.mean(w[sel])) if sel.any() else math.nan,
        "hold_error_rad_s": (
            float(np.mean(np.abs(w[late] - omega_ref))) if omega_ref is not None and late.any() else math.nan
        ),
        "leaves_lane_s": float(t[out_of_lane[0]]) if len(out_of_lane) else math.nan,
    }


def span_rows(
    shell_models=SHELL_MODELS, pressures=PRESSURES_KPA, refs=REFS_RAD_S, hold_tolerance_rad_s: float = 0.25
) -> list[dict]:
    rows = []
    for shell in shell_models:
        for p in pressures:
            zero = held_error(shell, p, None)
            held = [r for r in refs if held_error(shell, p, float(r))["hold_error_rad_s"] < hold_tolerance_rad_s]
            rows.append(
                {
                    "shell_model": shell,
                    "pressure_kpa": p,
                    "zero_mean_omega_d_rad_s": zero["mean_omega_d_rad_s"],
                    "zero_leaves_lane_s": zero["leaves_lane_s"],
                    "held_min_rad_s": min(held) if held else math.nan,
                    "held_max_rad_s": max(held) if held else math.nan,
                    "held": " ".join(f"{r:g}" for r in held),
                }
            )
    return rows


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=None, help="Markdown table to write (default: print only)")
    parser.add_argument("--hold-tolerance", type=float, default=0.25, help="rad/s")
    args = parser.parse_args(argv)
    if not (math.isfinite(args.hold_tolerance) and args.hold_tolerance > 0):
        parser.error(f"--hold-tolerance: value {args.hold_tolerance} must be > 0 rad/s")
    from sphere_env.provenance import machine_info
    from sphere_env.reporting import markdown_table

    rows = span_rows(hold_tolerance_rad_s=args.hold_tolerance)
    cols = [
        ("shell_model", "shell model", ""),
        ("pressure_kpa", "pressure kPa", "{:g}"),
        ("zero_mean_omega_d_rad_s", "zero torque: ω_d 3–6 s rad/s", "{:.2f}"),
        ("zero_leaves_lane_s", "zero torque: leaves 1 m lane at s", "{:.1f}"),
        ("held_min_rad_s", "PD holds from rad/s", "{:g}"),
        ("held_max_rad_s", "PD holds up to rad/s", "{:g}"),
        ("held", "ω_ref held (of 0.5…7)", ""),
    ]
    text = "\n".join(
        [
            "# What ω_ref the twin can hold on the RampDescent-v2 ramp (8°)",
            "",
            f"`python -m evaluation.experiments.command_span`; commit {machine_info()['commit']}. A command is held when "
            f"the PD baseline keeps the mean |ω_d − ω_ref| over 3–8 s below {args.hold_tolerance:g} rad/s (20 m ramp, "
            "9 m lane); what the PD holds is a lower bound of what the physics allows. Zero torque: mean ω_d "
            "over 3–6 s; nan = does not leave the lane within 8 s.",
            "",
            markdown_table(rows, cols),
            "",
        ]
    )
    print(text)
    if args.out is not None:
        write_text_atomic(args.out, text)
    return rows


if __name__ == "__main__":
    main()
