"""The randomization spec's schema (pure Python, no Drake): every refusal names the field's path,
its value and what is allowed; what it accepts becomes the same spec however it is written."""

import re

import numpy as np
import pytest

from sphere_env.params import ParameterSpace
from sphere_env.tasks.randomization import RandomizationSpec


@pytest.mark.parametrize(
    "spec, message",
    [
        # a string or a bool is never a number, at any depth
        ({"ground_friction": "1.0"}, "field 'ground_friction' = '1.0': Input should be a valid number"),
        ({"ground_friction": True}, "field 'ground_friction' = True: Input should be a valid number"),
        ({"ground_friction": {"low": "0.5", "high": 1.0}}, "field 'ground_friction.low' = '0.5'"),
        (
            {"ground_friction": {"distribution": "normal", "mean": 1.0, "std": False}},
            "field 'ground_friction.std' = False",
        ),
        (
            {"payload_mass_kg": {"distribution": "choice", "values": [1.0, "2"]}},
            "field 'payload_mass_kg.values[1]' = '2'",
        ),
        ({"payload_com_offset_m": [0.0, True, 0.0]}, "field 'payload_com_offset_m[1]' = True"),
        (
            {"ground_friction": {"low": 0.5, "high": 1.0, "mode": "interval", "interval_s": "1"}},
            "field 'ground_friction.interval_s' = '1'",
        ),
        ({"pressure_schedule": {"rate_kpa_per_s": -0.1, "delay_s": "2"}}, "field 'pressure_schedule.delay_s' = '2'"),
        ({"action_latency_steps": np.bool_(True)}, "field 'action_latency_steps' = True"),
        # a field the distribution does not use, or a mode field without its mode
        (
            {"ground_friction": {"distribution": "fixed", "value": 1.0, "low": 0.5}},
            "field 'ground_friction.low' is not used by distribution 'fixed'; allowed: ['delay_s', 'distribution', "
            "'interval_s', 'mode', 'rate_per_s', 'value']",
        ),
        (
            {"ground_friction": {"distribution": "uniform", "low": 0.5, "high": 1.0, "value": 0.8}},
            "field 'ground_friction.value' is not used by distribution 'uniform'",
        ),
        (
            {"ground_friction": {"low": 0.5, "high": 1.0, "value": 0.8}},
            "field 'ground_friction.distribution' is missing: the fields given belong to ['fixed', 'uniform']",
        ),
        (
            {"ground_friction": {"value": 1.0, "interval_s": 2.0}},
            "field 'ground_friction.interval_s' = 2.0 is only for mode 'interval'",
        ),
        (
            {"pressure_schedule": {"rate_kpa_per_s": {"value": -0.1, "mode": "interval", "interval_s": 1.0}}},
            "unknown field 'pressure_schedule.rate_kpa_per_s.mode'",
        ),
        # bounds and categorical names from the parameter registry
        (
            {"ground_friction": 2.0},
            "field 'ground_friction' = 2.0: Input should be less than 2; allowed: a finite number within (0, 2)",
        ),
        (
            {"action_latency_steps": {"distribution": "choice", "values": [0, 1.5]}},
            "field 'action_latency_steps.values[1]' = 1.5: Input should be a valid integer",
        ),
        (
            {"payload_com_offset_m": {"low": [0.0] * 3, "high": [0.0, 0.0, 0.5]}},
            "field 'payload_com_offset_m.high[2]' = 0.5: Input should be less than or equal to 0.3",
        ),
        (
            {"shell_model": {"distribution": "choice", "values": ["point", "rubber"]}},
            "field 'shell_model.values[1]' = 'rubber': Input should be 'point', 'injected' or 'hydroelastic'",
        ),
        (
            {"shell_model": {"value": "point", "mode": "interval", "interval_s": 1.0}},
            "field 'shell_model.mode' = 'interval': Input should be 'reset'; allowed: ['reset'] (shell_model changes only "
            "between episodes)",
        ),
        # what the input is, when it is no spec at all
        (3.5, "value 3.5 (float) is not a spec; allowed: None, a preset name ['off', 'default', 'full']"),
        ({"ground_friction": {}}, "field 'ground_friction.value' is missing: 'fixed' needs it"),
    ],
)
def test_refusals_name_the_path_the_value_and_what_is_allowed(spec, message):
    with pytest.raises(ValueError, match="^randomization: .*" + re.escape(message)):
        RandomizationSpec.parse(spec)


