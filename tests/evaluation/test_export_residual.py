"""A policy trained as residual control over the PD baseline (``PDResidualAction``) exports as one
graph with the PD's state as an explicit input and output: the torch PD law gives the Python
controller's actions and state over whole episodes (the integral's clip included); the exported
file, run one step at a time with its state carried, gives the actions evaluation's
``PolicyController`` applies on an episode the exporter never saw; ``policy.json`` states the state's
layout and reset value; other action wrappers are refused by name with nothing written."""

from __future__ import annotations

import json
import shutil

import gymnasium as gym
import numpy as np
import pytest
import torch
import yaml

import sphere_env  # noqa: F401
from sphere_env import safe_yaml
from sphere_env.controllers import OMEGA_D, PD_PRESETS, controller_for
from sphere_env.controllers_torch import PD_STATE, PD_STATE_RESET, PendulumPDModule
from sphere_env.evaluation.controller_specs import PolicyController
from sphere_env.evaluation.export import export
from sphere_env.evaluation.export import main as export_main
from tests.conftest import RESIDUAL_WRAPPER

ENV = "sphere_env/RampDescent-v2"
ONNX_PACKAGES = ("onnx", "onnxscript", "onnxruntime")


@pytest.mark.parametrize(
    "env_id, env_kwargs, preset, clips",
    [
        ("sphere_env/RampDescent-v2", {}, "RampDescent-v2", True),
        ("sphere_env/RampDescent-v1", {}, "RampDescent", True),
        ("sphere_env/Roll-v1", {"command_mode": "yaw_rate"}, "Roll", False),
    ],
)
def test_torch_pd_gives_the_controllers_actions_and_state_over_an_episode(make, env_id, env_kwargs, preset, clips):
    env = make(env_id, shell_model="point", randomization="off", **env_kwargs)
    pd = controller_for(env, "pd")
    assert {k: getattr(pd, k) for k in PD_PRESETS[preset]} == PD_PRESETS[preset]
    module = PendulumPDModule(pd)
    pd.reset()
    state = torch.tensor([PD_STATE_RESET], dtype=torch.float64)
    obs, info = env.reset(seed=0)
    limit, at_clip, n = pd.integral_limit_rad, 0, 0
    while True:
        want = pd(obs, info)
        with torch.no_grad():
            got, state = module(torch.as_tensor(obs[None]), state)
        np.testing.assert_allclose(got.numpy()[0].astype(np.float32), want, rtol=0, atol=1e-6)
        # the state is the controller's: its integral (private attribute), the ω_d it saw, no flag
        assert state[0, 0].item() == pytest.approx(pd._integral, abs=1e-12)
        assert state[0, 1].item() == float(obs[OMEGA_D]) and state[0, 2].item() == 0.0
        at_clip += abs(pd._integral) >= limit
        obs, _, terminated, truncated, info = env.step(want)
        n += 1
        if terminated or truncated:
            break
    assert n > 100  # a whole episode, not its first steps
    assert (at_clip > 0) == clips  # the integral's clip was exercised where the preset reaches it


