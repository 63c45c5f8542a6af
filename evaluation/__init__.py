"""Evaluation, benchmarks and the main demo job of sphere_env."""
