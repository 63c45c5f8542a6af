"""One twin, several inclines: set_incline moves the ground without a rebuild, and the results are
the same bits as a twin built at that incline (ramp and run-out, cached hydroelastic shells)."""

import numpy as np
import pytest

from sphere_env.physics import InitialState, Twin, TwinConfig
from sphere_env.physics.terrain import Terrain


def _run_over_ramp_end(twin: Twin, steps: int = 60) -> np.ndarray:
    """Start 0.4 m before the ramp's end, rolling down, and cross onto the flat run-out."""
    terrain = Terrain(twin.incline_deg, twin.config.ramp_length_m)
    p = twin.robot.radius_m * terrain.n_ramp + (twin.config.ramp_length_m - 0.4) * terrain.t_ramp
    twin.reset(InitialState(theta=0.2, position_m=tuple(p), velocity_m_s=tuple(1.5 * terrain.t_ramp)))
    rows = []
    for i in range(steps):
        twin.advance(0.02, (3.0 * np.sin(i / 7), -8.0))
        s = twin.state()
        rows.append(np.r_[s.position_m, s.velocity_m_s, s.phi, s.theta, s.omega_d])
    assert rows[-1][0] > twin.ramp_end_x_m + 0.1  # the run-out was reached
    return np.array(rows)


@pytest.mark.slow
@pytest.mark.parametrize("shell_model", ["hydroelastic", "injected"])
def test_switched_incline_is_bit_identical_to_a_twin_built_there(shell_model):
    shared = Twin(TwinConfig(shell_model=shell_model, incline_deg=16, ramp_length_m=4.0, inclines_deg=(13, 16, 19)))
    # Shells cached at one incline are restored at another (the snapshot's ground is moved back).
    for incline, p_kpa, mu in ((13, 5.0, 0.8), (19, 12.0, 1.1), (13, 12.0, 0.9), (16, 5.0, 0.8)):
        shared.set_incline(incline)
        shared.apply({"pressure_kpa": p_kpa, "ground_friction": mu})
        built = Twin(TwinConfig(shell_model=shell_model, incline_deg=incline, ramp_length_m=4.0))
        built.apply({"pressure_kpa": p_kpa, "ground_friction": mu})
        assert shared.ramp_end_x_m == built.ramp_end_x_m
        assert np.array_equal(_run_over_ramp_end(shared), _run_over_ramp_end(built))
    if shell_model == "hydroelastic":
        assert shared.cached_shell_count == 3  # the built shell, 5 and 12 kPa: shared by all inclines


def test_set_incline_refuses_an_incline_it_was_not_built_for():
    twin = Twin(TwinConfig(shell_model="point", incline_deg=16, ramp_length_m=4.0, inclines_deg=(12, 16)))
    twin.set_incline(12.0)
    with pytest.raises(ValueError, match=r"incline_deg: value 14 .*allowed: \[12.0, 16.0\]"):
        twin.set_incline(14)
    assert twin.incline_deg == 12.0 and twin.config.incline_deg == 12.0
    assert twin.inclines_deg == (12.0, 16.0)
