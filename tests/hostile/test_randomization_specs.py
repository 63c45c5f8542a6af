"""Randomization specs and command options that numpy could not sample or that lie outside the
allowed ranges are refused with an error naming the field (pure Python, no Drake)."""

import math
import re

import pytest

from sphere_env.envs.kwargs import reset_options
from sphere_env.schemas import validate
from sphere_env.tasks import RampDescentTask, RollTask
from sphere_env.tasks.randomization import RandomizationSpec


@pytest.mark.parametrize(
    "rate, field",
    [
        ([0.1, -0.1], "low"),  # inverted uniform range
        ({"distribution": "normal", "mean": 0.0, "std": -1.0}, "std"),
        ({"distribution": "uniform"}, "uniform needs both"),
        ({"distribution": "uniform", "low": -0.1}, "uniform needs both"),
        ({"distribution": "choice", "values": []}, "values"),
        ({"distribution": "choice", "values": 3}, "values"),
        ({"distribution": "fixed", "value": float("nan")}, "finite number"),
        ({"distribution": "poisson"}, "distribution"),
    ],
)
def test_bad_pressure_schedule_distributions_are_refused(rate, field):
    with pytest.raises(ValueError, match="pressure_schedule.rate_kpa_per_s") as err:
        RandomizationSpec.parse({"pressure_schedule": {"rate_kpa_per_s": rate}})
    assert field in str(err.value)


def test_schedule_mappings_are_validated_in_full():
    bad = {"pressure_schedule": {"rate_kpa_per_s": {"distribution": "uniform", "low": 0.2, "high": -0.2}}}
    with pytest.raises(
        ValueError,
        match=re.escape(
            "field 'pressure_schedule.rate_kpa_per_s' = {'distribution': 'uniform', 'low': 0.2, 'high': -0.2}: low 0.2 "
            "is above high -0.2; allowed: a number [kPa/s] (< 0: a leak), [low, high] or {distribution:"
        ),
    ):
        RandomizationSpec.parse(bad)
    with pytest.raises(ValueError, match="delay_s"):
        RandomizationSpec.parse({"pressure_schedule": {"rate_kpa_per_s": 0.0, "delay_s": -1.0}})


def test_valid_schedules_still_parse():
    spec = RandomizationSpec.parse({"pressure_schedule": {"rate_kpa_per_s": [-0.2, 0.0], "delay_s": 1.0}})
    assert spec.pressure_schedule.rate_kpa_per_s.as_data() == {"distribution": "uniform", "low": -0.2, "high": 0.0}
    assert RandomizationSpec.parse("full").pressure_schedule is not None


@pytest.mark.parametrize(
    "task, options, field",
    [
        (RollTask(), {"omega_ref": "abc"}, "field 'options.omega_ref' = 'abc'"),
        (RollTask(), {"omega_ref": [1.0, 2.0]}, "field 'options.omega_ref'"),
        (RollTask(), {"omega_ref": True}, "field 'options.omega_ref' = True"),  # a bool is not a number
        (RollTask(), {"omega_ref": None}, "field 'options.omega_ref' = None"),
        (
            RollTask(),
            {"omega_ref": 1e9},
            "field 'options.omega_ref' = 1000000000.0: Input should be less than or equal to 30; allowed: [-30, 30]",
        ),
        (RollTask(), {"heading_ref": "x"}, "options.heading_ref"),
        (RollTask(), {"heading_ref": 10.0}, "options.heading_ref"),
        (RollTask(), {"yaw_rate_ref": 1.0}, "unknown field 'options.yaw_rate_ref'"),  # heading mode
        (RollTask(command_mode="yaw_rate"), {"yaw_rate_ref": 9.0}, "options.yaw_rate_ref"),
        (
            RampDescentTask(),
            {"omega_ref": -1.0},
            "field 'options.omega_ref' = -1.0: Input should be greater than or equal to 0; allowed: [0, 30]",
        ),
        (RampDescentTask(), {"omega_ref": float("nan")}, "options.omega_ref"),
        (
            RampDescentTask(omega_ref_change_min_rad_s=None),
            {"omega_ref_after": 3.0},
            "unknown field 'options.omega_ref_after'",
        ),
        (RampDescentTask(), {"pressure_rate_kpa_per_s": "0.1"}, "field 'options.pressure_rate_kpa_per_s' = '0.1'"),
        (RampDescentTask(), {"initial_state": {"theta": "0.1"}}, "field 'options.initial_state.theta' = '0.1'"),
    ],
)
def test_command_options_are_checked_with_their_range(task, options, field):
    with pytest.raises(ValueError) as err:
        validate(reset_options(task), options, root="options")
    assert field in str(err.value)


def test_command_options_in_range_pass_as_floats():
    def given(task, options):
        return validate(reset_options(task), options, root="options").model_dump(exclude_unset=True)

    assert given(RollTask(), {"omega_ref": 2, "heading_ref": -math.pi}) == {"omega_ref": 2.0, "heading_ref": -math.pi}
    assert given(RampDescentTask(), {"omega_ref": 6.0, "pressure_kpa": 5.0}) == {"omega_ref": 6.0, "pressure_kpa": 5.0}
