"""Interval estimates over training seeds with whole runs as the samples, shared by the learning
study's summary and its randomization study.

A run's score on a set of episodes is one number: the mean over its episodes (a success rate). One
policy is scored on every shell and under every fault, so its per-shell or per-fault scores move
together; a bootstrap that resampled the runs of each shell or fault on its own (rliable's
stratified bootstrap with shells or faults as tasks) would combine scores of different runs and
give intervals narrower than the runs allow. Every bootstrap here resamples whole runs:

- :func:`interval_estimates`: rliable's interquartile mean (IQM) and mean with 95 % percentile
  intervals (Agarwal et al., 2021), each run's score as the single task of rliable's stratified
  bootstrap, which with one task is the plain bootstrap over runs;
- :func:`bootstrap_runs`: any statistic of two conditions' runs with arch's bootstrap (the library
  rliable's is built on): paired where both conditions ran the same seeds (a resampled seed draws
  that seed's run of each condition), else each condition's runs resampled on their own. Every
  output of the statistic (a difference over the whole grid and one per shell or fault) is
  computed on the same resampled runs.

Every bootstrap draws from a fixed seed, so the figures are the same on every rebuild.
"""

from __future__ import annotations

import math
import zlib
from typing import Callable, Mapping

import numpy as np

SHELLS = ("point", "injected", "hydroelastic")
BOOTSTRAP_REPS = 2000
CONFIDENCE = 0.95


def run_scores(task_scores: np.ndarray, episodes: np.ndarray) -> np.ndarray:
    """Each run's score as one number, the mean over its episodes: the success rates of its tasks
    (runs × tasks) weighted by each task's number of episodes."""
    task_scores, episodes = np.asarray(task_scores, dtype=float), np.asarray(episodes, dtype=float)
    if task_scores.ndim != 2 or task_scores.shape[1] != len(episodes):
        raise ValueError(
            f"task_scores: shape {task_scores.shape}; allowed: runs × {len(episodes)} tasks (one per episode count)"
        )
    return task_scores @ episodes / episodes.sum()


def interval_estimates(scores: Mapping[str, np.ndarray], seed: int = 0) -> dict[str, dict[str, list[float] | float]]:
    """rliable's IQM and mean with 95 % percentile-bootstrap intervals over whole runs, per key of
    ``scores`` (each a vector of one score per run). Each key's bootstrap has its own stream, seeded
    from ``seed`` and the key, so one recipe's interval does not move when another recipe gains runs."""
    from rliable import library as rly
    from rliable import metrics

    def agg(x: np.ndarray) -> np.ndarray:
        return np.array([metrics.aggregate_iqm(x), metrics.aggregate_mean(x)])

    out = {}
    for k, x in scores.items():
        x = np.asarray(x, dtype=float)
        if x.ndim != 1 or len(x) == 0:
            raise ValueError(f"scores[{k!r}]: shape {x.shape}; allowed: one score per run, a non-empty 1-D array")
        np.random.seed((seed + zlib.crc32(str(k).encode())) % 2**32)  # rliable draws from numpy's global generator
        point, ci = rly.get_interval_estimates(
            {k: x[:, None]}, agg, reps=BOOTSTRAP_REPS, confidence_interval_size=CONFIDENCE
        )
        out[k] = {
            "iqm": float(point[k][0]),
            "iqm_ci": [float(ci[k][0, 0]), float(ci[k][1, 0])],
            "mean": float(point[k][1]),
            "mean_ci": [float(ci[k][0, 1]), float(ci[k][1, 1])],
        }
    return out


def bootstrap_runs(
    a: np.ndarray,
    b: np.ndarray,
    statistic: Callable[[np.ndarray, np.ndarray], np.ndarray],
    paired: bool,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """``statistic(a, b)`` (a vector) and its 95 % percentile-bootstrap interval (2 × outputs: lower
    row, upper row), resampling whole runs, the rows of ``a`` and ``b``: ``paired`` (row i of both
    is the same training seed) draws one set of seeds for both, else each is resampled on its own."""
    from arch.bootstrap import IIDBootstrap, IndependentSamplesBootstrap

    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if paired and len(a) != len(b):
        raise ValueError(f"paired: {len(a)} runs against {len(b)}; allowed: the same seeds on both sides")
    bs = (IIDBootstrap if paired else IndependentSamplesBootstrap)(a, b, seed=seed)
    ci = bs.conf_int(statistic, reps=BOOTSTRAP_REPS, method="percentile", size=CONFIDENCE)
    return np.asarray(statistic(a, b), dtype=float), np.asarray(ci, dtype=float)


def pct(x: float | None) -> str:
    """A success rate as a whole percentage; a dash where there is none."""
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{100 * x:.0f}%"
