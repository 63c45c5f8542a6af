"""Task behaviour: physics agreement, baseline vs zero torque, schedules, failures, bad input."""

import math

import numpy as np
import pytest

from sphere_env.controllers import controller_for, run_episode
from sphere_env.physics import InitialState, Twin, TwinConfig
from tests.envs.conftest import ENV_IDS, rollout


def test_info_reward_terms_sum_to_reward(make):
    for env_id in ENV_IDS:
        env = make(env_id, randomization="full")
        steps = rollout(env, 150, seed=2)
        n = 0
        for step in steps:
            if len(step) == 5:
                obs, reward, term, trunc, info = step
                terms = [v for k, v in info.items() if k.startswith("reward_")]
                assert len(terms) >= 3 and math.isclose(sum(terms), reward, rel_tol=1e-12, abs_tol=1e-12)
                for key in ("shell_model", "pressure_kpa", "theta", "phi", "omega_d", "is_success", "params"):
                    assert key in info
                n += 1
        assert n == 150


@pytest.mark.parametrize("shell_model", ["point", "injected"])
def test_zero_torque_ramp_rolls_downhill_like_the_twin(make, shell_model):
    env = make("sphere_env/RampDescent-v1", shell_model=shell_model, randomization="off")
    obs, info = env.reset(seed=0)
    # the shipped calibration, without its drive law as the envs before RampDescent-v4
    twin = Twin(TwinConfig(shell_model=shell_model, incline_deg=16.0, ramp_length_m=4.0, calibration_drive_law=False))
    twin.reset(InitialState())
    x0 = info["position_m"][0]
    for _ in range(60):
        obs, r, term, trunc, info = env.step(np.zeros(2, np.float32))
        twin.advance(0.02, (0.0, 0.0))
        assert obs[6] == pytest.approx(twin.state().omega_d, abs=1e-9)
    assert info["position_m"][0] > x0 + 0.5 and info["omega_d"] > 2.0  # rolled forward, downhill
    assert info["position_m"][2] < twin.robot.radius_m - 0.1


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_baseline_beats_zero_torque(make, env_id):
    env = make(env_id)  # defaults: injected shell, pressure randomized
    seeds, margin = (range(6), 0.25) if "Ramp" in env_id else (range(3), 2.0)
    returns = {}
    for name in ("zero", "pd"):
        ctrl = controller_for(env, name)
        returns[name] = np.mean([run_episode(env, ctrl, seed=s)["return"] for s in seeds])
    assert returns["pd"] > returns["zero"] + margin, returns


def test_pressure_schedule_changes_pressure_and_dynamics(make):
    leak = dict(pressure_kpa=12.0, pressure_schedule={"rate_kpa_per_s": -3.0})
    env = make("sphere_env/Roll-v0", shell_model="injected", randomization=leak)
    ref = make("sphere_env/Roll-v0", shell_model="injected", randomization={"pressure_kpa": 12.0})
    a = rollout(env, 150, seed=1, actions=np.array([0.3, 0.6], np.float32))
    b = rollout(ref, 150, seed=1, actions=np.array([0.3, 0.6], np.float32))
    p = [s[-1]["pressure_kpa"] for s in a[1:]]
    # info reports the pressure applied during the step just simulated (schedule at its start).
    assert p[0] == 12.0 and p[1] == pytest.approx(12.0 - 3.0 * 0.02) and p[-1] < 3.1
    assert all(x >= y for x, y in zip(p, p[1:]))
    assert all(s[-1]["pressure_kpa"] == 12.0 for s in b[1:])
    assert env.unwrapped.twin.pressure_kpa == pytest.approx(p[-1], abs=0.011)  # pushed to the twin
    assert not np.allclose(a[-1][0], b[-1][0], atol=1e-3)  # different dynamics


@pytest.mark.parametrize("reading", ["current", "at_reset"])
def test_the_observed_pressure_follows_a_leak_or_keeps_the_reading_at_reset(make, reading):
    leak = dict(pressure_kpa=12.0, pressure_schedule={"rate_kpa_per_s": -3.0})
    env = make(
        "sphere_env/Roll-v1",
        shell_model="injected",
        randomization=leak,
        observe_pressure=True,
        pressure_reading=reading,
    )
    i = env.unwrapped.observation_layout["pressure_kpa"]
    steps = rollout(env, 100, seed=1, actions=np.array([0.3, 0.6], np.float32))
    observed = np.array([s[0][i] for s in steps[1:]])
    applied = np.array([s[-1]["pressure_kpa"] for s in steps[1:]])
    assert applied[-1] < 9.0  # the shell leaked
    if reading == "at_reset":
        np.testing.assert_allclose(observed, 12.0)
    else:  # the observation is taken after the step, at the pressure the next step uses
        assert observed[-1] == pytest.approx(applied[-1], abs=0.1) and observed[-1] < 9.0


