"""A run folder or a shipped policy is data, not code: loading one never runs code from it.

VecNormalize statistics are JSON (:mod:`sphere_env.training.saved`); an older folder's
``vecnormalize.pkl`` and a model zip's cloudpickled entries are read through the data-only
unpickler (:mod:`sphere_env.safe_pickle`), and the schedules come from the run's configuration.
Every crafted file below would create a marker file when unpickled; each is refused by name and the
marker never appears. The shipped policy acts as SB3's own loading makes it act.
"""

from __future__ import annotations

import base64
import json
import os
import pickle
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

from sphere_env import safe_pickle
from sphere_env.evaluation.controller_specs import PolicyController, check_spec, run_path
from sphere_env.training.saved import read_stats, save_stats


class _Runs:
    """Unpickled, runs ``os.system``, which creates the marker file."""

    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


@pytest.fixture
def folder(tmp_path):
    """A copy of the shipped policy's run folder."""
    dest = tmp_path / "policy"
    shutil.copytree(run_path("pretrained"), dest)
    return dest


@pytest.fixture
def no_cloudpickle(monkeypatch):
    """SB3's cloudpickle.loads (how it reads a model zip's pickled entries) fails the test if called."""
    from stable_baselines3.common import save_util

    def refuse(*args, **kwargs):
        raise AssertionError("a model entry was unpickled")

    monkeypatch.setattr(save_util.cloudpickle, "loads", refuse)


