"""Hostile inputs at the environment boundary, one pytest case each, for every env id × shell model.

Each bad ``gym.make`` kwarg, randomization spec, ``reset`` option or seed, and action must raise
``ValueError`` naming its field. A refused ``reset`` or ``step`` must leave the running episode as it
was: afterwards the env and an identical twin env that never saw the input step on together and
must return identical observations, rewards and parameters. ``step()`` after an episode ended, or
on a copy made mid-episode, raises ``RuntimeError`` asking for a reset; configurations whose
explicit torques diverge at the plant step are refused at ``gym.make``.

Cases of the point shell run in ``make test-fast``; the injected and hydroelastic shells repeat
them (each with its own twin, contact model and caches) and are marked ``slow``.
"""

from __future__ import annotations

import copy
import pickle
import re

import gymnasium as gym
import numpy as np
import pytest
import yaml

import sphere_env  # noqa: F401  (registers the ids)
from sphere_env.params import SHELL_MODELS
from sphere_env.resources import asset_path

RAMP, ROLL = "sphere_env/RampDescent-v0", "sphere_env/Roll-v0"
ENV_IDS = (RAMP, ROLL)
NAN = float("nan")
ZERO = np.zeros(2, np.float32)


def _short(env_id: str) -> str:
    return env_id.split("/")[1]