def test_interval_randomization_changes_within_episode(make):
    spec = {
        "ground_friction": {"distribution": "uniform", "low": 0.3, "high": 1.5, "mode": "interval", "interval_s": 0.2}
    }
    env = make("sphere_env/Roll-v0", shell_model="point", randomization=spec)
    steps = rollout(env, 30, seed=0)
    values = {s[-1]["params"]["ground_friction"] for s in steps}
    assert len(values) >= 3


def test_nan_and_inf_actions_raise_naming_the_action(make):
    env = make("sphere_env/Roll-v0", shell_model="point")
    env.reset(seed=0)
    for bad in ([np.nan, 0.0], [0.0, np.inf], [-np.inf, 1.0]):
        with pytest.raises(ValueError, match="action"):
            env.step(np.array(bad, np.float32))
    with pytest.raises(ValueError, match="action"):
        env.step(np.zeros(3))
    obs, *_ = env.step(np.array([1e6, -1e6]))  # clipped, fine
    assert np.all(np.isfinite(obs))


def test_physics_failure_truncates_with_reason(make, monkeypatch):
    env = make("sphere_env/RampDescent-v0", shell_model="point")
    env.reset(seed=0)
    twin = env.unwrapped.twin

    def boom(*args, **kwargs):
        raise RuntimeError("The Hessian of the momentum cost along the search direction is NaN.")

    monkeypatch.setattr(twin, "advance_unchecked", boom)
    obs, reward, term, trunc, info = env.step(np.zeros(2, np.float32))
    assert trunc and not term and reward == 0.0 and "physics_failure" in info["truncation_reason"]
    assert "Hessian" in info["truncation_reason"] and env.observation_space.contains(obs)
    # A diverged (implausible) state is a failure too, detected from the state readout.
    monkeypatch.undo()
    env.reset(options={"initial_state": {"angular_velocity_rad_s": (499.0, 499.0, 499.0)}})
    obs, reward, term, trunc, info = env.step(np.zeros(2, np.float32))
    assert trunc and info["truncation_reason"].startswith("physics_failure")
    assert np.all(np.isfinite(obs))
    obs, info = env.reset(seed=1)  # and the env recovers
    assert np.all(np.isfinite(obs))


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(shell_model="rubber"), "shell_model"),
        (dict(friction_model="sticky"), "friction_model"),
        (dict(calibration="/nonexistent.yaml"), "calibration"),
        (dict(control_frequency_hz=-5), "control_frequency_hz"),
        (dict(control_frequency_hz=33), "control_frequency_hz"),
        (dict(time_step_s=0.0), "time_step_s"),
        (dict(steer_torque_limit_nm=float("nan")), "steer_torque_limit_nm"),
        (dict(drive_torque_limit_nm=0), "drive_torque_limit_nm"),
        (dict(randomization={"pressure": 5}), "randomization"),
        (dict(observation_noise_scale=-1), "observation_noise_scale"),
        (dict(observe_pressure="yes"), "observe_pressure"),
        (dict(incline_deg=60), "incline_deg"),
        (dict(render_mode="vr"), "render_mode"),
        (dict(lane_half_width_m=0), "lane_half_width_m"),
        (dict(omega_ref_range_rad_s=(3, 1)), "omega_ref_range_rad_s"),
        (dict(reward_weights={"fun": 1}), "reward_weights"),
        (dict(no_such_kwarg=1), "no_such_kwarg"),
    ],
)
def test_bad_kwargs_raise_naming_the_kwarg(make, kwargs, name):
    with pytest.raises(ValueError, match=name):
        make("sphere_env/RampDescent-v0", **kwargs)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(command_mode="spin"), "command_mode"),
        (dict(heading_range_rad=7), "heading_range_rad"),
        (dict(command_resample_s=0), "command_resample_s"),
        (dict(randomization={"incline_deg": [10, 12]}), "incline"),
    ],
)
def test_bad_roll_kwargs(make, kwargs, name):
    with pytest.raises(ValueError, match=name):
        make("sphere_env/Roll-v0", **kwargs)


def test_roll_yaw_rate_mode_and_resampling(make):
    env = make("sphere_env/Roll-v0", shell_model="point", command_mode="yaw_rate", command_resample_s=0.5)
    steps = rollout(env, 100, seed=0)
    refs = {(s[-1]["omega_ref"], s[-1]["yaw_rate_ref"]) for s in steps}
    assert len(refs) >= 3  # resampled every 0.5 s
    ctrl = controller_for(env, "pd")
    assert ctrl.command_mode == "yaw_rate"


