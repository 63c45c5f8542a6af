"""rliable's interval estimates over training seeds, shared by the learning study's summary and
its randomization study: the interquartile mean (IQM) and the mean with 95 % stratified-bootstrap
intervals (Agarwal et al., 2021), a run's scores being its success rates on the tasks (the shell
models, or the faults of the fault grid)."""

from __future__ import annotations

import math
import zlib
from typing import Mapping

import numpy as np

SHELLS = ("point", "injected", "hydroelastic")
BOOTSTRAP_REPS = 2000


def interval_estimates(scores: Mapping[str, np.ndarray], seed: int = 0) -> dict[str, dict[str, list[float]]]:
    """rliable's IQM and mean with 95 % stratified-bootstrap intervals, per key of ``scores``
    (each a runs × tasks array). Each key's bootstrap has its own stream, seeded from ``seed`` and
    the key, so one recipe's interval does not move when another recipe gains runs."""
    from rliable import library as rly
    from rliable import metrics

    def agg(x: np.ndarray) -> np.ndarray:
        return np.array([metrics.aggregate_iqm(x), metrics.aggregate_mean(x)])

    out = {}
    for k, x in scores.items():
        np.random.seed((seed + zlib.crc32(str(k).encode())) % 2**32)  # rliable draws from numpy's global generator
        point, ci = rly.get_interval_estimates({k: x}, agg, reps=BOOTSTRAP_REPS)
        out[k] = {
            "iqm": float(point[k][0]),
            "iqm_ci": [float(ci[k][0, 0]), float(ci[k][1, 0])],
            "mean": float(point[k][1]),
            "mean_ci": [float(ci[k][0, 1]), float(ci[k][1, 1])],
        }
    return out


def pct(x: float | None) -> str:
    """A success rate as a whole percentage; a dash where there is none."""
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{100 * x:.0f}%"