# ---- gym.make kwargs: (id, kwargs, field the error must name) -------------------------------------
KWARGS = [
    ("shell_model-unknown", dict(shell_model="rubber"), "shell_model"),
    ("shell_model-None", dict(shell_model=None), "shell_model"),
    ("friction_model-unknown", dict(friction_model="sticky"), "friction_model"),
    ("friction_model-int", dict(friction_model=3), "friction_model"),
    (
        "friction_model-negative-viscous-c",
        dict(friction_model={"law": "viscous", "params": {"c": -1.0}}),
        "friction_model",
    ),
    ("friction_model-viscous-c300", dict(friction_model={"law": "viscous", "params": {"c": 300.0}}), "friction_model"),
    (
        "friction_model-drive-viscous-c1e4",
        dict(friction_model={"drive": {"law": "viscous", "params": {"c": 1e4}}}),
        "friction_model",
    ),
    ("calibration-missing-file", dict(calibration="/nonexistent/cal.yaml"), "calibration"),
    ("calibration-int", dict(calibration=123), "calibration"),
    ("control_frequency_hz-zero", dict(control_frequency_hz=0), "control_frequency_hz"),
    ("control_frequency_hz-nan", dict(control_frequency_hz=NAN), "control_frequency_hz"),
    ("control_frequency_hz-string", dict(control_frequency_hz="fast"), "control_frequency_hz"),
    ("control_frequency_hz-33", dict(control_frequency_hz=33.0), "control_frequency_hz"),
    ("control_frequency_hz-1e9", dict(control_frequency_hz=1e9), "control_frequency_hz"),
    ("time_step_s-zero", dict(time_step_s=0.0), "time_step_s"),
    ("time_step_s-1s", dict(time_step_s=1.0), "time_step_s"),
    ("time_step_s-string", dict(time_step_s="x"), "time_step_s"),
    ("steer_torque_limit_nm-zero", dict(steer_torque_limit_nm=0.0), "steer_torque_limit_nm"),
    ("steer_torque_limit_nm-1e9", dict(steer_torque_limit_nm=1e9), "steer_torque_limit_nm"),
    ("drive_torque_limit_nm-negative", dict(drive_torque_limit_nm=-1.0), "drive_torque_limit_nm"),
    ("drive_torque_limit_nm-nan", dict(drive_torque_limit_nm=NAN), "drive_torque_limit_nm"),
    ("observe_pressure-string", dict(observe_pressure="yes"), "observe_pressure"),
    ("observe_pressure-int", dict(observe_pressure=1), "observe_pressure"),
    ("observation_noise_scale-negative", dict(observation_noise_scale=-1.0), "observation_noise_scale"),
    ("observation_noise_scale-1e40", dict(observation_noise_scale=1e40), "observation_noise_scale"),
    ("observation_noise_scale-nan", dict(observation_noise_scale=NAN), "observation_noise_scale"),
    ("observation_noise_scale-string", dict(observation_noise_scale="x"), "observation_noise_scale"),
    ("incline_deg-45", dict(incline_deg=45.0), "incline_deg"),
    ("incline_deg-negative", dict(incline_deg=-1.0), "incline_deg"),
    ("incline_deg-nan", dict(incline_deg=NAN), "incline_deg"),
    ("render_mode-unknown", dict(render_mode="x"), "render_mode"),
    ("record_replay-string", dict(record_replay="yes"), "record_replay"),
    ("render_size-1x1", dict(render_size=(1, 1)), "render_size"),
    ("render_size-string", dict(render_size="big"), "render_size"),
    ("render_size-1e9-wide", dict(render_size=(10**9, 10)), "render_size"),
    (
        "hydroelastic_pressure_step_kpa-negative",
        dict(hydroelastic_pressure_step_kpa=-1.0),
        "hydroelastic_pressure_step_kpa",
    ),
    ("hydroelastic_pressure_step_kpa-10", dict(hydroelastic_pressure_step_kpa=10.0), "hydroelastic_pressure_step_kpa"),
    ("unknown-kwarg", dict(bogus=1), "bogus"),
    ("omega_ref_range_rad_s-reversed", dict(omega_ref_range_rad_s=(8.0, 4.0)), "omega_ref_range_rad_s"),
    ("omega_ref_range_rad_s-1e9", dict(omega_ref_range_rad_s=(0.0, 1e9)), "omega_ref_range_rad_s"),
    ("omega_ref_range_rad_s-string", dict(omega_ref_range_rad_s="fast"), "omega_ref_range_rad_s"),
    ("reward_weights-unknown-term", dict(reward_weights={"bogus": 1.0}), "reward_weights"),
    ("reward_weights-nan", dict(reward_weights={"speed": NAN}), "speed"),
    ("reward_weights-string", dict(reward_weights="x"), "reward_weights"),
]
KWARGS_BY_ENV = {
    RAMP: KWARGS
    + [
        ("ramp_length_m-zero", dict(ramp_length_m=0.0), "ramp_length_m"),
        ("ramp_length_m-1e9", dict(ramp_length_m=1e9), "ramp_length_m"),
        ("ramp_length_m-None", dict(ramp_length_m=None), "ramp_length_m"),
        ("lane_half_width_m-zero", dict(lane_half_width_m=0.0), "lane_half_width_m"),
        ("lane_half_width_m-100", dict(lane_half_width_m=100.0), "lane_half_width_m"),
    ],
    ROLL: KWARGS
    + [
        ("ramp_length_m-on-flat-ground", dict(ramp_length_m=4.0), "ramp_length_m"),
        ("heading_range_rad-4", dict(heading_range_rad=4.0), "heading_range_rad"),
        ("heading_range_rad-string", dict(heading_range_rad="x"), "heading_range_rad"),
        ("command_mode-unknown", dict(command_mode="x"), "command_mode"),
        ("command_resample_s-zero", dict(command_resample_s=0.0), "command_resample_s"),
        ("command_resample_s-negative", dict(command_resample_s=-1.0), "command_resample_s"),
        ("yaw_rate_range_rad_s-reversed", dict(yaw_rate_range_rad_s=(1.0, -1.0)), "yaw_rate_range_rad_s"),
    ],
}


# ---- randomization specs at gym.make: (id, spec); the error names ``randomization`` -------------------
def _schedule(rate, **kw):
    return {"pressure_schedule": {"rate_kpa_per_s": rate, **kw}}


