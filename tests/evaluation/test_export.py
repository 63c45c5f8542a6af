"""Policies for the robot: the exported file (ONNX through onnxruntime, TorchScript through
torch.jit) gives the SB3 model's deterministic actions, model.predict(vecnormalize.normalize_obs(obs),
deterministic=True), on observations recorded from real env rollouts that the exporter never saw;
its layout file matches the env; bad inputs are refused by name with nothing written."""

from __future__ import annotations

import json
import shutil

import gymnasium as gym
import numpy as np
import pytest

import sphere_env  # noqa: F401
from sphere_env.controllers import controller_for
from sphere_env.evaluation.export import export
from sphere_env.evaluation.export import main as export_main
from sphere_env.training.config import algo_class
from sphere_env.training.saved import read_stats

ENV = "sphere_env/RampDescent-v2"


def recorded_observations(env_kwargs) -> np.ndarray:
    """Observations of real rollouts unlike the exporter's own check: the PD baseline and seeded
    random actions, two shell models, pressures between the calibration points."""
    out = []
    rng = np.random.default_rng(7)
    for shell, pressure, seed, kind in (
        ("injected", 5.5, 21, "pd"),
        ("hydroelastic", 11.0, 22, "random"),
        ("point", 7.0, 23, "random"),
    ):
        env = gym.make(ENV, shell_model=shell, randomization="off", **env_kwargs)
        pd = controller_for(env, "pd")
        obs, info = env.reset(seed=seed, options={"pressure_kpa": pressure})
        for _ in range(60):
            out.append(obs)
            a = pd(obs, info) if kind == "pd" else rng.uniform(-1, 1, 2)
            obs, _, term, trunc, info = env.step(np.asarray(a, np.float32))
            if term or trunc:
                break
        env.close()
    return np.asarray(out, np.float32)


def sb3_actions(run, algo, obs):
    model = algo_class(algo).load(run / "model.zip", device="cpu")
    vecnormalize = read_stats(run / "vecnormalize.json")
    actions, _ = model.predict(vecnormalize.normalize_obs(obs), deterministic=True)
    raw, _ = model.predict(obs, deterministic=True)  # without the statistics
    return actions, raw


def run_file(path, fmt, obs):
    if fmt == "onnx":
        import onnxruntime as ort

        return ort.InferenceSession(str(path)).run(["action"], {"observation": obs})[0]
    import warnings

    import torch

    with warnings.catch_warnings(), torch.no_grad():
        warnings.simplefilter("ignore", DeprecationWarning)  # torch marks TorchScript deprecated
        return torch.jit.load(str(path))(torch.as_tensor(obs)).numpy()


@pytest.mark.slow
@pytest.mark.parametrize("algo, fmt", [("ppo", "onnx"), ("ppo", "torchscript"), ("sac", "onnx")])
def test_exported_policy_gives_the_sb3_actions(request, tmp_path, algo, fmt):
    run = request.getfixturevalue(f"tiny_{algo}_run")
    res = export(str(run), fmt, tmp_path / "export")
    obs = recorded_observations({})
    expected, unnormalized = sb3_actions(run, algo, obs)
    got = run_file(res["policy"], fmt, obs)
    assert got.shape == expected.shape == (len(obs), 2) and got.dtype == np.float32
    assert np.max(np.abs(got - expected)) < 1e-5
    # One observation at a time, as on the robot.
    single = np.concatenate([run_file(res["policy"], fmt, obs[i : i + 1]) for i in range(0, len(obs), 17)])
    assert np.max(np.abs(single - expected[::17])) < 1e-5
    # The test can fail: the actions vary, and the statistics change them (they are folded in).
    assert np.std(expected, axis=0).min() > 1e-4
    assert np.max(np.abs(unnormalized - expected)) > 1e-3
    assert sorted(p.name for p in (tmp_path / "export").iterdir()) == sorted(["policy.json", res["policy"].name])


