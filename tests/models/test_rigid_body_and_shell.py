import math

import numpy as np
import pytest
import yaml

from sphere_env.models.calibration_files import DEFAULT_CALIBRATION
from sphere_env.models.rigid_body import RobotParameters
from sphere_env.models.shell import ShellCalibration, membrane_contact_volume_m3


def test_equivalents_match_design_figures():
    r = RobotParameters.from_urdf()
    # docs/design.md §1/§5 figures (computed there from Table II; we compute from the URDF).
    assert r.m_total == pytest.approx(41.35, abs=0.01)
    assert r.weight_n == pytest.approx(405.6, abs=0.1)
    assert r.K_eq == pytest.approx(21.9, abs=0.05)
    assert r.omega_point_rad_s == pytest.approx(2.29, abs=0.01)
    assert r.omega_stand_rad_s == pytest.approx(5.66, abs=0.01)


def test_m_eq_is_inertia_about_contact_point():
    # M_eq = I_eq − 2 (m r) R equals the inertia about the contact point of the rigid
    # (θ = 0) body: Σ I_i + m_i (R − r_i)² (+ the small lateral COM offset).
    r = RobotParameters.from_urdf()
    R = r.radius_m
    direct = 0.0
    for link in r.links.values():
        _, y, z = link.com_m
        direct += link.inertia_kgm2[0] + link.mass_kg * (y * y + (R + z) ** 2)
    assert r.M_eq == pytest.approx(direct, rel=1e-12)


def test_uniform_ball_formula_is_the_d_zero_limit():
    r = RobotParameters.from_urdf()
    alpha = math.radians(16)
    # With d -> 0 the exact locked-rolling dynamics reduce to the textbook formula.
    import dataclasses

    links = {k: dataclasses.replace(v, com_m=(0.0, 0.0, 0.0)) for k, v in r.links.items()}
    ball = dataclasses.replace(r, links=links)
    acc = ball.radius_m * ball.locked_rolling_rhs(alpha)(0.0, [0.3, 0.0])[1]
    assert acc == pytest.approx(ball.uniform_ball_rolling_acceleration_m_s2(alpha), rel=1e-12)


def test_membrane_volume_shrinks_with_pressure_and_matches_small_flat_limit():
    r = RobotParameters.from_urdf()
    v = [membrane_contact_volume_m3(p, r.weight_n, r.radius_m) for p in (3, 6, 12)]
    assert v[0] > v[1] > v[2] > 0
    # small-flat limit δ ≈ a²/(2R), V ≈ π δ² R
    p = 200.0
    a2 = r.weight_n / (p * 1e3) / math.pi
    delta = a2 / (2 * r.radius_m)
    assert membrane_contact_volume_m3(p, r.weight_n, r.radius_m) == pytest.approx(
        math.pi * delta**2 * r.radius_m, rel=0.01
    )


def test_default_calibration_loads_and_gains_follow_eq_7_8():
    cal = ShellCalibration.load()
    r = RobotParameters.from_urdf()
    p = cal.nominal_pressure_kpa
    shell = cal.bind(r)
    K, C = shell.injected_gains(p)
    wn, z = float(cal.omega_n(p)), float(cal.zeta(p))
    assert K == pytest.approx(wn**2 * r.M_eq - r.K_eq)
    assert C == pytest.approx(2 * r.M_eq * wn * z)
    modulus, d = shell.hydroelastic(p)
    assert modulus == pytest.approx(r.weight_n / cal.volume_m3(p, r.weight_n, r.radius_m))  # eq. 10
    if cal.volume_model == "membrane":  # the shipped V(p) is the membrane estimate of docs/design.md §5
        assert cal.volume_m3(p, r.weight_n, r.radius_m) == pytest.approx(
            membrane_contact_volume_m3(p, r.weight_n, r.radius_m)
        )
    else:
        pk, vm = cal.volume_table
        assert cal.volume_m3(p, r.weight_n, r.radius_m) == pytest.approx(float(np.interp(p, pk, vm)))
    assert d == pytest.approx(cal.k_d * C)


def _write(tmp_path, data):
    path = tmp_path / "cal.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize(
    "mutate, match",
    [
        (lambda d: d.pop("omega_n"), "'omega_n' is missing"),
        (lambda d: d["zeta"].pop("scale"), "'zeta.scale' is missing"),
        (lambda d: d.__setitem__("pressure_range_kpa", [10, 5]), "pressure_range_kpa"),
        (
            lambda d: d["omega_n"].__setitem__("intercept_rad_s", "fast"),
            "field 'omega_n.intercept_rad_s' = 'fast': Input should be a valid number",
        ),
        (lambda d: d["contact_volume"].__setitem__("model", "guess"), "contact_volume.model"),
        (lambda d: d["zeta"].__setitem__("scale", 5.0), "zeta"),
    ],
)
def test_malformed_calibration_is_refused(tmp_path, mutate, match):
    data = yaml.safe_load(DEFAULT_CALIBRATION.read_text())
    mutate(data)
    with pytest.raises(ValueError, match=match):
        ShellCalibration.load(_write(tmp_path, data))


def test_unreadable_calibration_is_refused(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("omega_n: [unclosed")
    with pytest.raises(ValueError, match="cannot read"):
        ShellCalibration.load(bad)
    with pytest.raises(ValueError, match="cannot read"):
        ShellCalibration.load(tmp_path / "missing.yaml")


@pytest.mark.parametrize("p", [float("nan"), float("inf"), -1.0, 1e6, "high"])
def test_pressure_outside_range_is_refused(p):
    cal = ShellCalibration.load()
    with pytest.raises(ValueError, match="pressure_kpa"):
        cal.check_pressure(p)
