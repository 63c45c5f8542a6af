"""Sensor noise of the real logs: the high-frequency residual of every channel.

Each channel of each CSV under the log folder (default ``../shared/data/roboball`` beside the
repository) minus its Savitzky–Golay smooth (window 15 samples, cubic: about 0.15 s at 100 Hz, far
shorter than any rocking period) leaves the sensor noise and the fastest dynamics; its robust σ
(1.4826 × the median absolute deviation) bounds the noise from above. The fault grid's sensor-noise
fault is compared with these numbers (``evaluation/faults.py``).

    python -m evaluation.experiments.log_noise [--logs DIR]   # -> evaluation/results/log_noise.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from sphere_env.files import write_text_atomic

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
LOGS = REPO.parent / "shared" / "data" / "roboball"
OUT = HERE.parent / "results" / "log_noise.json"
WINDOW, ORDER = 15, 3


def residual_sigma(x: np.ndarray) -> float:
    from scipy.signal import savgol_filter

    r = x - savgol_filter(x, WINDOW, ORDER)
    return float(1.4826 * np.median(np.abs(r - np.median(r))))


def measure(logs: Path) -> dict:
    import pandas as pd

    from sphere_env.tasks.observation import DEFAULT_NOISE_STD, MEASURED_COMPONENTS

    files = sorted(logs.rglob("*.csv"))
    if not files:
        raise SystemExit(f"--logs: no CSV logs under {logs}")
    per_file, pos, vel = {}, [], []
    for f in files:
        d = pd.read_csv(f)
        sig = {c: residual_sigma(d[c].to_numpy(float)) for c in d.columns if c != "timestamp" and len(d) > WINDOW}
        per_file[str(f.relative_to(logs))] = sig
        for c, v in sig.items():
            if v > 0.0:  # an idle channel (a still drive) has no noise to measure
                (pos if c.endswith(".position") else vel).append(v)
    units = {c[0]: c[1] for c in MEASURED_COMPONENTS}
    default = dict(zip(units, DEFAULT_NOISE_STD.tolist()))
    return {
        "method": f"robust sigma of x - savgol(x, {WINDOW}, {ORDER}), channels with any residual",
        "angles_rad": {"median": float(np.median(pos)), "max": float(np.max(pos))},
        "rates_rad_s": {"median": float(np.median(vel)), "max": float(np.max(vel))},
        "default_noise_std": default,
        "per_file": per_file,
    }


def main(argv=None) -> None:
    p = argparse.ArgumentParser(
        prog="python -m evaluation.experiments.log_noise",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--logs", type=Path, default=LOGS)
    args = p.parse_args(argv)
    out = measure(args.logs)
    write_text_atomic(OUT, json.dumps(out, indent=1) + "\n")
    print(f"angles {out['angles_rad']}, rates {out['rates_rad_s']} -> {OUT}")


if __name__ == "__main__":
    main()
