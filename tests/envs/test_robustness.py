"""Short versions of evaluation/experiments/robustness.py (the full run: 1e5 fuzzed steps, 2e5-step soak)."""

import pytest

from sphere_env.evaluation.experiments.robustness import fuzz, soak


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


def test_hostile_input_tally_can_tell_the_outcomes_apart():
    """The classifier itself: each outcome is reachable, so zero counts mean something."""
    from sphere_env.evaluation.experiments.robustness import Tally

    tally = Tally()

    def bad_value():
        raise ValueError("pressure_kpa: value 99 outside allowed [3, 14] kPa")

    def bad_type():
        raise TypeError("unsupported operand")

    assert tally.expect("g", "named", bad_value, "pressure_kpa")
    assert not tally.expect("g", "unnamed", bad_value, "omega_ref")
    assert not tally.expect("g", "type", bad_type, "pressure_kpa")
    assert not tally.expect("g", "accepted", lambda: None, "pressure_kpa")
    assert tally.counts["g"] == {"clear_error": 1, "other_exception": 2, "silent_acceptance": 1}
