"""The policy shipped with the package (``pretrained``): evaluate and enjoy load it by name, without
training, and it controls the robot where zero torque does not."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401
from sphere_env.evaluation.cells import rollout
from sphere_env.evaluation.controller_specs import check_spec, env_kwargs_of, make_controller, run_folder
from sphere_env.evaluation.enjoy import EnjoySpec, enjoy
from sphere_env.evaluation.evaluate import SweepSpec, evaluate
from sphere_env.resources import shipped_policy_path


def test_the_shipped_policy_is_a_complete_run_folder_with_its_card():
    folder = shipped_policy_path("pretrained")
    card = json.loads((folder / "card.json").read_text())
    assert card["env_id"] == "sphere_env/RampDescent-v3" and card["algo"] == "ppo"
    assert set(card["per_shell"]) == {"point", "injected", "hydroelastic"}
    check_spec("pretrained", "sphere_env/RampDescent-v3")  # model and statistics load
    assert run_folder("pretrained@model")[0] == folder


def test_the_shipped_policy_tracks_where_zero_torque_does_not():
    """Rigid point contact at 8.5 kPa, the grid's seeds: zero torque keeps accelerating past the
    command; the shipped policy's tracking error is far below it in every episode."""
    kw = env_kwargs_of("pretrained")  # the observations it was trained on
    for seed in (0, 1, 2):
        job = dict(
            controller="x",
            spec="pretrained",
            env_id="sphere_env/RampDescent-v3",
            shell_model="point",
            friction="majd",
            pressure_kpa=8.5,
            seed=seed,
            env_kwargs=kw,
        )
        policy_row, _ = rollout(job)
        zero_row, _ = rollout({**job, "spec": "zero", "controller": "zero"})
        assert policy_row["tracking_rmse_rad_s"] < 0.6 * zero_row["tracking_rmse_rad_s"]


def test_evaluate_and_enjoy_take_the_shipped_policy_by_name(tmp_path):
    res = evaluate(
        SweepSpec(controllers=["pretrained"], pressures_kpa=[8.5], shell_models=["injected"], seeds=[0]),
        tmp_path / "eval",
        workers=1,
        plots=False,
    )
    (row,) = res["rows"]
    assert row["controller"] == "pretrained" and np.isfinite(row["tracking_rmse_rad_s"])
    rows = enjoy(EnjoySpec(run="pretrained", episodes=1, shell_model="injected", pressure_kpa=8.5), say=lambda _: None)
    assert rows[0]["tracking_rmse_rad_s"] == pytest.approx(row["tracking_rmse_rad_s"])


def test_the_shipped_policy_acts_on_the_env_it_was_trained_for():
    kw = {**env_kwargs_of("pretrained"), "shell_model": "hydroelastic", "randomization": "off"}
    env = gym.make("sphere_env/RampDescent-v3", **kw)
    ctrl = make_controller("pretrained", env)
    obs, info = env.reset(seed=0)
    a = ctrl(obs, info)
    assert a.shape == (2,) and np.all(np.abs(a) <= 1.0)
    env.close()
