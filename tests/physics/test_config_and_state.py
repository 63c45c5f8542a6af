"""Bad input is refused up front; the full state can be set and read back; replays record."""

import math

import numpy as np
import pytest

from sphere_env.physics import InitialState, Twin, TwinConfig

from .conftest import record


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(fixture="clamp"), "fixture"),
        (dict(shell_model="soft"), "shell_model"),
        (dict(steer_friction="sticky"), "joint 'steer'"),
        (dict(drive_friction={"law": "majd", "params": {"f_w": 1.0}}), "majd"),
        (dict(pressure_kpa=float("nan")), "pressure_kpa"),
        (dict(pressure_kpa=1e4), "pressure_kpa"),
        (dict(incline_deg=60), "incline_deg"),
        (dict(time_step_s=0.0), "time_step_s"),
        (dict(contact_approximation="magic"), "contact_approximation"),
        (dict(fixture="stand", incline_deg=10), "incline_deg"),
        (dict(inclines_deg=(12, 40)), "inclines_deg"),
        (dict(inclines_deg="12"), "inclines_deg"),
        (dict(fixture="stand", inclines_deg=(0, 5)), "inclines_deg"),
        (dict(time_step_s="0.005"), "field 'time_step_s' = '0.005'"),  # text is never a number
        (dict(ground_friction=True), "field 'ground_friction' = True"),  # nor is a bool
        (dict(resolution_hint_m=0.0), "resolution_hint_m"),
        (dict(urdf=3), "urdf"),
    ],
)
def test_bad_config_names_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        Twin(TwinConfig(**kwargs))


def test_bad_calibration_path_refused_before_build(tmp_path):
    with pytest.raises(ValueError, match="calibration file"):
        Twin(TwinConfig(calibration=tmp_path / "nope.yaml"))


@pytest.mark.parametrize(
    "initial, field",
    [
        (dict(theta=float("nan")), "initial_state.theta"),
        (dict(roll=float("inf")), "initial_state.roll"),
        (dict(velocity_m_s=(0.0, float("nan"), 0.0)), "initial_state.velocity_m_s"),
        (dict(position_m=(0.0, 0.0)), "initial_state.position_m"),
        (dict(theta="0.1"), "field 'initial_state.theta' = '0.1'"),
        (dict(drive_rate=True), "field 'initial_state.drive_rate' = True"),
    ],
)
def test_non_finite_initial_state_refused_and_twin_untouched(initial, field):
    twin = Twin(TwinConfig())
    twin.reset(InitialState(theta=0.2))
    before = twin.positions_velocities()
    with pytest.raises(ValueError, match=field):
        twin.reset(InitialState(**initial))
    after = twin.positions_velocities()
    np.testing.assert_array_equal(before[0], after[0])
    np.testing.assert_array_equal(before[1], after[1])


def test_set_pressure_out_of_range_keeps_old_pressure():
    twin = Twin(TwinConfig(shell_model="injected"))
    p0 = twin.pressure_kpa
    for bad in (float("nan"), -3.0, twin.calibration.pressure_range_kpa[1] + 1):
        with pytest.raises(ValueError, match="pressure_kpa"):
            twin.set_pressure(bad)
    assert twin.pressure_kpa == p0


def test_non_finite_torque_refused():
    twin = Twin(TwinConfig())
    with pytest.raises(ValueError, match="motor_torque_nm"):
        twin.advance(0.02, (float("nan"), 0.0))


def test_full_initial_state_round_trip():
    twin = Twin(TwinConfig(shell_model="point"))
    init = InitialState(
        theta=0.3,
        drive_angle=0.7,
        roll=0.1,
        heading=0.5,
        theta_dot=0.2,
        drive_rate=-0.4,
        position_m=(1.0, 2.0, 0.31),
        angular_velocity_rad_s=(0.0, 0.0, 0.3),
        velocity_m_s=(0.1, 0.0, 0.0),
    )
    s = twin.reset(init)
    assert (s.theta, s.theta_dot, s.drive_angle, s.drive_rate) == pytest.approx((0.3, 0.2, 0.7, -0.4))
    assert s.phi == pytest.approx(0.1)
    assert s.heading == pytest.approx(0.5)
    assert s.heading_rate == pytest.approx(0.3)
    np.testing.assert_allclose(s.position_m, (1.0, 2.0, 0.31))
    np.testing.assert_allclose(s.velocity_m_s, (0.1, 0.0, 0.0), atol=1e-12)
    # ω_d = ω_WP·ŷ: the pipe spins at −drive_rate about ŷ relative to the pitch center
    y_W = np.array([-math.sin(0.5) * math.cos(0.1), math.cos(0.5) * math.cos(0.1), math.sin(0.1)])
    assert s.omega_d == pytest.approx(np.dot([0.0, 0.0, 0.3], y_W) + 0.4)
    np.testing.assert_allclose(np.linalg.norm(s.gravity_in_pipe), 1.0)


