"""Experiments apart from the product: benchmarks and studies, each a script over the public API
that writes its results file under ``evaluation/results/``. No product module imports them.

    python -m evaluation.experiments.benchmark            # make bench
    python -m evaluation.experiments.benchmark_env
    python -m evaluation.experiments.benchmark_train
    python -m evaluation.experiments.command_span
    python -m evaluation.experiments.hydro_tradeoff
    python -m evaluation.experiments.learning run --recipe NAME --seeds 0 1 2 3 4
    python -m evaluation.experiments.learning summary
    python -m evaluation.experiments.log_noise
    python -m evaluation.experiments.robustness
    python -m evaluation.experiments.timestep_study
    python -m evaluation.experiments.tune_pd
    python -m evaluation.experiments.uncontrolled_descent
"""

from pathlib import Path

#: The committed results folder the studies write (``evaluation/results``; in a checkout only).
RESULTS = Path(__file__).resolve().parents[1] / "results"
