"""Calibration files that cannot be right are refused naming the field and what is allowed, and
`calibration shell` writes nothing rather than such a file."""

from __future__ import annotations

import copy
import math
import re

import pytest
import yaml

from sphere_env.calibration.__main__ import main
from sphere_env.calibration.decay import PressureFit, calibration_dict
from sphere_env.models.shell import ShellCalibration
from sphere_env.resources import asset_path
from tests.calibration.conftest import write_manifest

BASE = yaml.safe_load(asset_path("calibration", "default.yaml").read_text())


def _variant(**changes):
    d = copy.deepcopy(BASE)
    for dotted, v in changes.items():
        *path, last = dotted.split("__")
        node = d
        for k in path:
            node = node[k]
        node[last] = v
    return d


@pytest.mark.parametrize(
    "changes, field",
    [
        (
            {
                "omega_n__intercept_rad_s": BASE["omega_n"]["intercept_rad_s"] / (2 * math.pi),
                "omega_n__slope_rad_s_per_kpa": 0.0,
            },
            "omega_n",
        ),
        (
            {"contact_volume": {"model": "table", "pressure_kpa": [3.0, 14.0], "volume_m3": [float("nan"), 1e-3]}},
            "contact_volume",
        ),
        (
            {"contact_volume": {"model": "table", "pressure_kpa": [3.0, 14.0], "volume_m3": [True, 1e-3]}},
            "contact_volume",
        ),
        ({"pressure_range_kpa": [3000.0, 14000.0], "nominal_pressure_kpa": 4310.0}, "pressure_range_kpa"),
        ({"pressure_range_kpa": [0.003, 0.014], "nominal_pressure_kpa": 0.005}, "pressure_range_kpa"),
        ({"pressure_range_kpa": [True, 14]}, "pressure_range_kpa"),
        ({"nominal_pressure_kpa": True}, "nominal_pressure_kpa"),
        ({"hydroelastic__fitted_time_step_s": -0.005}, "hydroelastic.fitted_time_step_s"),
        ({"hydroelastic__resolution_hint_m": 1e6}, "hydroelastic.resolution_hint_m"),
        ({"hydroelastic__k_d_by_time_step": {"time_step_s": 0.01, "k_d": 0.2}}, "hydroelastic.k_d_by_time_step"),
        (
            {"hydroelastic__k_d_by_time_step": [{"time_step_s": 10.0, "k_d": 0.2}]},
            r"hydroelastic.k_d_by_time_step\[0\].time_step_s",
        ),
        (
            {"hydroelastic__k_d_by_time_step": [{"time_step_s": 0.01, "k_d": -0.2}]},
            r"hydroelastic.k_d_by_time_step\[0\].k_d",
        ),
        (
            {"hydroelastic__k_d_by_time_step": [{"time_step_s": 0.01, "kd": 0.2}]},
            r"hydroelastic.k_d_by_time_step\[0\].kd",
        ),
        (
            {"hydroelastic__k_d_by_time_step": [{"time_step_s": 0.005, "k_d": 0.2}]},  # the fitted step's k_d is k_d
            r"hydroelastic.k_d_by_time_step\[0\].time_step_s",
        ),
        (
            {"hydroelastic__k_d_by_time_step": [{"time_step_s": 0.01, "k_d": 0.2}, {"time_step_s": 0.01, "k_d": 0.3}]},
            r"hydroelastic.k_d_by_time_step\[1\].time_step_s",
        ),
        ({"hydroelastic__low_pressure_mesh": 0.1}, "hydroelastic.low_pressure_mesh"),
        (
            {"hydroelastic__low_pressure_mesh": {"below_kpa": 20.0, "resolution_hint_m": 0.1}},
            "hydroelastic.low_pressure_mesh.below_kpa",
        ),
        (
            {"hydroelastic__low_pressure_mesh": {"below_kpa": 3.0, "resolution_hint_m": 0.1}},
            "hydroelastic.low_pressure_mesh.below_kpa",
        ),
        (
            {"hydroelastic__low_pressure_mesh": {"below_kpa": 5.0, "resolution_hint_m": 1e6}},
            "hydroelastic.low_pressure_mesh.resolution_hint_m",
        ),
        ({"hydroelastic__low_pressure_mesh": {"below_kpa": 5.0}}, "hydroelastic.low_pressure_mesh.resolution_hint_m"),
        (
            {"hydroelastic__low_pressure_mesh": {"below_kpa": 5.0, "resolution_hint_m": 0.1, "hint_m": 0.1}},
            "hydroelastic.low_pressure_mesh.hint_m",
        ),
        ({"hydroelastic__k_d_by_pressure": 0.3}, "hydroelastic.k_d_by_pressure"),
        ({"hydroelastic__k_d_by_pressure": [{"pressure_kpa": 3.0, "k_d": 0.319}]}, "hydroelastic.k_d_by_pressure"),
        (
            {
                "hydroelastic__k_d_by_pressure": [
                    {"pressure_kpa": 3.0, "k_d": 0.319},
                    {"pressure_kpa": 10.0, "k_d": 0.319},
                ]
            },
            r"hydroelastic.k_d_by_pressure' covers \[3.0, 10.0\] kPa",
        ),  # would be extrapolated to 14 kPa
        (
            {
                "hydroelastic__k_d_by_pressure": [
                    {"pressure_kpa": 14.0, "k_d": 0.319},
                    {"pressure_kpa": 3.0, "k_d": 0.319},
                ]
            },
            r"hydroelastic.k_d_by_pressure\[1\].pressure_kpa",
        ),
        (
            {
                "hydroelastic__k_d_by_pressure": [
                    {"pressure_kpa": 3000.0, "k_d": 0.319},
                    {"pressure_kpa": 14000.0, "k_d": 0.3},
                ]
            },
            r"hydroelastic.k_d_by_pressure\[0\].pressure_kpa",
        ),  # Pa, not kPa
        (
            {
                "hydroelastic__k_d_by_pressure": [
                    {"pressure_kpa": 3.0, "k_d": -0.1},
                    {"pressure_kpa": 14.0, "k_d": 0.319},
                ]
            },
            r"hydroelastic.k_d_by_pressure\[0\].k_d",
        ),
        (
            {"hydroelastic__k_d_by_pressure": [{"pressure_kpa": 3.0, "kd": 0.3}, {"pressure_kpa": 14.0, "k_d": 0.319}]},
            r"hydroelastic.k_d_by_pressure\[0\].kd",
        ),
        (
            {"hydroelastic__k_d_by_pressure": [{"pressure_kpa": 3.0, "k_d": 0.2}, {"pressure_kpa": 14.0, "k_d": 0.4}]},
            r"hydroelastic.k_d' = 0.319 must equal its k_d_by_pressure at nominal_pressure_kpa 4.31 kPa \(0.2238",
        ),
        (
            {
                "hydroelastic__k_d_by_time_step": [
                    {
                        "time_step_s": 0.01,
                        "k_d": 0.2,
                        "k_d_by_pressure": [{"pressure_kpa": 3.0, "k_d": 0.1}, {"pressure_kpa": 14.0, "k_d": 0.3}],
                    }
                ]
            },
            r"hydroelastic.k_d_by_time_step\[0\].k_d' = 0.2 must equal",
        ),
        (
            {
                "hydroelastic__k_d_by_time_step": [
                    {
                        "time_step_s": 0.01,
                        "k_d": 0.2,
                        "k_d_by_pressure": [{"pressure_kpa": 4.0, "k_d": 0.2}, {"pressure_kpa": 14.0, "k_d": 0.2}],
                    }
                ]
            },
            r"hydroelastic.k_d_by_time_step\[0\].k_d_by_pressure' covers",
        ),
        ({"nominal_pressure_kpaa": 6.0}, "nominal_pressure_kpaa"),
        ({"hydroelastic__k_dd": 0.3}, "hydroelastic.k_dd"),
        ({"omega_n__slope": 0.03}, "omega_n.slope"),
    ],
)
def test_impossible_calibration_refused_naming_the_field(changes, field):
    with pytest.raises(ValueError, match=rf"field '{field}"):
        ShellCalibration.from_dict(_variant(**changes), source="bad.yaml")


