"""Numerical admissibility checks of the twin: explicit-torque stability and ground clearance."""

import math

import numpy as np
import pytest

from sphere_env.models.friction import FrictionModel
from sphere_env.physics import Twin, TwinConfig
from sphere_env.physics.admissibility import EXPLICIT_DAMPING_LIMIT, friction_peak_slope, ground_clearance_m
from sphere_env.physics.terrain import Terrain


def test_friction_peak_slope_matches_the_laws():
    assert friction_peak_slope(FrictionModel("viscous", {"c": 7.0})) == pytest.approx(7.0, rel=1e-6)
    # coulomb: slope at v = 0 is 3 μ_s / v_tol + c (FrictionModel docstring)
    law = FrictionModel("coulomb", {"mu_s": 0.7, "mu_d": 0.65, "c": 0.1, "v_tol": 0.05})
    assert friction_peak_slope(law) == pytest.approx(3 * 0.7 / 0.05 + 0.1, rel=1e-3)
    assert friction_peak_slope(FrictionModel("none")) == 0.0


def test_ground_clearance_on_a_ramp_and_its_run_out():
    t = Terrain(16.0, 4.0)
    a = math.radians(16.0)
    n = np.array([math.sin(a), 0.0, math.cos(a)])
    assert ground_clearance_m(t, 0.3 * n) == pytest.approx(0.3)
    end = t.ramp_end_W
    assert ground_clearance_m(t, end + np.array([2.0, 0.0, 0.2])) == pytest.approx(0.2)  # over the run-out
    assert ground_clearance_m(Terrain(0.0, None), (5.0, -3.0, -0.1)) == pytest.approx(-0.1)


def test_explicit_stability_limit_scales_with_the_step():
    fm = FrictionModel("viscous", {"c": 150.0})
    fine = Twin(TwinConfig(shell_model="point", steer_friction=fm, drive_friction="none", time_step_s=0.002))
    assert fine.explicit_stability_problem() is None
    assert fine.explicit_stability_problem(steer_friction_scale=3.0) is not None  # 450 N m s/rad
    coarse = Twin(TwinConfig(shell_model="point", steer_friction=fm, drive_friction="none", time_step_s=0.01))
    problem = coarse.explicit_stability_problem()
    assert problem.startswith("friction_model: steer joint damping 150") and f"<= {EXPLICIT_DAMPING_LIMIT:g}" in problem
