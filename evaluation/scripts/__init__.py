"""Command-line studies whose reports are committed under ``evaluation/results/``.

    python -m evaluation.scripts.benchmark            # make bench
    python -m evaluation.scripts.benchmark_env
    python -m evaluation.scripts.benchmark_train
    python -m evaluation.scripts.robustness
    python -m evaluation.scripts.timestep_study
    python -m evaluation.scripts.uncontrolled_descent
"""
