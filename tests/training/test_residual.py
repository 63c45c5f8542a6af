"""Residual control over the PD baseline (``sphere_env.wrappers.PDResidualAction``, rl-zoo3's
``env_wrapper`` key): a zero residual reproduces the PD's episode exactly; the residual moves the
applied torques by ``scale``; a run trained inside the wrapper is evaluated with the same PD, gives in
evaluation the actions it took in its wrapped env, and is exported together with that PD; bad
wrapper entries are refused by name."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401
from sphere_env.controllers import controller_for
from sphere_env.wrappers import PDResidualAction
from tests.conftest import TINY_PPO

ENV = "sphere_env/RampDescent-v2"


def _episode(env, act, seed=3, pressure=6.0, steps=120):
    obs, info = env.reset(seed=seed, options={"pressure_kpa": pressure})
    out = []
    for _ in range(steps):
        obs, r, term, trunc, info = env.step(act(obs, info))
        out.append((obs.copy(), r))
        if term or trunc:
            break
    return out


@pytest.mark.parametrize("shell", ["point", "injected"])
def test_zero_residual_reproduces_the_pd_episode(shell):
    bare = gym.make(ENV, shell_model=shell, randomization="off")
    pd = controller_for(bare, "pd")
    pd.reset()
    want = _episode(bare, pd)
    wrapped = PDResidualAction(gym.make(ENV, shell_model=shell, randomization="off"), scale=0.5)
    got = _episode(wrapped, lambda obs, info: np.zeros(2, np.float32))
    assert len(got) == len(want) > 50
    for (o1, r1), (o2, r2) in zip(want, got):
        np.testing.assert_array_equal(o1, o2)
        assert r1 == r2


def test_residual_adds_scale_times_the_action_to_the_pd_torques():
    env = PDResidualAction(gym.make(ENV, shell_model="point", randomization="off"), scale=0.25)
    env.reset(seed=1, options={"pressure_kpa": 8.0})
    residual = np.array([0.4, -0.8], np.float32)
    for _ in range(20):
        _, _, _, _, info = env.step(residual)
        want = np.clip(info["base_action"] + 0.25 * residual, -1, 1)
        np.testing.assert_allclose(info["applied_action"], want, atol=1e-6)
        # joint torques: +drive is forward, about the URDF's −y drive axis (τ_drive = −a·limit)
        limits = np.array([env.unwrapped.steer_torque_limit_nm, -env.unwrapped.drive_torque_limit_nm])
        np.testing.assert_allclose(info["motor_torque_nm"], want * limits, rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize("scale", [0.0, -0.5, 2.5, float("nan"), "big", True])
def test_bad_scale_is_refused_by_name(scale):
    with pytest.raises(ValueError, match="scale"):
        PDResidualAction(gym.make(ENV, shell_model="point"), scale=scale)


def test_bad_residual_action_is_refused_before_stepping():
    env = PDResidualAction(gym.make(ENV, shell_model="point"), scale=0.5)
    env.reset(seed=0)
    t = env.unwrapped.twin.context.get_time()
    for bad in ([np.nan, 0.0], [0.0], [0.1, 0.2, 0.3]):
        with pytest.raises(ValueError, match="action"):
            env.step(np.asarray(bad, np.float32))
    assert env.unwrapped.twin.context.get_time() == t


@pytest.mark.parametrize(
    "value, needle",
    [
        ("sphere_env.wrappers.NoSuchWrapper", "NoSuchWrapper"),
        ("no_such_module.Wrapper", "no_such_module"),
        ("sphere_env.controllers.PendulumPDController", "not a gymnasium.Wrapper"),
        ([{"sphere_env.wrappers.PDResidualAction": [0.5]}], "mapping of kwargs"),
        ([{"sphere_env.wrappers.PDResidualAction": {"scale": 7}}], "scale"),
        ([{"sphere_env.wrappers.PDResidualAction": {"gain": 1}}], "gain"),
    ],
)
def test_bad_env_wrapper_is_refused_by_name(value, needle):
    from sphere_env.training.config import resolve_config

    with pytest.raises(ValueError, match="env_wrapper") as err:
        resolve_config(ENV, "ppo", overrides={"env_wrapper": value, "env_kwargs": {"shell_model": "point"}})
    assert needle in str(err.value)


@pytest.mark.parametrize(
    "value",
    [
        "sphere_env.wrappers.PDResidualAction",
        {"sphere_env.wrappers.PDResidualAction": {"scale": 0.5}},
        [{"sphere_env.wrappers.PDResidualAction": {"scale": 0.5}}],
    ],
)
def test_env_wrapper_accepts_rl_zoo3_forms(value):
    from sphere_env.training.schemas import check_section

    (entry,) = check_section("ppo", {"env_wrapper": value}).env_wrapper
    assert list(entry) == ["sphere_env.wrappers.PDResidualAction"]
    assert entry["sphere_env.wrappers.PDResidualAction"] == ({} if isinstance(value, str) else {"scale": 0.5})


@pytest.fixture(scope="module")
def residual_run(tmp_path_factory):
    from sphere_env.resources import hyperparams_path
    from sphere_env.training.config import resolve_config
    from sphere_env.training.trainer import train

    cfg = resolve_config(
        ENV,
        "ppo",
        hyperparams_path("ppo_residual"),
        overrides={
            **TINY_PPO,
            "n_timesteps": 128,
            "env_kwargs": {"shell_model": "point"},
        },
        eval_episodes=1,
    )
    assert cfg.env_wrapper == [
        {"sphere_env.wrappers.ShellModelMixture": {"shell_models": ["point", "injected"]}},
        {"sphere_env.wrappers.PDResidualAction": {"scale": 0.5}},
    ]
    return train(cfg, tmp_path_factory.mktemp("residual") / "run", progress_bar=False)


def test_evaluation_applies_the_runs_pd_as_training_did(residual_run):
    """The controller built from a residual run gives, on the bare env, the action the wrapped env
    applied for the same network output: PD + 0.5 × residual, step by step over an episode."""
    from sphere_env.evaluation.controller_specs import PolicyController, make_controller

    bare = gym.make(ENV, shell_model="injected", randomization="off")
    controller = make_controller(str(residual_run), bare)
    policy = PolicyController(residual_run)
    wrapped = PDResidualAction(gym.make(ENV, shell_model="injected", randomization="off"), scale=0.5)
    controller.reset()
    obs_b, info_b = bare.reset(seed=5, options={"pressure_kpa": 9.0})
    obs_w, _ = wrapped.reset(seed=5, options={"pressure_kpa": 9.0})
    for _ in range(60):
        a_bare = controller(obs_b, info_b)
        residual, _ = policy.model.predict(policy.normalize(obs_w), deterministic=True)
        obs_w, _, term, trunc, info_w = wrapped.step(residual)
        np.testing.assert_array_equal(a_bare, info_w["applied_action"])
        obs_b, _, _, _, info_b = bare.step(a_bare)
        np.testing.assert_array_equal(obs_b, obs_w)
        if term or trunc:
            break


def test_residual_recipe_run_exports_with_its_pd(residual_run, tmp_path):
    """The recipe's run (shell mixture, then the residual) exports as one graph with the PD: the
    training-only mixture is left out, the PD's state is an input, and the exporter's own check
    against evaluation's actions passes."""
    import json

    from sphere_env.evaluation.export import export

    res = export(str(residual_run), "torchscript", tmp_path / "export")
    layout = json.loads(res["layout"].read_text())
    assert layout["residual"]["scale"] == 0.5 and layout["state"]["reset_value"] == [0.0, 0.0, 1.0]
    assert layout["check"]["max_abs_action_diff"] == res["max_abs_action_diff"] < 1e-5


