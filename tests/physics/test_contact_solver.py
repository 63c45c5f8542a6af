"""The contact solver setting: ``tamsi`` builds a TAMSI plant, for the twin and the env; a solver
the installed Drake does not offer falls back to SAP with one warning line naming the reason."""

import gymnasium as gym
import numpy as np
import pytest
from pydrake.multibody.plant import DiscreteContactApproximation, DiscreteContactSolver

import sphere_env  # noqa: F401  (registers the ids)
from sphere_env.physics import Twin, TwinConfig
from sphere_env.physics import diagram as diagram_module

from .conftest import record

RAMP = dict(incline_deg=16.0, ramp_length_m=4.0)


def test_drake_offers_tamsi_and_sap():
    offered = diagram_module.offered_contact_approximations()
    assert {"sap", "lagged"} <= set(offered)
    assert "tamsi" in offered  # the installed drake 1.51 still has it (deprecated)


@pytest.mark.parametrize("shell_model", ["point", "injected"])
def test_env_with_tamsi_steps_a_tamsi_plant(shell_model):
    env = gym.make("sphere_env/RampDescent-v3", shell_model=shell_model, contact_approximation="tamsi")
    try:
        env.reset(seed=0)
        plant = env.unwrapped.twin.plant
        assert plant.get_discrete_contact_approximation() == DiscreteContactApproximation.kTamsi
        assert plant.get_discrete_contact_solver() == DiscreteContactSolver.kTamsi
        x0 = env.unwrapped.twin.state().position_m.copy()
        for _ in range(25):  # 0.5 s with zero torque: rolls down the ramp
            env.step(np.zeros(2, dtype=np.float32))
        assert env.unwrapped.twin.state().position_m[0] > x0[0] + 0.01
    finally:
        env.close()


def test_default_is_sap_for_rigid_shells():
    plant = Twin(TwinConfig(shell_model="point", **RAMP)).plant
    assert plant.get_discrete_contact_approximation() == DiscreteContactApproximation.kSap


def test_tamsi_not_offered_falls_back_to_sap_with_one_warning(monkeypatch, caplog):
    offered = tuple(a for a in diagram_module.offered_contact_approximations() if a != "tamsi")
    monkeypatch.setattr(diagram_module, "offered_contact_approximations", lambda: offered)
    with caplog.at_level("WARNING", logger="sphere_env"):
        twin = Twin(TwinConfig(shell_model="point", contact_approximation="tamsi", **RAMP))
    lines = [r for r in caplog.records if r.levelname == "WARNING"]
    assert len(lines) == 1
    message = lines[0].getMessage()
    assert "\n" not in message
    assert "'tamsi'" in message and "not offered by the installed Drake" in message and "'sap'" in message
    assert twin.plant.get_discrete_contact_approximation() == DiscreteContactApproximation.kSap
    # the fallback twin simulates exactly as one built with SAP
    _, omega = record(twin, 1.0, field="omega_d")
    _, omega_sap = record(
        Twin(TwinConfig(shell_model="point", contact_approximation="sap", **RAMP)), 1.0, field="omega_d"
    )
    assert omega[-1] > 0.5  # rolling down the ramp
    np.testing.assert_array_equal(omega, omega_sap)
