"""The twin against closed-form mechanics (docs/design.md)."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from sphere_env.analysis.decay import fit_free_decay
from sphere_env.physics import InitialState

from .conftest import record


def test_locked_steer_point_contact_matches_eq5(make_twin):
    twin = make_twin(fixture="locked_steer", shell_model="point", steer_friction="none", drive_friction="none")
    twin.reset(InitialState(roll=0.02))
    t, phi = record(twin, 10.0)
    fit = fit_free_decay(t, phi)
    expected = math.sqrt(twin.robot.K_eq / twin.robot.M_eq)  # ≈ 2.29 rad/s, from the URDF
    assert fit.omega_n == pytest.approx(expected, rel=0.01)
    assert fit.zeta < 0.01


def test_stand_small_swing_frequency(make_twin):
    twin = make_twin(fixture="stand", shell_model="point", steer_friction="none")
    twin.reset(InitialState(theta=0.02))
    t, theta = record(twin, 4.0, chunk_s=0.01, field="theta")
    fit = fit_free_decay(t, theta)
    assert fit.omega_n == pytest.approx(twin.robot.omega_stand_rad_s, rel=0.01)  # ≈ 5.66 rad/s


def test_locked_joints_roll_without_slip_down_16deg_ramp(make_twin):
    alpha = math.radians(16.0)
    twin = make_twin(
        shell_model="point", incline_deg=16.0, steer_friction="none", drive_friction="none", time_step_s=0.001
    )
    twin.reset()  # pendulum hangs plumb: COM straight below the centre
    twin.lock_joints(steer=True, drive=True)
    p0 = twin.state().position_m
    T = 0.4
    t, _ = record(twin, T)
    travel = (twin.state().position_m - p0) @ twin.terrain.t_ramp
    # Exact rolling-without-slip dynamics of the locked robot (its COM sits d below the centre).
    sol = solve_ivp(twin.robot.locked_rolling_rhs(alpha), (0, T), [0.0, 0.0], rtol=1e-10, atol=1e-12)
    expected_travel = twin.robot.radius_m * sol.y[0, -1]
    mean_acc, expected_acc = 2 * travel / T**2, 2 * expected_travel / T**2
    assert mean_acc == pytest.approx(expected_acc, rel=0.02)
    # rolling, not sliding: the shell's contact point is (nearly) at rest
    s = twin.state()
    v_contact = s.velocity_m_s + np.cross([0.0, s.omega_d, 0.0], -twin.robot.radius_m * twin.terrain.n_ramp)
    assert np.linalg.norm(v_contact) < 0.02 * np.linalg.norm(s.velocity_m_s)


def test_joint_with_friction_decays_and_without_does_not(make_twin):
    free = make_twin(fixture="stand", steer_friction="none")
    damped = make_twin(fixture="stand", steer_friction="majd")
    amps = {}
    for name, twin in (("free", free), ("damped", damped)):
        twin.reset(InitialState(theta=0.3))
        _, th = record(twin, 6.0, chunk_s=0.01, field="theta")
        amps[name] = np.ptp(th[-150:]) / 2
    assert amps["free"] == pytest.approx(0.3 + 0.035, abs=0.03)  # swings about θ_eq ≈ −0.035 rad
    assert amps["damped"] < 0.05