@pytest.mark.parametrize("ramp_length_m", [None, 1.0])
def test_state_readout_agrees_with_drake_kinematics(ramp_length_m):
    """state() uses float math on [q; v]; check it against Drake's own body poses and velocities."""
    twin = Twin(TwinConfig(shell_model="injected", incline_deg=16.0, ramp_length_m=ramp_length_m))
    twin.reset(InitialState(theta=0.3, roll=0.2, heading=0.4, drive_angle=0.5))
    rng = np.random.default_rng(0)
    plant, ctx = twin.plant, twin.plant_context
    for _ in range(60):
        twin.advance(0.02, (rng.uniform(-10, 10), rng.uniform(-15, 15)))
        s = twin.state()
        R_WPC = plant.EvalBodyPoseInWorld(ctx, twin.pc).rotation().matrix()
        X_WP = plant.EvalBodyPoseInWorld(ctx, twin.pipe)
        V_WP = plant.EvalBodySpatialVelocityInWorld(ctx, twin.pipe)
        V_WPC = plant.EvalBodySpatialVelocityInWorld(ctx, twin.pc)
        y_W = R_WPC[:, 1]
        n_W = np.array(twin.terrain.normal_at(X_WP.translation()))
        np.testing.assert_allclose(s.position_m, X_WP.translation(), atol=1e-12)
        np.testing.assert_allclose(s.velocity_m_s, V_WP.translational(), atol=1e-12)
        np.testing.assert_allclose(s.gravity_in_pipe, X_WP.rotation().matrix().T @ [0, 0, -1], atol=1e-12)
        assert s.omega_d == pytest.approx(V_WP.rotational() @ y_W, abs=1e-9)
        assert s.phi == pytest.approx(math.asin(y_W @ n_W), abs=1e-9)
        f = np.cross(y_W, [0, 0, 1.0])
        assert s.heading == pytest.approx(math.atan2(f[1], f[0]), abs=1e-9)
        y_dot = np.cross(V_WPC.rotational(), y_W)
        assert s.phi_dot == pytest.approx((y_dot @ n_W) / math.sqrt(1 - (y_W @ n_W) ** 2), abs=1e-9)


def test_pendulum_pitch_readout_agrees_with_drake_kinematics():
    """α = atan2(−ẑ_W·x̂_PC, ẑ_W·ẑ_PC) from Drake's pose; α̇ matches its finite difference; upright,
    ω_d = α̇ − q̇_d."""
    twin = Twin(TwinConfig(shell_model="injected"))
    twin.reset(InitialState(pitch=0.3, roll=0.2))
    s = twin.state()
    assert s.pendulum_pitch == pytest.approx(math.atan2(math.sin(0.3), math.cos(0.3) * math.cos(0.2)), abs=1e-12)
    twin.reset(InitialState(theta=0.2, heading=0.7))
    rng = np.random.default_rng(1)
    plant, ctx = twin.plant, twin.plant_context
    probe = plant.CreateDefaultContext()

    def alpha_at(q):  # α from Drake's pose of the pitch center
        plant.SetPositions(probe, q)
        R = plant.EvalBodyPoseInWorld(probe, twin.pc).rotation().matrix()
        return math.atan2(-R[2, 0], R[2, 2])

    for _ in range(30):
        twin.advance(0.02, (rng.uniform(-5, 5), rng.uniform(-20, 20)))
        s = twin.state()
        q, v = twin.positions_velocities()
        assert s.pendulum_pitch == pytest.approx(alpha_at(q), abs=1e-12)
        q_dot, eps = plant.MapVelocityToQDot(ctx, v), 1e-6  # central difference along the motion
        rate = (alpha_at(q + eps * q_dot) - alpha_at(q - eps * q_dot)) / (2 * eps)
        assert s.pendulum_pitch_rate == pytest.approx(rate, abs=1e-6)
    upright = Twin(TwinConfig(shell_model="point", fixture="free"))
    upright.reset(InitialState(pitch=0.2, drive_rate=1.5, angular_velocity_rad_s=(0.0, 0.8, 0.0)))
    s = upright.state()
    assert s.omega_d == pytest.approx(s.pendulum_pitch_rate - s.drive_rate, abs=1e-12)