def _sb3_actions(folder: Path, env, obs: np.ndarray) -> np.ndarray:
    """Deterministic actions of a run folder's model as SB3 itself loads it (``PPO.load``, its
    pickled entries unpickled) and normalizes (a VecNormalize over ``env`` holding the saved
    statistics)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    data = json.loads((folder / "vecnormalize.json").read_text())
    model = PPO.load(folder / "model.zip", device="cpu")
    venv = VecNormalize(DummyVecEnv([lambda: env]), training=False, norm_reward=False)
    venv.clip_obs, venv.epsilon = data["clip_obs"], data["epsilon"]
    venv.obs_rms.mean = np.asarray(data["obs_rms"]["mean"], np.float64)
    venv.obs_rms.var = np.asarray(data["obs_rms"]["var"], np.float64)
    actions, _ = model.predict(venv.normalize_obs(obs), deterministic=True)
    return actions


def test_the_shipped_policy_acts_as_sb3_loads_it_with_nothing_unpickled(request):
    """On observations of the env it was trained for, the shipped policy's network acts exactly as
    when SB3 loads it its own way (cloudpickle) and VecNormalize normalizes; loading it through the
    data-only route unpickles nothing."""
    import gymnasium as gym

    from sphere_env.evaluation.controller_specs import env_kwargs_of

    env = gym.make("sphere_env/RampDescent-v3", **env_kwargs_of("pretrained"))
    obs = np.stack([env.reset(seed=seed)[0] for seed in range(6)]).astype(np.float32)
    expected = _sb3_actions(run_path("pretrained"), env, obs)
    env.close()
    request.getfixturevalue("no_cloudpickle")
    check_spec("pretrained", "sphere_env/RampDescent-v3")
    controller = PolicyController(run_path("pretrained"))
    actions, _ = controller.model.predict(controller.normalize(obs), deterministic=True)
    assert np.array_equal(actions, expected)
    assert not (run_path("pretrained") / "vecnormalize.pkl").exists()


def _swap_pickle(folder: Path, marker: Path, payload: object = None) -> Path:
    (folder / "vecnormalize.json").unlink()
    path = folder / "vecnormalize.pkl"
    path.write_bytes(pickle.dumps(_Runs(marker) if payload is None else payload))
    return path


@pytest.mark.parametrize("load", ["check_spec", "PolicyController"])
def test_a_vecnormalize_pickle_that_runs_code_is_refused(folder, tmp_path, load):
    marker = tmp_path / "ran"
    _swap_pickle(folder, marker)
    with pytest.raises(ValueError, match=r"vecnormalize\.pkl: the pickle calls 'posix.system'.*refused"):
        check_spec(str(folder)) if load == "check_spec" else PolicyController(folder)
    assert not marker.exists()


@pytest.mark.parametrize("payload, kind", [({"obs_rms": [1.0]}, "'dict'"), ([1, 2], "'list'")])
def test_a_vecnormalize_pickle_of_another_type_is_a_named_error(folder, tmp_path, payload, kind):
    _swap_pickle(folder, tmp_path / "ran", payload)
    with pytest.raises(ValueError, match=rf"vecnormalize\.pkl: holds {kind}, not VecNormalize statistics"):
        PolicyController(folder)


def test_an_older_folders_vecnormalize_pickle_still_reads(tmp_path):
    """A genuine VecNormalize pickle (what runs wrote before the JSON) gives the same statistics."""
    import gymnasium as gym
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    vn = VecNormalize(DummyVecEnv([lambda: gym.make("Pendulum-v1")]), clip_obs=7.0)
    vn.reset()
    for _ in range(5):
        vn.step(np.zeros((1, 1), np.float32))
    (tmp_path / "vecnormalize.pkl").write_bytes(pickle.dumps(vn))
    old = read_stats(tmp_path / "vecnormalize.pkl")
    new = read_stats(save_stats(old, tmp_path / "vecnormalize.json"))
    obs = np.array([[0.3, -0.2, 1.5]], np.float32)
    assert np.array_equal(vn.normalize_obs(obs), old.normalize_obs(obs))
    assert np.array_equal(vn.normalize_obs(obs), new.normalize_obs(obs))
    assert (new.clip_obs, new.obs_rms.count) == (7.0, vn.obs_rms.count)
    vn.close()


@pytest.mark.parametrize(
    "change, needle",
    [
        (lambda d: d.update(format="other"), "field 'format'"),
        (lambda d: d["obs_rms"].update(var=[-1.0] * len(d["obs_rms"]["var"])), r"field 'obs_rms.var\[0\]' = -1.0"),
        (lambda d: d["obs_rms"].update(mean=[0.0] * 3), r"mean and var must hold \d+ numbers"),
        (lambda d: d.update(clip_obs=float("nan")), "field 'clip_obs'"),
    ],
    ids=["format", "negative-var", "wrong-size", "nan-clip"],
)
def test_a_statistics_file_with_a_wrong_value_is_refused_by_field(folder, change, needle):
    path = folder / "vecnormalize.json"
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=needle):
        check_spec(str(folder))


def _rewrite_entry(zip_path: Path, key: str, payload: object) -> None:
    with zipfile.ZipFile(zip_path) as z:
        files = {name: z.read(name) for name in z.namelist()}
    data = json.loads(files["data"])
    data[key] = {":type:": "<class 'object'>", ":serialized:": base64.b64encode(pickle.dumps(payload)).decode()}
    files["data"] = json.dumps(data).encode()
    with zipfile.ZipFile(zip_path, "w") as z:
        for name, content in files.items():
            z.writestr(name, content)


@pytest.mark.parametrize("key", ["observation_space", "_last_obs", "policy_class", "rollout_buffer_class"])
def test_a_model_entry_that_runs_code_is_refused_by_name(folder, tmp_path, key):
    marker = tmp_path / "ran"
    _rewrite_entry(folder / "model.zip", key, _Runs(marker))
    with pytest.raises(ValueError, match=rf"model\.zip: entry '{key}'.*refused"):
        check_spec(str(folder))
    with pytest.raises(ValueError, match=rf"entry '{key}'"):
        PolicyController(folder)
    assert not marker.exists()


def test_a_schedule_entry_is_never_read(folder, tmp_path, no_cloudpickle):
    """Schedules come from the run's configuration: a crafted one is not even looked at."""
    marker = tmp_path / "ran"
    _rewrite_entry(folder / "model.zip", "learning_rate", _Runs(marker))
    controller = PolicyController(folder)
    assert controller.model.learning_rate(1.0) == pytest.approx(3e-4) and not marker.exists()


def test_a_pickle_cannot_call_a_data_class_constructor():
    """A statistics object is built from its state; calling its constructor (whose shape could ask
    for gigabytes) is refused before anything is called."""
    from stable_baselines3.common.running_mean_std import RunningMeanStd

    class Huge:
        def __reduce__(self):
            return (RunningMeanStd, (1e-4, (10**10,)))

    with pytest.raises(safe_pickle.UnsafePickleError, match="calls 'stable_baselines3.*RunningMeanStd'"):
        safe_pickle.loads(pickle.dumps(Huge()), "stats")
