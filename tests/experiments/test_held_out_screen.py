"""The validation screen of held_out: names checked before any episode, figures on the validation
set cached where the run keeps them."""

from __future__ import annotations

import json

import pytest

from sphere_env.evaluation.experiments.held_out import screen, screen_cache


@pytest.mark.parametrize(
    "kwargs, needle",
    [
        ({"faults": ["friction_lower"]}, "field 'faults[0]' = 'friction_lower': not a fault"),
        ({"calibrations": ["nominal"]}, "field 'calibrations[0]' = 'nominal': not a shipped calibration"),
    ],
)
def test_a_bad_name_is_refused_before_any_episode(tmp_path, kwargs, needle):
    with pytest.raises(ValueError, match="allowed") as err:
        screen(["zero"], **{"faults": [], "calibrations": [], **kwargs}, runs_root=tmp_path)
    assert needle in str(err.value)
    assert not any(tmp_path.iterdir())


def test_zero_torque_is_screened_on_the_validation_set_under_a_fault(tmp_path):
    """Zero torque under the drive joint's friction x 0.5: the validation set's 27 episodes, each
    shell's share, cached as a whole file that a second call reads back unchanged."""
    out = screen(["zero"], faults=["friction_drive_50pct"], calibrations=[], runs_root=tmp_path)
    fig = out["zero"]["friction_drive_50pct"]
    assert fig["set"] == "validation" and fig["episodes"] == 27
    assert set(fig["per_shell"]) == {"point", "injected", "hydroelastic"}
    assert 0.0 <= fig["success_rate"] <= 1.0
    cached = json.loads((screen_cache("zero", tmp_path) / "validation_friction_drive_50pct.json").read_text())
    assert cached["success_rate"] == fig["success_rate"] and len(cached["episodes_detail"]) == 27
    assert screen(["zero"], faults=["friction_drive_50pct"], calibrations=[], runs_root=tmp_path) == out
