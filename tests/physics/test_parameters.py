"""The twin's parameters take one path: Twin.apply checks them in the calibration's parameter space,
stores them in one set and pushes the changed ones into the context; set_pressure and the other
setters are shorthands for it. Checked on the real Drake twin."""

import numpy as np
import pytest

from sphere_env.physics import InitialState

from .conftest import record

ALL = {
    "steer_friction_scale": 1.3,
    "drive_friction_scale": 0.7,
    "ground_friction": 0.8,
    "payload_mass_kg": 2.0,
    "payload_com_offset_m": (0.01, 0.0, -0.02),
    "shell_stiffness_scale": 1.2,
    "shell_damping_scale": 0.8,
}


def _episode(twin, change) -> np.ndarray:
    """Roll from a tilt, ``change`` the twin mid-run, roll on: the final positions and velocities."""
    twin.reset(InitialState(roll=0.1, drive_rate=1.0))
    record(twin, 0.2, torque=(0.5, 1.0))
    change(twin)
    record(twin, 0.3, torque=(0.5, 1.0))
    return np.concatenate(twin.positions_velocities())


@pytest.mark.parametrize("shell_model", ["injected", "hydroelastic"])
def test_apply_changes_pressure_exactly_like_set_pressure(make_twin, shell_model):
    a = make_twin(fixture="free", shell_model=shell_model)
    b = make_twin(fixture="free", shell_model=shell_model)
    lo, hi = a.calibration.pressure_range_kpa
    with_apply = _episode(a, lambda t: t.apply({"pressure_kpa": hi}))
    with_setter = _episode(b, lambda t: t.set_pressure(hi))
    np.testing.assert_array_equal(with_apply, with_setter)  # bit-identical
    assert a.pressure_kpa == b.pressure_kpa == a.state().pressure_kpa == hi
    unchanged = _episode(b, lambda t: t.set_pressure(lo))
    assert not np.array_equal(unchanged, with_setter)  # the episode can tell the pressures apart


def test_apply_of_every_parameter_at_once_is_the_setters_in_turn(make_twin):
    a = make_twin(fixture="free", shell_model="injected")
    b = make_twin(fixture="free", shell_model="injected")
    p = a.calibration.pressure_range_kpa[1]
    at_once = _episode(a, lambda t: t.apply({**ALL, "pressure_kpa": p, "not_a_twin_parameter": 1}))

    def setters(t):
        t.set_friction_scale(ALL["steer_friction_scale"], ALL["drive_friction_scale"])
        t.set_ground_friction(ALL["ground_friction"])
        t.set_payload(ALL["payload_mass_kg"], ALL["payload_com_offset_m"])
        t.set_shell_law_scale(ALL["shell_stiffness_scale"], ALL["shell_damping_scale"])
        t.set_pressure(p)

    np.testing.assert_array_equal(at_once, _episode(b, setters))
    assert a.params == b.params == {**ALL, "pressure_kpa": p}


def test_a_refused_value_changes_no_parameter(make_twin):
    twin = make_twin(fixture="free", shell_model="injected")
    before = twin.params
    before["pressure_kpa"] = -1.0  # a copy: the twin keeps its own
    assert twin.params["pressure_kpa"] == twin.calibration.nominal_pressure_kpa
    with pytest.raises(
        ValueError,
        match=r"^field 'pressure_kpa' = 99\.0: .*; allowed: \[3\.0, 14\.0\] kPa, "
        r"the calibrated range \(calibration ",
    ):
        twin.apply({**ALL, "pressure_kpa": 99.0})
    with pytest.raises(ValueError, match=r"^field 'payload_mass_kg' = 99\.0: .*; allowed: \[0, 50\] kg$"):
        twin.apply({"pressure_kpa": 5.0, "payload_mass_kg": 99.0})
    with pytest.raises(ValueError, match=r"^field 'pressure_kpa' = 99\.0"):
        twin.reset(pressure_kpa=99.0)
    assert twin.params == {**before, "pressure_kpa": twin.calibration.nominal_pressure_kpa}


def test_apply_unchecked_is_apply_for_checked_values(make_twin):
    """The env's path (values drawn within the space, or checked options): the same episode as
    Twin.apply, keys that are no twin parameter ignored; Twin.reset's pressure takes it too."""
    a = make_twin(fixture="free", shell_model="injected")
    b = make_twin(fixture="free", shell_model="injected")
    p = a.calibration.pressure_range_kpa[1]
    checked = _episode(a, lambda t: t.apply({**ALL, "pressure_kpa": p}))
    unchecked = _episode(b, lambda t: t.apply_unchecked({**ALL, "pressure_kpa": p, "incline_deg": 3.0}))
    np.testing.assert_array_equal(checked, unchecked)
    assert b.params == {**ALL, "pressure_kpa": p}
    b.reset(pressure_kpa=4.0)
    assert b.pressure_kpa == b.state().pressure_kpa == 4.0
