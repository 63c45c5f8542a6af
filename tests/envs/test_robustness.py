"""Short versions of evaluation/scripts/robustness.py (the full run: 1e5 fuzzed steps, 2e5-step soak)."""

import pytest

from sphere_env.evaluation.scripts.robustness import fuzz, soak


@pytest.mark.slow
@pytest.mark.parametrize("env_id, shell_model", [("sphere_env/RampDescent-v0", "injected"),
                                                 ("sphere_env/Roll-v0", "point")])
def test_fuzzed_actions_never_crash(env_id, shell_model):
    row = fuzz(env_id, shell_model, steps=1500, seed=1)
    assert row["unexpected"] == 0, row["unexpected_examples"]
    assert row["nan_inf_raised"] == row["nan_inf_sent"] > 0
    assert row["non_finite_outputs"] == 0


@pytest.mark.slow
def test_soak_memory_is_bounded():
    result = soak(steps=8_000, sample_every=2_000)
    assert result["growth_after_first_sample_mb"] <= 10.0, result
    assert result["growth_from_build_mb"] <= 50.0, result
