"""Task functions are pure: tested here without Drake."""

import math
import re
from types import SimpleNamespace

import numpy as np
import pytest

from sphere_env.params import ParameterSpace
from sphere_env.tasks import RollTask, observation, rewards, termination
from sphere_env.tasks.randomization import RandomizationSpec, schedule_pressure

#: The parameter space of a calibration whose pressure range is [3, 14] kPa.
SPACE = ParameterSpace.for_calibration(3.0, 14.0)


def fake_state(**kw):
    base = dict(
        time_s=0.0,
        theta=0.1,
        theta_dot=0.2,
        drive_angle=7.0,
        drive_rate=-1.0,
        phi=0.05,
        phi_dot=0.3,
        omega_d=2.0,
        heading=0.1,
        heading_rate=0.4,
        position_m=np.array([1.0, 0.2, 0.3]),
        velocity_m_s=np.array([0.5, 0.0, 0.0]),
        gravity_in_pipe=np.array([0.0, 0.0, -1.0]),
        pressure_kpa=5.0,
    )
    base.update(kw)
    return SimpleNamespace(**base)


def test_observation_layout_units_and_wrap():
    s = fake_state()
    obs = observation.assemble_observation(s, [3.0, -0.1], pressure_kpa=6.5)
    assert obs.dtype == np.float32 and obs.shape == (observation.N_MEASURED + 3,)
    assert len(observation.MEASURED_COMPONENTS) == observation.N_MEASURED == 11
    assert obs[2] == pytest.approx(7.0 - 2 * math.pi, abs=1e-6)  # drive angle wrapped to [-π, π)
    assert obs[6] == pytest.approx(2.0) and obs[7] == pytest.approx(0.4)
    assert list(obs[-3:]) == pytest.approx([3.0, -0.1, 6.5])
    noisy = observation.assemble_observation(s, [3.0], noise=np.full(11, 0.5))
    assert noisy[0] == pytest.approx(0.6) and noisy[11] == pytest.approx(3.0)  # command not noised


@pytest.mark.parametrize("angle", [-7.0, -math.pi, 0.0, 3.0, math.pi, 10.0])
def test_wrap_angle(angle):
    w = observation.wrap_angle(angle)
    assert -math.pi <= w < math.pi and math.isclose(math.cos(w), math.cos(angle), abs_tol=1e-12)


def test_reward_terms_signs_and_peak():
    w = rewards.RampRewardWeights()
    on = rewards.ramp_descent_terms(w, 0.02, 3.0, 3.0, 0.0, 0.0, (0.0, 0.0), False, False)
    off = rewards.ramp_descent_terms(w, 0.02, 5.0, 3.0, 0.5, 0.3, (1.0, -1.0), True, True)
    assert on["speed"] == pytest.approx(0.02) and on["lateral"] == on["heading"] == on["ctrl"] == 0.0
    assert off["speed"] < on["speed"] and off["lateral"] < 0 and off["heading"] < 0 and off["ctrl"] < 0
    assert off["success"] == w.success and off["off_ramp"] == -w.off_ramp
    r = rewards.roll_terms(rewards.RollRewardWeights(), 0.02, 1.0, 1.0, 0.0, (0.0, 0.0))
    assert r == {"speed": pytest.approx(0.02), "heading": pytest.approx(0.02), "ctrl": 0.0}
    assert rewards.gaussian_tolerance(1.0, 1.0) == pytest.approx(math.exp(-0.5))


def test_reward_weights_validation():
    assert rewards.load_weights(rewards.RollRewardWeights, {"speed": 2}).speed == 2.0
    assert rewards.load_weights(rewards.RollRewardWeights, None) == rewards.RollRewardWeights()
    with pytest.raises(ValueError, match="unknown field 'bogus'"):
        rewards.load_weights(rewards.RollRewardWeights, {"bogus": 1.0})
    for bad in (float("nan"), "2", True):  # not finite, text, a bool: never a weight
        with pytest.raises(ValueError, match="field 'speed' = "):
            rewards.load_weights(rewards.RollRewardWeights, {"speed": bad})
    with pytest.raises(ValueError, match="reward_weights.speed"):  # through the task's kwarg
        RollTask(reward_weights={"speed": "2"})


def test_termination():
    assert termination.ramp_status([3.9, 0.0, 0], 3.8, 1.0) == (True, False)
    assert termination.ramp_status([1.0, -1.2, 0], 3.8, 1.0) == (False, True)
    assert termination.physics_failure(fake_state()) is None
    assert "non-finite" in termination.physics_failure(fake_state(omega_d=float("nan")))
    assert "speed" in termination.physics_failure(fake_state(velocity_m_s=np.array([1e3, 0, 0])))


def test_randomization_presets_and_sampling_are_seeded():
    spec = RandomizationSpec.parse("default").resolved(SPACE)
    a = spec.sample(np.random.default_rng(1))
    assert a == spec.sample(np.random.default_rng(1)) and 3.0 <= a["pressure_kpa"] <= 14.0
    assert a != spec.sample(np.random.default_rng(2))
    assert RandomizationSpec.parse("off").sample(np.random.default_rng(0)) == {}
    full = RandomizationSpec.parse("full").resolved(SPACE)
    vals = full.sample(np.random.default_rng(0))
    assert set(vals) >= {"pressure_kpa", "ground_friction", "payload_mass_kg", "payload_com_offset_m", "incline_deg"}
    assert len(vals["payload_com_offset_m"]) == 3 and full.pressure_schedule is not None
    assert "incline_deg" not in RandomizationSpec.parse("full", ramp=False).resolved(SPACE).sample(
        np.random.default_rng(0)
    )