RANDOMIZATION = [
    ("name-unknown", "fully"),
    ("int", 3),
    ("list", [1, 2]),
    ("unknown-parameter", {"bogus": 1.0}),
    ("base-int", {"base": 3}),
    ("base-unknown-name", {"base": "fully"}),
    ("pressure_kpa-99", {"pressure_kpa": 99.0}),
    ("pressure_kpa-reversed", {"pressure_kpa": [14.0, 3.0]}),
    ("pressure_kpa-nan", {"pressure_kpa": NAN}),
    ("pressure_kpa-string", {"pressure_kpa": "high"}),
    ("ground_friction-up-to-5", {"ground_friction": [0.5, 5.0]}),
    ("ground_friction-zero", {"ground_friction": 0.0}),
    ("ground_friction-normal-negative-std", {"ground_friction": {"distribution": "normal", "mean": 1.0, "std": -1.0}}),
    ("ground_friction-unknown-distribution", {"ground_friction": {"distribution": "weird"}}),
    ("ground_friction-extra-key", {"ground_friction": {"value": 1.0, "extra": 2}}),
    ("ground_friction-interval-without-interval_s", {"ground_friction": {"low": 0.5, "high": 1.5, "mode": "interval"}}),
    (
        "ground_friction-interval-negative-interval_s",
        {"ground_friction": {"low": 0.5, "high": 1.5, "mode": "interval", "interval_s": -1.0}},
    ),
    ("ground_friction-unknown-mode", {"ground_friction": {"low": 0.5, "high": 1.5, "mode": "sometimes"}}),
    ("payload_mass_kg-choice-empty", {"payload_mass_kg": {"distribution": "choice", "values": []}}),
    ("payload_mass_kg-choice-not-a-list", {"payload_mass_kg": {"distribution": "choice", "values": 3}}),
    ("payload_mass_kg-uniform-without-bounds", {"payload_mass_kg": {"distribution": "uniform"}}),
    ("payload_mass_kg-up-to-1e6", {"payload_mass_kg": [0.0, 1e6]}),
    ("payload_com_offset_m-scalar-bounds", {"payload_com_offset_m": [1.0, 2.0]}),
    ("payload_com_offset_m-up-to-1m", {"payload_com_offset_m": [[0, 0, 0], [1, 1, 1]]}),
    ("steer_friction_scale-up-to-100", {"steer_friction_scale": [1.0, 100.0]}),
    ("steer_friction_scale-fixed-nan", {"steer_friction_scale": {"distribution": "fixed", "value": NAN}}),
    ("pressure_schedule-reversed-rate", _schedule([0.1, -0.1])),
    ("pressure_schedule-normal-negative-std", _schedule({"distribution": "normal", "mean": 0.0, "std": -1.0})),
    ("pressure_schedule-uniform-without-bounds", _schedule({"distribution": "uniform"})),
    ("pressure_schedule-choice-empty", _schedule({"distribution": "choice", "values": []})),
    ("pressure_schedule-string-rate", _schedule("fast")),
    ("pressure_schedule-negative-delay", _schedule(0.0, delay_s=-1.0)),
    ("pressure_schedule-nan-rate", _schedule(NAN)),
    ("pressure_schedule-unknown-key", {"pressure_schedule": {"rate": 1.0}}),
    ("pressure_schedule-int", {"pressure_schedule": 5}),
]
RANDOMIZATION_BY_ENV = {
    RAMP: RANDOMIZATION
    + [
        (
            "incline_deg-interval-mode",
            {"incline_deg": {"low": 10.0, "high": 20.0, "mode": "interval", "interval_s": 1.0}},
        ),
        ("incline_deg-up-to-45", {"incline_deg": [10.0, 45.0]}),
    ],
    ROLL: RANDOMIZATION + [("incline_deg-on-flat-ground", {"incline_deg": [10.0, 20.0]})],
}