def test_layout_file_describes_the_env(tiny_ppo_run, tmp_path):
    res = export(str(tiny_ppo_run), "torchscript", tmp_path / "export")
    layout = json.loads(res["layout"].read_text())
    env = gym.make(ENV, shell_model="point")
    u = env.unwrapped
    assert [o["name"] for o in layout["observation"]] == list(u.observation_layout.names)
    assert all(o["unit"] for o in layout["observation"])
    assert all(
        o["from_sensors"]["computation"] and o["from_sensors"]["unit"] == o["unit"] for o in layout["observation"]
    )
    assert [a["torque_limit_nm"] for a in layout["action"]] == [u.steer_torque_limit_nm, u.drive_torque_limit_nm]
    assert layout["control_frequency_hz"] == pytest.approx(1.0 / u.control_period_s)
    assert (layout["env_id"], layout["shell_model"], layout["algo"], layout["file"]) == (
        ENV,
        "point",
        "ppo",
        "policy.pt",
    )
    rms = read_stats(tiny_ppo_run / "vecnormalize.json").obs_rms
    assert [o["normalization_mean"] for o in layout["observation"]] == pytest.approx(rms.mean.tolist(), rel=1e-12)
    assert layout["check"]["max_abs_action_diff"] < 1e-5 and layout["versions"]["torch"]
    env.close()


def test_action_layout_is_what_step_applies():
    env = gym.make(ENV, shell_model="point", randomization="off", steer_torque_limit_nm=15.0)
    env.reset(seed=0)
    action = np.array([0.5, -0.25], np.float32)
    _, _, _, _, info = env.step(action)
    expected = [
        rec["joint_torque_sign"] * a * rec["torque_limit_nm"] for rec, a in zip(env.unwrapped.action_layout(), action)
    ]
    assert info["motor_torque_nm"] == pytest.approx(expected) and expected == pytest.approx([7.5, 5.5])
    env.close()


@pytest.mark.parametrize(
    "case, needles",
    [
        ("format", ["field 'format' = 'tflite'", "onnx", "torchscript"]),
        ("out_file", ["field 'out'", "is a file"]),
        ("tol", ["field 'tol' = -1"]),
        ("tiny_tol", ["check:", "nothing written"]),
        ("no_vecnormalize", ["run:", "vecnormalize.json", "is missing"]),
        ("other_env", ["env:", "--allow-env-mismatch"]),
    ],
)
def test_bad_export_refused_with_nothing_written(tiny_ppo_run, tmp_path, capsys, case, needles):
    run = str(tiny_ppo_run)
    (tmp_path / "file").write_text("keep")
    out = ["--out", str(tmp_path / "new" / "export")]
    if case == "no_vecnormalize":
        run = str(tmp_path / "copy")
        shutil.copytree(tiny_ppo_run, run)
        (tmp_path / "copy" / "vecnormalize.json").unlink()
    argv = {
        "format": [run, "--format", "tflite", *out],
        "out_file": [run, "--out", str(tmp_path / "file" / "x")],
        "tol": [run, "--tol", "-1", *out],
        "tiny_tol": [run, "--tol", "1e-30", *out],
        "no_vecnormalize": [run, *out],
        "other_env": [run, "--env", "sphere_env/Roll-v1", *out],
    }[case]
    with pytest.raises(SystemExit) as exc:
        export_main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    for n in needles:
        assert n in err, err
    assert not (tmp_path / "new").exists() and (tmp_path / "file").read_text() == "keep"


def test_an_interrupted_export_leaves_the_previous_pair(tiny_ppo_run, tmp_path, monkeypatch):
    """The policy file and policy.json are replaced together: an export that fails after writing
    its policy file (here: while writing policy.json) leaves the previous export's pair as it was."""
    import pathlib

    out = tmp_path / "deploy"
    export(str(tiny_ppo_run), "torchscript", out)
    (out / "NOTES.txt").write_text("mine")
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    real = pathlib.Path.write_text

    def fail_on_layout(self, *args, **kwargs):
        if self.name == "policy.json":
            raise KeyboardInterrupt
        return real(self, *args, **kwargs)

    monkeypatch.setattr(pathlib.Path, "write_text", fail_on_layout)
    with pytest.raises(KeyboardInterrupt):
        export(str(tiny_ppo_run), "torchscript", out)
    monkeypatch.undo()
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no staging left behind
    export(str(tiny_ppo_run), "onnx", out)  # a complete export replaces the pair, keeps the user's file
    assert sorted(p.name for p in out.iterdir()) == ["NOTES.txt", "policy.json", "policy.onnx"]