def test_driving_forward_lifts_the_pendulum_forward():
    """Driving forward on flat ground holds the pendulum lifted toward the motion: α < 0 while
    ω_d > 0 (the real robot's log shows pitch_joint < 0 while drive_shaft turns > 0)."""
    twin = Twin(TwinConfig(shell_model="injected"))
    twin.reset()
    _, alpha = record(twin, 2.0, field="pendulum_pitch", torque=(0.0, -12.0))  # + drive = −joint torque
    s = twin.state()
    assert s.omega_d > 0.5 and np.all(alpha[10:] < -0.05)
    for fixture in ("stand", "steer_plane"):  # no pitch freedom: α = 0
        t = Twin(TwinConfig(shell_model="point", fixture=fixture))
        t.reset(InitialState(theta=0.3))
        t.advance(0.1)
        assert (t.state().pendulum_pitch, t.state().pendulum_pitch_rate) == (0.0, 0.0)


def test_rolling_forward_gives_positive_drive_velocity():
    twin = Twin(TwinConfig(shell_model="point", incline_deg=16, steer_friction="none", drive_friction="none"))
    twin.reset()
    record(twin, 1.0)
    s = twin.state()
    assert s.position_m[0] > 0.05 and s.omega_d > 0  # downhill is +x; ω_d > 0 rolling forward
    # and ω_d R equals the centre speed (rolling without slip)
    assert s.omega_d * twin.robot.radius_m == pytest.approx(np.linalg.norm(s.velocity_m_s), rel=0.02)


def test_reset_reuses_diagram_and_is_repeatable():
    twin = Twin(TwinConfig(shell_model="injected", incline_deg=16))
    runs = []
    for _ in range(2):
        twin.reset(InitialState(theta=0.1))
        record(twin, 0.5, torque=(1.0, -2.0))
        runs.append(twin.positions_velocities())
    np.testing.assert_array_equal(runs[0][0], runs[1][0])
    np.testing.assert_array_equal(runs[0][1], runs[1][1])


def test_meshcat_replay_is_self_contained_html(tmp_path):
    from sphere_env.physics import start_meshcat

    meshcat = start_meshcat()
    twin = Twin(TwinConfig(shell_model="point", incline_deg=16), meshcat=meshcat)
    twin.reset()
    twin.start_recording()
    record(twin, 0.5)
    path = twin.save_recording(tmp_path / "replay.html")
    html = path.read_text()
    assert html.startswith("<!DOCTYPE html>") or "<html" in html[:200]
    assert "animation" in html and len(html) > 10_000
    assert "localhost" not in html.split("<script")[0]  # no live server needed to view it


def test_hydroelastic_at_another_step_than_fitted_warns(caplog, tmp_path):
    import yaml

    from sphere_env.models.calibration_files import DEFAULT_CALIBRATION

    with caplog.at_level("WARNING", logger="sphere_env"):
        Twin(TwinConfig(shell_model="hydroelastic", time_step_s=0.002))
    assert "refit k_d" in caplog.text.lower()
    caplog.clear()
    data = yaml.safe_load(DEFAULT_CALIBRATION.read_text())
    del data["hydroelastic"]["fitted_time_step_s"]  # optional: older files have no record
    path = tmp_path / "cal.yaml"
    path.write_text(yaml.safe_dump(data))
    with caplog.at_level("WARNING", logger="sphere_env"):
        Twin(TwinConfig(shell_model="hydroelastic", time_step_s=0.002, calibration=path))
    assert "refit" not in caplog.text.lower()
