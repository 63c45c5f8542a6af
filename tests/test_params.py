"""The parameter space: the registry resolved against a calibration. A parameter whose bounds come
from the calibration (the pressure) and an ordinary one are checked, clipped and read by the same
code; no Drake needed."""

import re

import pytest

from sphere_env.models.shell import ShellCalibration
from sphere_env.parameter import Parameter
from sphere_env.params import PARAMETERS, TWIN_PARAMETERS, ParameterSpace

SPACE = ParameterSpace.for_calibration(3.0, 14.0, 4.31, "cal.yaml")


def test_calibration_bounded_and_registered_parameters_take_one_check(monkeypatch):
    checked = []
    check = Parameter.check

    def spy(rec, value, field=None):
        checked.append(rec.name)
        return check(rec, value, field)

    monkeypatch.setattr(Parameter, "check", spy)
    with pytest.raises(
        ValueError,
        match="^"
        + re.escape(
            "field 'pressure_kpa' = 99: Input should be less than or equal to 14; allowed: [3.0, 14.0] kPa, "
            "the calibrated range (calibration cal.yaml)"
        )
        + "$",
    ):
        SPACE.check("pressure_kpa", 99)
    with pytest.raises(
        ValueError,
        match="^"
        + re.escape("field 'payload_mass_kg' = 99: Input should be less than or equal to 50; allowed: [0, 50] kg")
        + "$",
    ):
        SPACE.check("payload_mass_kg", 99)
    assert checked == ["pressure_kpa", "payload_mass_kg"]  # one method for both
    with pytest.raises(ValueError, match=r"^--pressure-kpa = nan: .*; allowed: \[3\.0, 14\.0\] kPa"):
        SPACE.check("pressure_kpa", float("nan"), "--pressure-kpa")
    with pytest.raises(ValueError, match=r"^options: field 'ground_friction' = 2\.0: .*; allowed: \(0, 2\)$"):
        SPACE.check("ground_friction", 2.0, "options: field 'ground_friction'")
    assert SPACE.check("pressure_kpa", 5) == 5.0 and isinstance(SPACE.check("pressure_kpa", 5), float)


def test_space_fills_in_the_calibration_bounds_and_keeps_every_other_record():
    assert SPACE.nominal("pressure_kpa") == 4.31 and SPACE.bounds("pressure_kpa") == (3.0, 14.0)
    assert SPACE.clip("pressure_kpa", 20.0) == 14.0 and SPACE.clip("pressure_kpa", 1.0) == 3.0
    assert SPACE.clip("payload_com_offset_m", (1.0, 0.0, -1.0)) == (0.3, 0.0, -0.3)
    assert 1.0 < SPACE.clip("ground_friction", 5.0) < 2.0  # an open bound clips inside
    assert SPACE.clip("shell_model", "point") == "point"
    for name, rec in PARAMETERS.items():
        if rec.bounds_from is None:
            assert SPACE[name] is rec
    assert ParameterSpace.for_calibration(3.0, 14.0).nominal("pressure_kpa") == 8.5  # the schema's default
    assert ParameterSpace.for_calibration(3.0, 14.0, 4.31, "cal.yaml") is SPACE  # one per calibration


def test_a_record_with_calibration_bounds_is_refused_outside_a_space():
    rec = PARAMETERS["pressure_kpa"]
    assert rec.bounds_from == "calibration" and rec.nominal is None
    for use in (lambda: rec.check(5.0), lambda: rec.clip(5.0)):
        with pytest.raises(LookupError, match="pressure_kpa: its bounds come from the calibration"):
            use()


def test_calibration_pressure_check_is_the_space_check():
    cal = ShellCalibration.load()
    space = cal.parameter_space()
    assert space.bounds("pressure_kpa") == cal.pressure_range_kpa
    assert space.nominal("pressure_kpa") == cal.nominal_pressure_kpa
    assert {name: space.nominal(name) for name in TWIN_PARAMETERS}["pressure_kpa"] == cal.nominal_pressure_kpa
    errors = []
    for check in (
        lambda: cal.check_pressure(99.0, "--pressure-kpa"),
        lambda: space.check("pressure_kpa", 99.0, "--pressure-kpa"),
    ):
        with pytest.raises(ValueError) as err:
            check()
        errors.append(str(err.value))
    assert errors[0] == errors[1]
    assert errors[0].endswith(f"; allowed: [3.0, 14.0] kPa, the calibrated range (calibration {cal.source})")
    wide = cal.extrapolated(2.0).parameter_space()
    assert wide.bounds("pressure_kpa") == (1.0, 16.0) and wide.check("pressure_kpa", 15.0) == 15.0