# ---- reset options on a running episode: (id, options, field) --------------------------------------
# Most mappings start with a valid change (pressure), so a reset that applied it before failing
# would show in the lockstep check.
P = {"pressure_kpa": 12.0}
OPTIONS = [
    ("options-list-of-pairs", [("pressure_kpa", 12.0)], "options"),
    ("options-string", "pressure_kpa=12", "options"),
    ("options-int", 3, "options"),
    ("unknown-option", {**P, "bogus": 1}, "bogus"),
    ("pressure_kpa-99", {"pressure_kpa": 99.0}, "pressure_kpa"),
    ("pressure_kpa-nan", {"pressure_kpa": NAN}, "pressure_kpa"),
    ("pressure_kpa-string", {"pressure_kpa": "x"}, "pressure_kpa"),
    ("pressure_kpa-range", {"pressure_kpa": [4.0, 8.0]}, "pressure_kpa"),
    ("ground_friction-5", {**P, "ground_friction": 5.0}, "ground_friction"),
    ("payload_com_offset_m-one-number", {**P, "payload_com_offset_m": [1.0]}, "payload_com_offset_m"),
    ("incline_deg-45", {**P, "incline_deg": 45.0}, "incline_deg"),
    ("steer_friction_scale-11", {**P, "steer_friction_scale": 11.0}, "steer_friction_scale"),
    ("pressure_rate_kpa_per_s-string", {**P, "pressure_rate_kpa_per_s": "x"}, "pressure_rate_kpa_per_s"),
    ("pressure_rate_kpa_per_s-nan", {**P, "pressure_rate_kpa_per_s": NAN}, "pressure_rate_kpa_per_s"),
    ("pressure_rate_kpa_per_s-list", {**P, "pressure_rate_kpa_per_s": [1.0]}, "pressure_rate_kpa_per_s"),
    ("initial_state-string", {**P, "initial_state": "upright"}, "initial_state"),
    ("initial_state-unknown-key", {**P, "initial_state": {"spin": 1.0}}, "initial_state"),
    ("initial_state-roll-nan", {**P, "initial_state": {"roll": NAN}}, "initial_state.roll"),
    (
        "initial_state-below-ground",
        {**P, "initial_state": {"position_m": (0.0, 0.0, -0.5)}},
        "initial_state.position_m",
    ),
    ("initial_state-position-2d", {**P, "initial_state": {"position_m": (0.0, 0.0)}}, "initial_state.position_m"),
    ("initial_state-velocity-string", {**P, "initial_state": {"velocity_m_s": "fast"}}, "initial_state.velocity_m_s"),
    (
        "initial_state-spin-5e3",
        {**P, "initial_state": {"angular_velocity_rad_s": (0.0, 5e3, 0.0)}},
        "initial_state.angular_velocity_rad_s",
    ),
    ("initial_state-theta_dot-1e300", {**P, "initial_state": {"theta_dot": 1e300}}, "initial_state.theta_dot"),
    ("omega_ref-string", {**P, "omega_ref": "abc"}, "omega_ref"),
    ("omega_ref-list", {**P, "omega_ref": [1.0, 2.0]}, "omega_ref"),
    ("omega_ref-1e9", {**P, "omega_ref": 1e9}, "omega_ref"),
    ("omega_ref-nan", {**P, "omega_ref": NAN}, "omega_ref"),
    ("omega_ref-None", {**P, "omega_ref": None}, "omega_ref"),
]
OPTIONS_BY_ENV = {
    RAMP: OPTIONS + [("omega_ref-negative", {**P, "omega_ref": -1.0}, "omega_ref")],
    ROLL: OPTIONS
    + [
        ("heading_ref-string", {**P, "heading_ref": "x"}, "heading_ref"),
        ("heading_ref-1e9", {**P, "heading_ref": 1e9}, "heading_ref"),
        ("yaw_rate_ref-in-heading-mode", {**P, "yaw_rate_ref": 1.0}, "yaw_rate_ref"),
    ],
}

SEEDS = [("negative", -1), ("float", 1.5), ("string", "7"), ("bool", True), ("list", [1, 2])]

ACTIONS = [
    ("shape-3", np.zeros(3, np.float32)),
    ("shape-1", [0.1]),
    ("shape-2x1", np.zeros((2, 1))),
    ("scalar", 0.5),
    ("nested-list", [[0.1, 0.2]]),
    ("str", "ab"),
    ("str-list", ["0.1", "0.2"]),
    ("str-array", np.array(["1", "0"])),
    ("complex", np.array([0.1 + 1j, 0.0])),
    ("None", None),
    ("None-inside", [None, 0.1]),
    ("dict", {"steer": 0.1}),
    ("bool", [True, False]),
    ("object-array", np.array([0.1, "x"], dtype=object)),
    ("NaN", np.array([NAN, 0.0], np.float32)),
    ("inf", [0.0, float("inf")]),
    ("float16-NaN", np.array([np.nan, 0], np.float16)),
]


def _params(by_env: dict) -> list:
    """One pytest case per env id × shell model × case; shells other than point are ``slow``."""
    return [
        pytest.param(
            env_id,
            shell_model,
            *case[1:],
            id=f"{_short(env_id)}-{shell_model}-{case[0]}",
            marks=() if shell_model == "point" else pytest.mark.slow,
        )
        for env_id in ENV_IDS
        for shell_model in SHELL_MODELS
        for case in by_env[env_id]
    ]


def _field(name: str) -> str:
    return re.escape(name)


