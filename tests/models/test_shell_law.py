"""The steer-direction shell law: forms, the stand-still check, binding to a robot, symbolic = numpy."""

import math

import numpy as np
import pytest
import yaml

from sphere_env.models.rigid_body import RobotParameters
from sphere_env.models.shell import ShellCalibration
from sphere_env.models.steer_law import (
    PHI_REACH_RAD,
    gravity_stiffness_free_pendulum,
    injected_gains,
    injected_torques,
    steer_torque,
)

BASE = {
    "pressure_range_kpa": [3.0, 14.0],
    "nominal_pressure_kpa": 6.0,
    "omega_n": {"model": "linear", "intercept_rad_s": 2.6, "slope_rad_s_per_kpa": 0.05},
    "zeta": {"model": "exponential", "scale": 0.2, "rate_per_kpa": -0.05},
    "contact_volume": {"model": "membrane"},
    "hydroelastic": {"k_d": 0.5, "resolution_hint_m": 0.05},
}


def cal_with(**sections) -> dict:
    data = yaml.safe_load(yaml.safe_dump(BASE))
    for k, v in sections.items():
        data[k] = v if not isinstance(v, dict) or k not in data else dict(data[k], **v)
    return data


def test_linear_law_without_rest_angle_is_paper_eq_9():
    phi, phi_dot, omega_d = np.array([-0.3, 0.1]), np.array([0.5, -1.0]), np.array([2.0, -0.4])
    tau_phi, tau_d = injected_torques(phi, phi_dot, omega_d, 20.0, 3.0, 3.0)
    assert tau_phi == pytest.approx(-3.0 * phi_dot - 20.0 * phi)
    assert tau_d == pytest.approx(-3.0 * omega_d)


def test_each_form_gives_its_documented_torque_and_stiffness():
    r = RobotParameters.from_urdf()
    p = 6.0
    K, _ = injected_gains(2.9, 0.1, r.M_eq, r.K_eq)
    sat = ShellCalibration.from_dict(
        cal_with(
            steer_law={
                "form": "saturating",
                "rest_angle_rad": 0.04,
                "amplitude_stiffness_nm_per_rad": 30.0,
                "amplitude_scale_rad": 0.1,
            }
        )
    )
    quad = ShellCalibration.from_dict(
        cal_with(steer_law={"form": "quadratic", "rest_angle_rad": -0.02, "quadratic_stiffness_nm_per_rad2": 10.0})
    )
    phi = np.linspace(-1.0, 1.0, 9)
    for cal, direct in (
        (sat, lambda d: -K * d - 30.0 * 0.1 * np.tanh(d / 0.1)),
        (quad, lambda d: -K * d - 10.0 * d * np.abs(d)),
    ):
        g = cal.bind(r).law_gains("injected", p)
        g[0] = K  # the same linear stiffness for both checks
        law = cal.steer_law
        tau = steer_torque(phi, 0.0, g[0], g[1], *g[3:])
        assert tau == pytest.approx(direct(phi - law.rest_angle_rad))
        # the documented tangent stiffness is −∂τ/∂φ
        h = 1e-6
        num = -(steer_torque(phi + h, 0.0, g[0], 0.0, *g[3:]) - steer_torque(phi - h, 0.0, g[0], 0.0, *g[3:])) / (2 * h)
        assert law.stiffness(phi, K) == pytest.approx(num, rel=1e-5, abs=1e-4)
    # at rest the spring is silent: the robot rests at φ_0 (with gravity pulling toward 0)
    assert steer_torque(0.04, 0.0, K, 1.0, *sat.steer_law.gains_tail()) == pytest.approx(0.0)


def test_symbolic_law_evaluates_like_numpy():
    from pydrake.symbolic import Variable

    from sphere_env.physics.forces import SYMBOLIC

    v = [Variable(n) for n in ("phi", "phi_dot", "wd")]
    gains = (21.0, 2.5, 1.5, 0.03, 4.0, 8.0, 6.0)
    tau_phi, tau_d = injected_torques(*v, *gains, m=SYMBOLIC)
    for vals in ((-0.4, 0.7, 1.2), (0.25, -1.1, -0.3)):
        env = dict(zip(v, vals))
        a, b = injected_torques(*vals, *gains)
        assert tau_phi.Evaluate(env) == pytest.approx(a, rel=1e-12)
        assert tau_d.Evaluate(env) == pytest.approx(b, rel=1e-12)