def test_low_pressure_mesh_applies_below_its_pressure_only():
    cal = ShellCalibration.from_dict(
        _variant(
            hydroelastic__resolution_hint_m=0.05,
            hydroelastic__low_pressure_mesh={"below_kpa": 5.0, "resolution_hint_m": 0.1},
        )
    )
    assert [cal.resolution_hint_at(p) for p in (3.0, 4.99, 5.0, 14.0)] == [0.1, 0.1, 0.05, 0.05]
    plain = copy.deepcopy(BASE)
    plain["hydroelastic"].pop("low_pressure_mesh", None)
    uniform = ShellCalibration.from_dict(plain)
    assert {uniform.resolution_hint_at(p) for p in (3.0, 14.0)} == {uniform.resolution_hint_m}


def test_k_d_refit_at_a_time_step_is_used_at_that_step_only():
    cal = ShellCalibration.from_dict(
        _variant(
            hydroelastic__k_d=0.3,
            hydroelastic__fitted_time_step_s=0.005,
            hydroelastic__k_d_by_time_step=[{"time_step_s": 0.01, "k_d": 0.2}],
        )
    )
    at_10 = cal.for_time_step(0.01)
    assert (at_10.k_d, at_10.fitted_time_step_s) == (0.2, 0.01)
    assert cal.for_time_step(0.005) is cal and cal.for_time_step(0.002) is cal  # no refit there: unchanged
    back = at_10.for_time_step(0.005)  # the fitted step's k_d moved into the table
    assert (back.k_d, back.fitted_time_step_s) == (0.3, 0.005)
    reloaded = ShellCalibration.from_dict(at_10.raw)  # its raw mapping is a valid calibration of the same laws
    assert (reloaded.k_d, reloaded.fitted_time_step_s, reloaded.k_d_by_time_step) == (0.2, 0.01, ((0.005, 0.3),))