def test_without_a_ramp_the_incline_is_fixed_or_refused():
    with pytest.raises(
        ValueError,
        match=re.escape("randomization: field 'incline_deg.distribution' = 'uniform': this environment has no ramp"),
    ):
        RandomizationSpec.parse({"incline_deg": [10.0, 20.0]}, ramp=False)
    assert RandomizationSpec.parse({"incline_deg": 10.0}, ramp=False).terms[0].distribution.value == 10.0
    assert "incline_deg" not in {t.parameter for t in RandomizationSpec.parse("full", ramp=False).terms}


def test_the_kwarg_names_the_error():
    with pytest.raises(ValueError, match=r"^options: field 'ground_friction' = 5\.0"):
        RandomizationSpec.parse({"ground_friction": 5.0}, kwarg="options")


def test_spec_objects_are_checked_where_they_are_built_and_for_the_env_at_hand():
    with pytest.raises(ValueError, match=r"mode"):
        RandomizationSpec(ground_friction={"value": 1.0, "mode": "often"})
    with pytest.raises(ValueError, match=r"pressure_schedule"):
        RandomizationSpec(pressure_schedule=5)
    ramp = RandomizationSpec.parse({"incline_deg": [10.0, 20.0]})
    with pytest.raises(ValueError, match=re.escape("field 'incline_deg.distribution' = 'uniform': this environment")):
        RandomizationSpec.parse(ramp, ramp=False)
    for spec in (
        "off",
        "default",
        "full",
        {
            "shell_model": ["point", "injected"],
            "action_latency_steps": [0, 2],
            "ground_friction": {
                "distribution": "normal",
                "mean": 1.0,
                "std": 0.1,
                "mode": "interval",
                "interval_s": 0.5,
            },
        },
    ):
        parsed = RandomizationSpec.parse(spec)
        assert RandomizationSpec.parse(parsed) == parsed  # an env's copies re-parse the spec they hold
        resolved = parsed.resolved(ParameterSpace.for_calibration(3.0, 14.0))
        assert RandomizationSpec.parse(resolved) == resolved


def test_equivalent_forms_give_the_same_spec():
    short = RandomizationSpec.parse(
        {
            "ground_friction": [0.8, 1.2],
            "payload_com_offset_m": (0.01, 0.0, 0.0),
            "action_latency_steps": np.int64(2),
            "shell_model": ["point", "injected"],
        }
    )
    full = RandomizationSpec.parse(
        {
            "ground_friction": {"distribution": "uniform", "low": 0.8, "high": 1.2},
            "payload_com_offset_m": {"value": np.array([0.01, 0.0, 0.0])},
            "action_latency_steps": {"distribution": "fixed", "value": 2.0},
            "shell_model": {"values": ["point", "injected"]},
        }
    )
    assert short == full
    assert full.terms[1].distribution.value == (0.01, 0.0, 0.0)
    normal = RandomizationSpec.parse({"ground_friction": {"mean": 1.0, "std": 0.1}}).terms[0].distribution
    # the distribution whose fields are given
    assert normal.as_data() == {"distribution": "normal", "mean": 1.0, "std": 0.1, "mode": "reset"}


def test_terms_keep_the_preset_order_then_the_mapping_order():
    """Terms are drawn in order: an entry replaces the preset's in its place, new ones follow as given."""
    spec = RandomizationSpec.parse(
        {"base": "full", "shell_model": "point", "ground_friction": 1.0, "pressure_schedule": None}
    )
    assert [t.parameter for t in spec.terms] == [
        "pressure_kpa",
        "steer_friction_scale",
        "drive_friction_scale",
        "ground_friction",
        "payload_mass_kg",
        "payload_com_offset_m",
        "incline_deg",
        "shell_model",
    ]
    assert spec.terms[3].distribution.as_data() == {"distribution": "fixed", "value": 1.0, "mode": "reset"}
    assert spec.pressure_schedule is None
    assert RandomizationSpec.parse("full").pressure_schedule.as_data() == {
        "rate_kpa_per_s": {"distribution": "uniform", "low": -0.2, "high": 0.0},
        "delay_s": 0.0,
    }