def test_randomization_mapping_formats():
    spec = RandomizationSpec.parse(
        {
            "pressure_kpa": [4.0, 8.0],
            "ground_friction": {
                "distribution": "normal",
                "mean": 1.0,
                "std": 0.1,
                "mode": "interval",
                "interval_s": 0.5,
            },
            "payload_mass_kg": 2.0,
            "pressure_schedule": {"rate_kpa_per_s": -0.1, "delay_s": 1.0},
        }
    ).resolved(SPACE)
    modes = {t.parameter: t.mode for t in spec.terms}
    assert modes == {"pressure_kpa": "reset", "ground_friction": "interval", "payload_mass_kg": "reset"}
    assert spec.sample(np.random.default_rng(0))["payload_mass_kg"] == 2.0
    assert set(spec.sample(np.random.default_rng(0), "interval")) == {"ground_friction"}
    assert spec.pressure_schedule.delay_s == 1.0


@pytest.mark.parametrize(
    "bad, match",
    [
        ({"bogus": 1.0}, "unknown field 'bogus'"),
        (
            {"pressure_kpa": [1.0, 8.0]},
            re.escape(
                "field 'pressure_kpa' = 1.0: Input should be greater than or equal to 3; "
                "allowed: [3.0, 14.0] kPa, the calibrated range"
            ),
        ),
        (
            {"ground_friction": {"distribution": "uniform", "low": 1.5, "high": 1.0}},
            re.escape(
                "field 'ground_friction' = {'distribution': 'uniform', 'low': 1.5, 'high': 1.0}: low 1.5 is above "
                "high 1.0; allowed: "
            ),
        ),
        (
            {"ground_friction": [1.2, 0.8]},
            re.escape("field 'ground_friction' = [1.2, 0.8]: low 1.2 is above high 0.8; allowed: "),
        ),
        (
            {"payload_com_offset_m": [[0.1, 0.0, 0.0], [0.0, 0.1, 0.1]]},
            re.escape(
                "field 'payload_com_offset_m' = [[0.1, 0.0, 0.0], [0.0, 0.1, 0.1]]: low [0.1, 0.0, 0.0] is above high "
                "[0.0, 0.1, 0.1]; allowed: "
            ),
        ),
        (
            {"incline_deg": {"distribution": "uniform", "low": 10, "high": 12, "mode": "interval", "interval_s": 1}},
            "interval",
        ),
        ({"ground_friction": {"distribution": "uniform", "low": 0.5, "high": 1.0, "mode": "interval"}}, "interval_s"),
        ({"payload_mass_kg": -1.0}, "field 'payload_mass_kg' = -1.0: Input should be greater than or equal to 0"),
        ({"pressure_schedule": {"rate": 1}}, "pressure_schedule"),
        ("sometimes", "field 'base' = 'sometimes'"),
    ],
)
def test_randomization_bad_specs_name_the_field(bad, match):
    with pytest.raises(ValueError, match=match) as err:
        RandomizationSpec.parse(bad).resolved(SPACE)
    assert "randomization" in str(err.value)


def test_pressure_schedule_leaks_and_clips():
    assert schedule_pressure(10.0, -1.0, 0.0, 2.0, SPACE) == pytest.approx(8.0)
    assert schedule_pressure(10.0, -1.0, 1.0, 0.5, SPACE) == 10.0
    assert schedule_pressure(4.0, -1.0, 0.0, 10.0, SPACE) == 3.0


def test_speed_linear_term_pulls_where_the_gaussian_is_flat():
    """Far from the command the gaussian speed term barely changes with the error; the opt-in
    speed_linear term rises by the same amount per rad/s at every error inside its margin, never
    goes below 0 (no reward for ending early), and is 0 by default."""
    default = rewards.RampRewardWeights()
    w = rewards.RampRewardWeights(speed_linear=0.5, speed_linear_margin=5.0)

    def total(weights, omega_d):
        return sum(rewards.ramp_descent_terms(weights, 0.02, omega_d, 3.0, 0.0, 0.0, (0.0, 0.0), False, False).values())

    def linear(weights, omega_d):
        return rewards.ramp_descent_terms(weights, 0.02, omega_d, 3.0, 0.0, 0.0, (0.0, 0.0), False, False)[
            "speed_linear"
        ]

    assert linear(default, 7.0) == 0.0
    flat = total(default, 7.0) - total(default, 8.0)  # 4 → 5 rad/s too fast
    pulled = total(w, 7.0) - total(w, 8.0)
    assert 0.0 < flat < 1e-5
    assert pulled == pytest.approx(flat + 0.5 * 0.02 / 5.0, rel=1e-6)
    assert total(w, 3.0) - total(w, 4.0) > total(default, 3.0) - total(default, 4.0)
    assert linear(w, 3.0) == pytest.approx(0.5 * 0.02)
    assert linear(w, 9.0) == linear(w, -5.0) == 0.0  # beyond the margin: 0, never negative
    with pytest.raises(ValueError, match="speed_linear_margin"):
        rewards.load_weights(rewards.RampRewardWeights, {"speed_linear_margin": 0.0})