def test_bound_shell_gains_per_model():
    r = RobotParameters.from_urdf()
    cal = ShellCalibration.from_dict(
        cal_with(
            hydroelastic={"couple_stiffness_factor": 0.8, "couple_damping_factor": 0.5},
            steer_law={"form": "linear", "rest_angle_rad": 0.03},
        )
    )
    shell = cal.bind(r)
    K, C = shell.injected_gains(6.0)
    assert (K, C) == pytest.approx(injected_gains(float(cal.omega_n(6.0)), float(cal.zeta(6.0)), r.M_eq, r.K_eq))
    assert shell.law_gains("injected", 6.0) == pytest.approx([K, C, C, 0.03, 0.0, 1.0, 0.0])
    # hydroelastic: the steer couple scaled, no drive damper (the contact damps rolling)
    assert shell.law_gains("hydroelastic", 6.0) == pytest.approx([0.8 * K, 0.5 * C, 0.0, 0.03, 0.0, 1.0, 0.0])
    assert not np.any(shell.law_gains("point", 6.0)[[0, 1, 2, 4, 6]])
    m, d = shell.hydroelastic(6.0)
    assert d == pytest.approx(0.5 * C) and m > 0
    assert shell.parameters("hydroelastic", 6.0)["couple_stiffness_factor"] == 0.8


def test_old_files_keep_their_behaviour():
    cal = ShellCalibration.from_dict(BASE)
    assert cal.steer_law.form == "linear" and cal.steer_law.rest_angle_rad == 0.0
    assert cal.couple_stiffness_factor == 0.0  # hydroelastic without a couple, as before


def _can_stand(cal_dict) -> bool:
    try:
        ShellCalibration.from_dict(cal_dict)
        return True
    except ValueError as err:
        assert "cannot stand still" in str(err)
        return False


@pytest.mark.parametrize(
    "law, field",
    [
        # a softening quadratic: zero stiffness well inside the reachable range (the tipping robot)
        (
            {"form": "quadratic", "rest_angle_rad": 0.0, "quadratic_stiffness_nm_per_rad2": -30.0},
            "steer_law.quadratic_stiffness_nm_per_rad2",
        ),
        (
            {
                "form": "saturating",
                "rest_angle_rad": 0.0,
                "amplitude_stiffness_nm_per_rad": -40.0,
                "amplitude_scale_rad": 0.2,
            },
            "steer_law.amplitude_stiffness_nm_per_rad",
        ),
    ],
)
def test_a_law_the_robot_cannot_stand_still_with_is_refused_naming_the_field(tmp_path, law, field):
    path = tmp_path / "unstable.yaml"
    path.write_text(yaml.safe_dump(cal_with(steer_law=law)))
    with pytest.raises(ValueError, match=rf"{path}.*field '{field}'.*cannot stand still"):
        ShellCalibration.load(path)


def test_too_soft_linear_spring_is_refused_naming_omega_n():
    # ω_n so low that K_inject = ω_n² M_eq − K_eq is more negative than gravity's free-pendulum stiffness
    data = cal_with(omega_n={"intercept_rad_s": 1.0, "slope_rad_s_per_kpa": 0.0})
    with pytest.raises(ValueError, match="field 'omega_n'.*cannot stand still"):
        ShellCalibration.from_dict(data)


def test_stand_still_check_agrees_with_the_analytic_boundary():
    """The refusal sits where K_g cos φ + K + 2 K_2 |φ| first reaches 0 within |φ| <= 1.2 rad."""
    r = RobotParameters.from_urdf()
    cal = ShellCalibration.from_dict(BASE)
    k_lo = min(cal.bind(r).injected_gains(p)[0] for p in (3.0, 14.0))
    k_g = gravity_stiffness_free_pendulum(r)
    # the most softening K_2 that keeps the minimum stiffness (at |φ| = 1.2) positive
    k2_edge = -(k_lo + k_g * math.cos(PHI_REACH_RAD)) / (2 * PHI_REACH_RAD)
    law = {"form": "quadratic", "rest_angle_rad": 0.0}
    assert _can_stand(cal_with(steer_law=dict(law, quadratic_stiffness_nm_per_rad2=0.98 * k2_edge)))
    assert not _can_stand(cal_with(steer_law=dict(law, quadratic_stiffness_nm_per_rad2=1.02 * k2_edge)))


@pytest.mark.parametrize(
    "law, match",
    [
        ({"form": "cubic"}, "'steer_law.form' = 'cubic': .*allowed: \\['linear', 'saturating', 'quadratic'\\]"),
        ({"form": "linear", "amplitude_scale_rad": 0.1}, "not used by form 'linear'"),
        (
            {"form": "saturating", "amplitude_stiffness_nm_per_rad": 5.0, "amplitude_scale_rad": 0.0},
            "'steer_law.amplitude_scale_rad' = 0.0: Input should be greater than 0",
        ),
        ({"form": "saturating", "amplitude_stiffness_nm_per_rad": 5.0}, "'steer_law.amplitude_scale_rad' is missing"),
        ({"form": "linear", "rest_angle_rad": 0.9}, "'steer_law.rest_angle_rad' = 0.9"),
    ],
)
def test_bad_steer_law_fields_are_named(law, match):
    with pytest.raises(ValueError, match=match):
        ShellCalibration.from_dict(cal_with(steer_law=law))


def test_negative_couple_factor_is_refused():
    with pytest.raises(
        ValueError, match="'hydroelastic.couple_damping_factor' = -0.1: Input should be greater than or equal to 0"
    ):
        ShellCalibration.from_dict(cal_with(hydroelastic={"couple_damping_factor": -0.1}))