def test_k_d_by_pressure_is_interpolated_at_its_step_and_moves_with_it():
    table = [{"pressure_kpa": 3.0, "k_d": 0.2}, {"pressure_kpa": 4.31, "k_d": 0.25}, {"pressure_kpa": 14.0, "k_d": 0.6}]
    cal = ShellCalibration.from_dict(
        _variant(hydroelastic__k_d_by_time_step=[{"time_step_s": 0.01, "k_d": 0.25, "k_d_by_pressure": table}])
    )
    assert [cal.k_d_at(p) for p in (3.0, 8.5, 14.0)] == [0.319] * 3  # at its fitted 5 ms: one k_d
    at_10 = cal.for_time_step(0.01)
    assert at_10.k_d == 0.25
    assert at_10.k_d_at(3.0) == 0.2 and at_10.k_d_at(14.0) == pytest.approx(0.6)
    assert at_10.k_d_at(9.155) == pytest.approx(0.425)  # halfway between 4.31 and 14 kPa
    robot = _robot()
    shell = at_10.bind(robot)
    assert shell.hydroelastic(8.5)[1] == pytest.approx(at_10.k_d_at(8.5) * shell.injected_gains(8.5)[1])
    reloaded = ShellCalibration.from_dict(at_10.raw)  # its raw mapping is a valid calibration of the same laws
    assert reloaded.k_d_by_pressure == at_10.k_d_by_pressure and reloaded.k_d_by_time_step == ((0.005, 0.319),)
    back = reloaded.for_time_step(0.005)  # the 10 ms table moved into the list and comes back
    assert back.k_d_by_pressure == () and back.k_d == 0.319
    assert back.for_time_step(0.01).k_d_by_pressure == at_10.k_d_by_pressure