# ---- ShellModelMixture ---------------------------------------------------------------------------
def _mixture_run(seed, n_episodes=12, steps=5):
    from sphere_env.wrappers import ShellModelMixture

    env = ShellModelMixture(gym.make(ENV, shell_model="injected", randomization="default"), ["point", "injected"])
    out = []
    for k in range(n_episodes):
        obs, info = env.reset(seed=seed if k == 0 else None)
        for _ in range(steps):
            obs, _, _, _, info = env.step(np.array([0.1, 0.3], np.float32))
        out.append((info["shell_model"], info["pressure_kpa"], obs.copy()))
    env.close()
    return out


def test_shell_model_mixture_draws_both_models_reproducibly_under_a_seed():
    a, b = _mixture_run(4), _mixture_run(4)
    assert {m for m, _, _ in a} == {"point", "injected"}
    for (m1, p1, o1), (m2, p2, o2) in zip(a, b):
        assert (m1, p1) == (m2, p2)
        np.testing.assert_array_equal(o1, o2)
    assert [m for m, _, _ in _mixture_run(5)] != [m for m, _, _ in a]


@pytest.mark.parametrize("models", [[], "point", ["point", "rigid"], ["point", "point", "injected"], ["point"]])
def test_shell_model_mixture_refuses_bad_lists_by_name(models):
    from sphere_env.wrappers import ShellModelMixture

    with pytest.raises(ValueError, match="shell_models"):
        ShellModelMixture(gym.make(ENV, shell_model="injected"), models)


def test_shell_model_mixture_needs_the_env_s_own_model():
    from sphere_env.wrappers import ShellModelMixture

    with pytest.raises(
        ValueError,
        match=r"^ShellModelMixture: the env's shell_model = 'injected': .*; allowed: one of "
        r"shell_models \['point', 'hydroelastic'\]$",
    ):
        ShellModelMixture(gym.make(ENV, shell_model="injected"), ["point", "hydroelastic"])


def test_shell_model_mixture_sets_the_randomization_of_every_model_or_none():
    from sphere_env.wrappers import ShellModelMixture

    env = ShellModelMixture(gym.make(ENV, shell_model="injected", randomization="off"), ["point", "injected"])
    before = [e.unwrapped.randomization for e in env.envs.values()]
    with pytest.raises(ValueError, match="pressure_kpa"):
        env.set_randomization({"pressure_kpa": [1.0, 2.0]})
    assert [e.unwrapped.randomization for e in env.envs.values()] == before
    env.set_randomization({"pressure_kpa": [5.0, 6.0]})
    for _ in range(4):
        _, info = env.reset()
        assert 5.0 <= info["pressure_kpa"] <= 6.0
    assert all(e.unwrapped.randomization != b for e, b in zip(env.envs.values(), before))


def test_trainer_venv_set_attr_randomization_reaches_every_shell_model():
    from functools import partial

    from stable_baselines3.common.vec_env import DummyVecEnv

    from sphere_env.training.env_factory import make_env

    wrappers = [{"sphere_env.wrappers.ShellModelMixture": {"shell_models": ["point", "injected"]}}]
    venv = DummyVecEnv(
        [partial(make_env, ENV, {"shell_model": "point", "randomization": "off"}, 0, env_wrapper=wrappers)]
    )
    venv.set_attr("randomization", {"pressure_kpa": [7.0, 7.5]})
    (mixture,) = venv.get_attr("envs")
    assert all(7.0 <= e.unwrapped.randomization.terms[0].distribution.low for e in mixture.values())
    venv.close()