def test_randomized_parameters_reach_the_physics(make):
    env = make(
        "sphere_env/RampDescent-v0",
        shell_model="point",
        randomization={
            "incline_deg": 12.0,
            "payload_mass_kg": 3.0,
            "ground_friction": 0.8,
            "drive_friction_scale": 1.5,
        },
    )
    obs, info = env.reset(seed=0)
    twin = env.unwrapped.twin
    assert twin.config.incline_deg == 12.0 and info["params"]["incline_deg"] == 12.0
    assert twin.pendulum.CalcSpatialInertiaInBodyFrame(twin.plant_context).get_mass() == pytest.approx(22.03 + 3.0)
    assert (twin.params["steer_friction_scale"], twin.params["drive_friction_scale"]) == (1.0, 1.5)
    env.reset(options={"incline_deg": 16.0, "payload_mass_kg": 0.0})
    twin2 = env.unwrapped.twin
    assert twin2.config.incline_deg == 16.0
    assert twin2.pendulum.CalcSpatialInertiaInBodyFrame(twin2.plant_context).get_mass() == pytest.approx(22.03)


def test_rgb_array_render_headless(make):
    env = make("sphere_env/RampDescent-v0", shell_model="point", render_mode="rgb_array", render_size=(160, 120))
    env.reset(seed=0)
    env.step(np.zeros(2, np.float32))
    frame = env.render()
    assert frame.shape == (120, 160, 3) and frame.dtype == np.uint8 and frame.std() > 1.0


def test_episode_replay_html(make, tmp_path):
    env = make("sphere_env/Roll-v0", shell_model="point", record_replay=True)
    env.reset(seed=0)
    for _ in range(10):
        env.step(np.array([0.2, 0.5], np.float32))
    path = env.unwrapped.save_replay(tmp_path / "episode.html")
    text = path.read_text()
    assert path.stat().st_size > 10_000 and "<html" in text.lower()


def test_human_render_uses_meshcat(make):
    env = make("sphere_env/Roll-v0", shell_model="point", render_mode="human")
    u = env.unwrapped
    assert u.meshcat is not None and u.twin.is_visualized
    env.reset(seed=0)
    env.step(np.zeros(2, np.float32))
    assert env.render() is None


def test_no_meshcat_unless_asked(make):
    env = make("sphere_env/Roll-v0", shell_model="point")
    assert env.unwrapped.meshcat is None and not env.unwrapped.twin.is_visualized


def test_cached_hydroelastic_pressure_is_identical_to_a_fresh_one():
    def run(twin):
        twin.reset(InitialState(theta=0.3))
        for _ in range(30):
            twin.advance(0.02, (3.0, -8.0))
        return twin.state().phi, twin.state().omega_d

    cached = Twin(TwinConfig(shell_model="hydroelastic"))
    fresh = Twin(TwinConfig(shell_model="hydroelastic"))
    # (5, ·) and (12, ·) again are cache hits, also under another ground μ (re-applied after the
    # restore): the cache keys on the shell alone.
    for p, mu in ((5.0, 0.4), (12.0, 0.4), (5.0, 0.4), (5.0, 1.2), (12.0, 1.2), (12.0, 0.7)):
        cached.set_ground_friction(mu)
        cached.set_pressure(p)
        fresh.set_ground_friction(mu)
        fresh.clear_shell_cache()  # force a re-mesh
        fresh.set_pressure(p)
        assert run(cached) == run(fresh)
    assert cached.cached_shell_count == 1 + 2  # the built shell + one per distinct pressure


def test_hydroelastic_shell_cache_stays_within_one_twins_budget(make, monkeypatch):
    """Full randomization (pressure, incline, ground μ, friction scales, payload): one twin serves
    every incline drawn, so the cached shells never exceed one twin's budget, however many
    inclines and pressures the resets draw. (A budget of 6 shells keeps the re-meshing short.)"""
    monkeypatch.setattr(Twin, "GEOMETRY_CACHE_SIZE", 6)
    env = make("sphere_env/RampDescent-v0", shell_model="hydroelastic", randomization="full")
    u = env.unwrapped
    inclines, pressures, mus = set(), set(), set()
    for i in range(30):
        _, info = env.reset(seed=i)
        inclines.add(info["params"]["incline_deg"])
        pressures.add(info["params"]["pressure_kpa"])
        mus.add(info["params"]["ground_friction"])
        assert u.cached_twin_count == 1
        assert u.cached_shell_count <= 6
    assert len(inclines) >= 7 and len(pressures) > 6 and len(mus) == 30
    assert u.cached_shell_count == 6
    # An incline outside the randomization's grid gets its own twin; the shared one is kept.
    env.reset(options={"incline_deg": 13.37})
    assert u.cached_twin_count == 2 and u.twin.incline_deg == 13.37