def test_default_calibration_has_one_k_d_at_every_pressure():
    """No table in the shipped default.yaml: the hydroelastic dissipation is k_d · C_inject(p) with
    the same k_d at every pressure and step (the registered envs' trajectories are unchanged)."""
    robot = _robot()
    for step in (0.005, 0.01):
        cal = ShellCalibration.load().for_time_step(step)
        assert cal.k_d_by_pressure == () and cal.k_d_by_pressure_at_steps == ()
        shell = cal.bind(robot)
        for p in (3.0, 4.31, 5.0, 8.5, 14.0):
            assert cal.k_d_at(p) == cal.k_d
            assert shell.hydroelastic(p)[1] == cal.k_d * shell.injected_gains(p)[1]


def test_calibration_by_shipped_name():
    assert ShellCalibration.load("hydroelastic_fast").source == str(asset_path("calibration", "hydroelastic_fast.yaml"))
    assert ShellCalibration.load("default").raw == ShellCalibration.load().raw
    with pytest.raises(
        ValueError,
        match=r"^calibration = 'hydroelastic_fst': .*; allowed: the path of a calibration "
        r"YAML file, the name of a shipped one \[.*'hydroelastic_fast'",
    ):
        ShellCalibration.load("hydroelastic_fst")


def _robot():
    from sphere_env.models.rigid_body import RobotParameters

    return RobotParameters.from_urdf()


def test_hz_message_says_rad_per_s():
    bad = _variant(
        omega_n__intercept_rad_s=BASE["omega_n"]["intercept_rad_s"] / (2 * math.pi), omega_n__slope_rad_s_per_kpa=0.0
    )
    with pytest.raises(ValueError, match="a value in Hz is 2π too small"):
        ShellCalibration.from_dict(bad)


def test_shipped_calibrations_still_load():
    for name in ("default.yaml", "v0_linear.yaml", "free_robot.yaml", "hydroelastic_fast.yaml"):
        ShellCalibration.load(asset_path("calibration", name))


@pytest.mark.parametrize("value", [123, 4.5, ["a.yaml"]])
def test_calibration_that_is_not_a_path_is_a_named_error(value):
    with pytest.raises(ValueError, match=re.escape(f"calibration = {value!r}: ")) as err:
        ShellCalibration.load(value)
    assert (
        "; allowed: the path of a calibration YAML file, the name of a shipped one ['default', "
        "'free_robot', 'hydroelastic_fast', 'v0_linear'], or None"
    ) in str(err.value)


def test_env_with_calibration_123_is_a_named_error():
    import gymnasium as gym

    import sphere_env  # noqa: F401

    with pytest.raises(ValueError, match="calibration"):
        gym.make("sphere_env/RampDescent-v2", shell_model="point", calibration=123)


def test_fitted_curves_in_hz_are_not_turned_into_a_calibration(tmp_path):
    """calibration_dict (what `calibration shell` writes) refuses ω_n curves in Hz."""
    hz = PressureFit(
        omega_n_intercept=0.45,
        omega_n_slope=0.005,
        zeta_scale=0.17,
        zeta_rate=-0.05,
        ci={},
        pressures_kpa=(3.0, 8.0, 14.0),
        confidence=0.95,
    )
    with pytest.raises(ValueError, match="omega_n"):
        calibration_dict(hz)


def test_shell_command_with_pressures_in_pa_writes_nothing(tmp_path, capsys):
    man = write_manifest(
        tmp_path / "m.yaml",
        [
            {
                "name": f"t{p}",
                "file": f"t{p}.csv",
                "fixture": "locked_steer",
                "group": "locked_steer",
                "pressure_kpa": p,
            }
            for p in (4000, 8000, 12000)
        ],
    )
    out = tmp_path / "cal.yaml"
    assert main(["shell", "--manifest", str(man), "--out", str(out)]) == 2
    assert "pressure_kpa" in capsys.readouterr().err
    assert not out.exists() and not list(tmp_path.glob("cal.yaml*"))