@pytest.mark.parametrize("env_id, shell_model, kwargs, field", _params(KWARGS_BY_ENV))
def test_make_refuses_a_bad_kwarg(env_id, shell_model, kwargs, field):
    with pytest.raises(ValueError, match=_field(field)):
        gym.make(env_id, **{"shell_model": shell_model, **kwargs})


@pytest.mark.parametrize("env_id, shell_model, spec", _params(RANDOMIZATION_BY_ENV))
def test_make_refuses_a_bad_randomization_spec(env_id, shell_model, spec):
    with pytest.raises(ValueError, match="randomization"):
        gym.make(env_id, shell_model=shell_model, randomization=spec)


# ---- refused reset / step on a running episode: nothing changes ------------------------------------
def lockstep(env, ref, n: int = 3) -> bool:
    """Step both envs with the same random actions; True if everything they return is identical."""
    rng = np.random.default_rng(0)
    for _ in range(n):
        a = rng.uniform(-1, 1, 2).astype(np.float32)
        o1, r1, te1, tr1, i1 = env.step(a)
        o2, r2, te2, tr2, i2 = ref.step(a)
        if not (
            np.array_equal(o1, o2)
            and r1 == r2
            and i1["params"] == i2["params"]
            and i1.get("omega_ref") == i2.get("omega_ref")
        ):
            return False
        if te1 or tr1:
            env.reset(seed=1)
            ref.reset(seed=1)
    return True


@pytest.fixture(scope="module")
def episodes():
    """Per (env id, shell model): an env and its twin, built once; ``episode`` resets both."""
    built: dict = {}
    yield built
    for pair in built.values():
        for e in pair:
            e.close()


@pytest.fixture
def episode(episodes, env_id, shell_model):
    """A running episode (full randomization, seed 0) and an identical twin that never sees the input."""
    key = (env_id, shell_model)
    if key not in episodes:
        episodes[key] = tuple(
            gym.make(env_id, shell_model=shell_model, randomization="full", disable_env_checker=True) for _ in range(2)
        )
    env, ref = episodes[key]
    for e in (env, ref):
        e.reset(seed=0)
    return env, ref


@pytest.mark.parametrize("env_id, shell_model, options, field", _params(OPTIONS_BY_ENV))
def test_reset_refuses_a_bad_option_and_the_episode_carries_on(episode, options, field):
    env, ref = episode
    with pytest.raises(ValueError, match=_field(field)):
        env.reset(options=options)
    assert lockstep(env, ref)


@pytest.mark.parametrize("env_id, shell_model, seed", _params({e: SEEDS for e in ENV_IDS}))
def test_reset_refuses_a_bad_seed_and_the_episode_carries_on(episode, seed):
    env, ref = episode
    with pytest.raises(ValueError, match="seed"):
        env.reset(seed=seed)
    assert lockstep(env, ref)


@pytest.mark.parametrize("env_id, shell_model, action", _params({e: ACTIONS for e in ENV_IDS}))
def test_step_refuses_a_bad_action_and_the_episode_carries_on(episode, action):
    env, ref = episode
    with pytest.raises(ValueError, match="action"):
        env.step(action)
    assert lockstep(env, ref)


def test_lockstep_tells_a_changed_episode_apart():
    """The check above can fail: two episodes at different pressures do not step alike."""
    env, ref = (gym.make(ROLL, shell_model="point") for _ in range(2))
    env.reset(seed=0, options={"pressure_kpa": 12.0})
    ref.reset(seed=0, options={"pressure_kpa": 4.0})
    assert not lockstep(env, ref)
    env.reset(seed=0, options={"pressure_kpa": 4.0})
    ref.reset(seed=0, options={"pressure_kpa": 4.0})
    assert lockstep(env, ref)
    assert np.isfinite(env.step(ZERO)[0]).all()


# ---- ended and copied episodes ----------------------------------------------------------------------
def _shells(env_ids=ENV_IDS, shells=SHELL_MODELS) -> list:
    return [
        pytest.param(env_id, sm, id=f"{_short(env_id)}-{sm}", marks=() if sm == "point" else pytest.mark.slow)
        for env_id in env_ids
        for sm in shells
    ]


def _run_until_the_end(env, action, max_steps):
    for _ in range(max_steps):
        obs, r, term, trunc, info = env.step(np.asarray(action, np.float32))
        if term or trunc:
            return obs, term, trunc, info
    raise AssertionError(f"the episode did not end within {max_steps} steps")