def _run_file(path, fmt):
    """A step function (observation row, state) -> (action, next_state) of an exported file."""
    if fmt == "onnx":
        import onnxruntime as ort

        session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
        assert [i.name for i in session.get_inputs()] == ["observation", "state"]
        assert [o.name for o in session.get_outputs()] == ["action", "next_state"]
        return lambda o, s: session.run(["action", "next_state"], {"observation": o, "state": s})
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # torch marks TorchScript deprecated
        module = torch.jit.load(str(path))

    def step(o, s):
        with torch.no_grad():
            a, n = module(torch.as_tensor(o), torch.as_tensor(s))
        return a.numpy(), n.numpy()

    return step


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["torchscript", "onnx"])
def test_exported_residual_policy_gives_the_evaluation_actions(tiny_residual_run, tmp_path, fmt):
    if fmt == "onnx":
        for package in ONNX_PACKAGES:
            pytest.importorskip(package)
    res = export(str(tiny_residual_run), fmt, tmp_path / "export")
    assert res["max_abs_action_diff"] < 1e-5
    layout = json.loads(res["layout"].read_text())
    assert layout["state"]["reset_value"] == list(PD_STATE_RESET) == [0.0, 0.0, 1.0]
    assert [c["name"] for c in layout["state"]["components"]] == [name for name, *_ in PD_STATE]
    assert (layout["state"]["input"], layout["state"]["output"], layout["state"]["shape"]) == (
        "state",
        "next_state",
        ["batch", 3],
    )
    assert layout["residual"]["scale"] == 0.5
    assert {k: layout["residual"]["pd"][k] for k in PD_PRESETS["RampDescent-v2"]} == PD_PRESETS["RampDescent-v2"]

    # an episode the exporter's check never saw: another shell, pressure and seed, to its end
    env = gym.make(ENV, shell_model="injected", randomization="off")
    policy = PolicyController(tiny_residual_run)
    policy.check_env(env)
    pd = controller_for(env, "pd")
    step = _run_file(res["policy"], fmt)
    policy.reset()
    pd.reset()
    state = np.asarray([PD_STATE_RESET], np.float64)
    obs, info = env.reset(seed=5, options={"pressure_kpa": 9.0})
    rows, want, got, pd_only = [], [], [], []
    while True:
        action = policy(obs, info)
        a, state = step(obs[None].astype(np.float32), state)
        rows.append(obs)
        want.append(action)
        got.append(np.asarray(a)[0])
        pd_only.append(pd(obs, info))
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    env.close()
    want, got, pd_only = np.asarray(want), np.asarray(got), np.asarray(pd_only)
    diff = float(np.max(np.abs(got - want)))
    print(f"{fmt}: max |exported - PolicyController| = {diff:.3g} over {len(want)} steps")
    assert len(want) > 100 and got.dtype == np.float32
    assert diff < 1e-5
    # The test can fail: the network's residual moves the PD's actions ...
    assert np.max(np.abs(want - pd_only)) > 1e-3
    # ... and the carried state matters (a state reset at every step gives other actions).
    fresh = np.concatenate([step(r[None].astype(np.float32), np.asarray([PD_STATE_RESET]))[0] for r in rows])
    assert np.max(np.abs(fresh - want)) > 1e-2


def _edited_run(run, tmp_path, env_wrapper):
    """A copy of ``run`` whose config.yaml names ``env_wrapper``."""
    copy = tmp_path / "copy"
    shutil.copytree(run, copy)
    cfg = safe_yaml.load_file(copy / "config.yaml")
    cfg["env_wrapper"] = env_wrapper
    (copy / "config.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
    return copy


@pytest.mark.parametrize(
    "env_wrapper, needles",
    [
        (
            [{"gymnasium.wrappers.TimeLimit": {"max_episode_steps": 10}}],
            ["env_wrapper", "gymnasium.wrappers.TimeLimit", "allowed", RESIDUAL_WRAPPER],
        ),
        (
            [{RESIDUAL_WRAPPER: {"scale": 0.5}}, {RESIDUAL_WRAPPER: {"scale": 0.25}}],
            ["env_wrapper: run", f"[{RESIDUAL_WRAPPER!r}, {RESIDUAL_WRAPPER!r}]", f"allowed: one {RESIDUAL_WRAPPER}"],
        ),
    ],
)
def test_other_action_wrappers_are_refused_by_name(tiny_ppo_run, tmp_path, capsys, env_wrapper, needles):
    run = _edited_run(tiny_ppo_run, tmp_path, env_wrapper)
    out = tmp_path / "new" / "export"
    with pytest.raises(SystemExit) as exc:
        export_main([str(run), "--format", "torchscript", "--out", str(out)])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    for needle in needles:
        assert needle in err, err
    assert not (tmp_path / "new").exists()


def test_a_non_finite_row_gets_zero_torque_and_keeps_its_state(tiny_residual_run, tmp_path):
    res = export(str(tiny_residual_run), "torchscript", tmp_path / "export")
    step = _run_file(res["policy"], "torchscript")
    env = gym.make(ENV, shell_model="point", randomization="off")
    obs, _ = env.reset(seed=0)
    env.close()
    rows = np.repeat(obs[None], 3, axis=0).astype(np.float32)
    rows[1, 4] = np.nan
    state = np.asarray([[0.3, 1.5, 0.0], [0.3, 1.5, 0.0], [np.inf, 0.0, 1.0]], np.float64)
    action, next_state = step(rows, state)
    np.testing.assert_array_equal(action[1:], 0.0)
    np.testing.assert_array_equal(next_state[1:], state[1:])
    assert np.abs(action[0]).sum() > 0 and next_state[0, 2] == 0.0  # a finite row acts and steps on
