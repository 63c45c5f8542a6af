import numpy as np
import pytest

from sphere_env.models.friction import FRICTION_LAWS, FrictionModel, load_friction_presets, majd, resolve_friction

STEER = dict(f_w=0.20, f_c=0.45, sigma=10.0, omega_c=0.1, n=1.0)
DRIVE = dict(f_w=1.78, f_c=1.24, sigma=8.33, omega_c=1.36, n=1.60)


@pytest.mark.parametrize("p", [STEER, DRIVE])
def test_majd_continuous_at_zero(p):
    eps = np.array([1e-9, 1e-7, 1e-5])
    assert np.all(np.abs(majd(eps, **p)) < 1e-3)
    assert np.all(np.abs(majd(-eps, **p)) < 1e-3)
    assert majd(0.0, **p) == 0.0


@pytest.mark.parametrize("p", [STEER, DRIVE])
def test_majd_odd_and_resisting(p):
    v = np.linspace(0.001, 20, 500)
    np.testing.assert_allclose(majd(-v, **p), -majd(v, **p), rtol=0, atol=1e-12)
    assert np.all(majd(v, **p) < 0)  # resists motion


@pytest.mark.parametrize("p", [STEER, DRIVE])
def test_majd_tends_to_viscous_plus_coulomb(p):
    v = np.array([50.0, 100.0, -80.0])
    np.testing.assert_allclose(majd(v, **p), -(p["f_w"] * v + p["f_c"] * np.sign(v)), rtol=1e-6)


def test_coulomb_regularized_smooth_and_levels():
    m = FrictionModel("coulomb", dict(mu_s=0.7, mu_d=0.65, c=0.104, v_tol=0.05))
    v = np.linspace(-1, 1, 20001)
    tau = m.torque(v)
    assert np.max(np.abs(np.diff(tau))) < 0.01  # no jump anywhere on a 1e-4 rad/s grid
    assert abs(m.torque(0.0)) == 0.0
    # well above the stick band: kinetic + viscous, as eq. 2
    np.testing.assert_allclose(m.torque(1.0), -(0.65 + 0.104), rtol=1e-3)
    # inside the stick band the resisting torque rises to (nearly) the static level μ_s
    band = (v > 0) & (v <= 0.05)
    assert 0.6 < -tau[band].min() <= 0.7 + 0.104 * 0.05


def test_presets_load_table_one():
    presets = load_friction_presets()
    for name in ("viscous_steer", "coulomb_steer", "majd_steer", "majd_drive"):
        assert name in presets
    assert presets["majd_drive"].params == pytest.approx(DRIVE)
    assert presets["viscous_steer"].params == {"c": pytest.approx(0.104)}
    assert resolve_friction("majd", "drive") == presets["majd_drive"]
    assert resolve_friction("none", "steer").law == "none"


@pytest.mark.parametrize(
    "spec, match",
    [
        (
            "stribeck",
            r"joint 'steer': name = 'stribeck': .*; allowed: a preset or law name \[.*'majd', 'majd_drive', "
            r"'majd_steer'.*'none'.*\]",
        ),
        (5, r"joint 'steer': name = 5: .*; allowed: a preset or law name \["),
        ({"law": "majd", "params": {"f_w": 1}}, "missing"),
        ({"law": "viscous", "params": {"c": -1.0}}, r"params.c. = -1.0.*>= 0"),
        ({"law": "viscous", "parms": {"c": 1.0}}, "unknown field .parms."),
        ({"law": "viscous", "params": {"c": "1"}}, r"params.c. = .1.: Input should be a valid number"),
        ({"law": "viscous", "params": {"c": float("nan")}}, "finite"),
    ],
)
def test_bad_friction_specs(spec, match):
    with pytest.raises(ValueError, match=match):
        resolve_friction(spec, "steer")


def test_every_law_is_resisting_or_zero():
    v = np.linspace(-5, 5, 101)
    for law, (_, names) in FRICTION_LAWS.items():
        params = {"c": 0.1, "mu_s": 0.7, "mu_d": 0.65, "v_tol": 0.05, **STEER}
        tau = FrictionModel(law, {k: params[k] for k in names}).torque(v)
        assert np.all(tau * v <= 1e-15), law