def _assert_physics_failure_then_reset_needed(env, obs, trunc, info):
    assert trunc, info
    assert info["truncation_reason"].startswith("physics_failure"), info
    assert np.isfinite(obs).all()
    with pytest.raises(RuntimeError, match=re.escape("call reset()")):
        env.step(ZERO)


@pytest.mark.parametrize("env_id, shell_model", _shells())
def test_a_launched_robot_truncates_and_the_next_step_asks_for_reset(env_id, shell_model):
    """The largest accepted initial spin (499 rad/s about each axis) ends in a physics failure."""
    env = gym.make(env_id, shell_model=shell_model, disable_env_checker=True)
    env.reset(seed=0, options={"initial_state": {"angular_velocity_rad_s": (499.0, 499.0, 499.0)}})
    obs, _, trunc, info = _run_until_the_end(env, (0.0, 0.0), 5)
    _assert_physics_failure_then_reset_needed(env, obs, trunc, info)
    env.close()


@pytest.mark.parametrize("copier", [copy.deepcopy, lambda e: pickle.loads(pickle.dumps(e))], ids=["deepcopy", "pickle"])
@pytest.mark.parametrize("env_id, shell_model", _shells())
def test_step_on_a_copy_made_mid_episode_asks_for_reset(env_id, shell_model, copier):
    env = gym.make(env_id, shell_model=shell_model, disable_env_checker=True)
    env.reset(seed=0)
    for _ in range(3):
        env.step(ZERO)
    dup = copier(env)
    with pytest.raises(RuntimeError, match=re.escape("call reset()")):
        dup.step(ZERO)
    dup.close()
    env.close()


# The hydroelastic shell does not diverge on this route within 150 steps, so it has no case here.
@pytest.mark.parametrize("env_id, shell_model", _shells((ROLL,), ("point", "injected")))
def test_diverging_drive_friction_truncates_and_the_next_step_asks_for_reset(env_id, shell_model):
    """Flat ground, an accepted drive friction just under the explicit-stability limit (viscous
    c = 120 N m s/rad at 5 ms, limit ≈123), full torque: the explicit update diverges within tens of steps."""
    env = gym.make(
        env_id,
        shell_model=shell_model,
        randomization="off",
        disable_env_checker=True,
        friction_model={"drive": {"law": "viscous", "params": {"c": 120.0}}},
    )
    env.reset(seed=0)
    obs, _, trunc, info = _run_until_the_end(env, (-1.0, 1.0), 300)
    _assert_physics_failure_then_reset_needed(env, obs, trunc, info)
    env.close()


# ---- configurations whose explicit torques diverge at the plant step ---------------------------------
@pytest.mark.parametrize("omega_n", [250.0, 300.0, 1e4], ids=lambda w: f"omega_n-{w:g}")
def test_make_refuses_a_calibration_whose_injected_stiffness_diverges(tmp_path, omega_n):
    data = yaml.safe_load(asset_path("calibration", "default.yaml").read_text())
    data["omega_n"] = {**data["omega_n"], "intercept_rad_s": omega_n, "slope_rad_s_per_kpa": 0.0}
    path = tmp_path / "calibration.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ValueError, match="omega_n"):
        gym.make(ROLL, shell_model="injected", calibration=str(path))


def test_make_refuses_coulomb_friction_randomized_up_to_10x_steer_friction():
    with pytest.raises(ValueError, match="steer_friction_scale"):
        gym.make(ROLL, friction_model="coulomb", randomization={"steer_friction_scale": [1.0, 10.0]})


def test_reset_refuses_coulomb_friction_at_10x_steer_friction():
    env = gym.make(ROLL, friction_model="coulomb", disable_env_checker=True)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="steer_friction_scale"):
        env.reset(options={"steer_friction_scale": 10.0})
    env.close()


@pytest.mark.parametrize("joint", ["steer", "drive"])
@pytest.mark.parametrize("c", [300.0, 1e3, 1e6], ids=lambda c: f"c{c:g}")
def test_make_refuses_viscous_friction_beyond_explicit_stability(joint, c):
    with pytest.raises(ValueError, match="friction_model"):
        gym.make(ROLL, friction_model={joint: {"law": "viscous", "params": {"c": c}}})
