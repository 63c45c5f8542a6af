"""An asymmetric actor-critic exports as the robot runs it: the file takes the observation without
the privileged components (pressure, shell one-hot) and gives the SB3 policy's deterministic action
on the full observation, whatever those components hold."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401
from sphere_env.evaluation.export import export, run_exported
from sphere_env.training.config import algo_class
from sphere_env.training.saved import read_stats
from tests.conftest import TINY_PPO


@pytest.mark.parametrize("fmt", ["torchscript", "onnx"])
def test_the_exported_actor_takes_the_robot_observation_only(tiny_recipe_run, tmp_path, fmt):
    res = export(str(tiny_recipe_run), fmt, tmp_path / fmt)
    layout = json.loads(res["layout"].read_text())
    names = [c["name"] for c in layout["observation"]]
    assert "pressure_kpa" not in names and not any(n.startswith("shell_") for n in names)
    assert layout["input"]["shape"] == ["batch", len(names)]

    model = algo_class("ppo").load(tiny_recipe_run / "model.zip", device="cpu")
    vn = read_stats(tiny_recipe_run / "vecnormalize.json")
    env = gym.make(
        "sphere_env/RampDescent-v3",
        shell_model="hydroelastic",
        randomization="off",
        observe_pressure=True,
        observe_shell_model=True,
    )
    obs, _ = env.reset(seed=3, options={"pressure_kpa": 9.0})
    rows = [obs]
    rng = np.random.default_rng(0)
    for _ in range(30):
        obs, *_ = env.step(rng.uniform(-0.5, 0.5, 2).astype(np.float32))
        rows.append(obs)
    env.close()
    full = np.asarray(rows, np.float32)
    expected, _ = model.predict(vn.normalize_obs(full), deterministic=True)
    got = run_exported(res["policy"], fmt, full[:, : len(names)])
    np.testing.assert_allclose(got, expected, atol=1e-5)
    other = full.copy()
    other[:, len(names) :] = [3.0, 1.0, 0.0, 0.0]  # another pressure and shell: the actor ignores them
    np.testing.assert_allclose(model.predict(vn.normalize_obs(other), deterministic=True)[0], expected, atol=1e-6)


@pytest.mark.parametrize("fmt", ["torchscript", "onnx"])
def test_a_non_finite_observation_gets_zero_torque_from_the_file_and_an_error_from_python(
    tiny_recipe_run, tmp_path, fmt
):
    from sphere_env.evaluation.controller_specs import PolicyController

    res = export(str(tiny_recipe_run), fmt, tmp_path / fmt)
    n = json.loads(res["layout"].read_text())["input"]["shape"][1]
    env = gym.make(
        "sphere_env/RampDescent-v3",
        shell_model="point",
        randomization="off",
        observe_pressure=True,
        observe_shell_model=True,
    )
    obs, _ = env.reset(seed=0)
    env.close()
    rows = np.repeat(obs[None, :n], 3, axis=0)
    rows[1, 4] = np.nan
    rows[2, 0] = np.inf
    got = run_exported(res["policy"], fmt, rows)
    assert np.isfinite(got).all()
    np.testing.assert_array_equal(got[1:], 0.0)
    assert np.abs(got[0]).sum() > 0  # a finite row still acts
    policy = PolicyController(tiny_recipe_run)
    bad = obs.copy()
    bad[4] = np.nan
    with pytest.raises(ValueError, match=r"observation: components \[4\]"):
        policy.act(bad)


def test_an_actor_that_sees_the_pressure_exports_it_as_the_operators_reading(tmp_path):
    """With ``privileged_dims: 3`` only the shell one-hot is the critic's alone: the file takes the
    pressure as its last input, and policy.json says where the robot gets it (no sensor gives it)."""
    from sphere_env.training.config import resolve_config
    from sphere_env.training.trainer import train

    over = {
        **TINY_PPO,
        "n_timesteps": 64,
        "n_workers": 1,
        "policy_kwargs": {"net_arch": [16], "privileged_dims": 3},
    }
    run = train(resolve_config("sphere_env/RampDescent-v3", "ppo", overrides=over, eval_freq=0), tmp_path / "run")
    res = export(str(run), "torchscript", tmp_path / "out")
    layout = json.loads(res["layout"].read_text())
    names = [c["name"] for c in layout["observation"]]
    assert names[-1] == "pressure_kpa" and not any(n.startswith("shell_") for n in names)
    pressure = layout["observation"][-1]
    assert "from_sensors" not in pressure and "before the run" in pressure["from_operator"]["source"]
    assert all("from_sensors" in c for c in layout["observation"][:-1])
