"""A run's saved files read as data, never as code: its models and its observation statistics.

**Models.** A stable-baselines3 ``model.zip`` keeps some entries as cloudpickles: the learning-rate
and clip-range schedules (functions), the policy and buffer classes, spaces and arrays.
:func:`load_model` gives SB3 every one of them in ``custom_objects``, so SB3 never unpickles the
file: schedules come from the run's configuration (SB3 rebuilds ``lr_schedule`` and the clip
ranges from them), classes are read as references to installed classes
(:func:`sphere_env.safe_pickle.class_reference`) and everything else as plain data
(:func:`sphere_env.safe_pickle.loads`). The weights load with ``torch.load(weights_only=True)``.

**Statistics.** VecNormalize's statistics are written as JSON (:data:`STATS_SUFFIX`:
``vecnormalize.json``, ``checkpoints/rl_model_vecnormalize_<n>_steps.json``) by :func:`save_stats`
and read by :func:`read_stats`. A folder written before holds ``vecnormalize.pkl`` instead: it is
read when no JSON is beside it, through the data-only unpickler, which refuses anything but
VecNormalize's own state; that pickle is the one trust boundary left (README, "Trust").
"""

from __future__ import annotations

import base64
import inspect
import json
import math
import zipfile
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from sphere_env import safe_pickle
from sphere_env.files import write_text_atomic
from sphere_env.schemas import Schema, count, number, shown, validate

STATS_SUFFIX = ".json"
LEGACY_SUFFIX = ".pkl"
FORMAT = "sphere_env.vecnormalize/1"
#: The largest statistics file read [bytes] (an observation of 22 numbers takes about 2 kB).
MAX_STATS_BYTES = 16 * 1024 * 1024
#: Entries the run's configuration gives (else the algorithm's default): the schedules, whose saved
#: value is a function (SB3 rebuilds ``lr_schedule`` from ``learning_rate``, the clip ranges from
#: themselves), and SAC's ``train_freq`` (rebuilt from its number or pair).
CONFIGURED = ("learning_rate", "lr_schedule", "clip_range", "clip_range_vf", "train_freq")
#: Entries that are classes (read as references to installed classes).
CLASSES = ("policy_class", "rollout_buffer_class", "replay_buffer_class")

_SETTINGS = ("norm_obs", "norm_reward", "clip_obs", "clip_reward", "gamma", "epsilon")
_Real = number()
_Positive = number(gt=0)


class _RunningStats(Schema):
    shape: list[count(low=1, high=1_000_000)] = Field(max_length=8)
    mean: list[_Real] = Field(max_length=1_000_000)
    var: list[number(ge=0)] = Field(max_length=1_000_000)
    count: _Positive

    @model_validator(mode="after")
    def _sizes(self) -> _RunningStats:
        n = math.prod(self.shape)
        if len(self.mean) != n or len(self.var) != n:
            raise ValueError(f"mean and var must hold {n} numbers each (shape {self.shape})")
        return self


class _StatsFile(Schema):
    format: Literal["sphere_env.vecnormalize/1"]
    norm_obs: bool
    norm_reward: bool
    clip_obs: _Positive
    clip_reward: _Positive
    gamma: number(ge=0, le=1)
    epsilon: _Positive
    obs_rms: _RunningStats
    ret_rms: _RunningStats


class ObsStats:
    """VecNormalize's statistics without an env: ``normalize_obs`` as VecNormalize computes it
    (``clip((obs − mean) / sqrt(var + epsilon), ±clip_obs)`` in float64, returned as float32)."""

    training = False

    def __init__(self, *, norm_obs, norm_reward, clip_obs, clip_reward, gamma, epsilon, obs_rms, ret_rms):
        self.norm_obs, self.norm_reward = bool(norm_obs), bool(norm_reward)
        self.clip_obs, self.clip_reward = float(clip_obs), float(clip_reward)
        self.gamma, self.epsilon = float(gamma), float(epsilon)
        self.obs_rms, self.ret_rms = obs_rms, ret_rms

    @classmethod
    def of(cls, vn: Any, where: str) -> ObsStats:
        """The statistics of a VecNormalize (or of an object with its attributes, such as an
        ``ObsStats``), checked as a statistics file is.

        :raises ValueError: naming ``where``: another type, a missing or wrong value.
        """
        from stable_baselines3.common.running_mean_std import RunningMeanStd
        from stable_baselines3.common.vec_env import VecNormalize

        rms = [getattr(vn, name, None) for name in ("obs_rms", "ret_rms")]
        if not isinstance(vn, (VecNormalize, ObsStats)) or not all(isinstance(r, RunningMeanStd) for r in rms):
            raise ValueError(
                f"{where}: holds {shown(type(vn).__name__)}, not VecNormalize statistics of a Box observation "
                "(obs_rms and ret_rms, each a RunningMeanStd)"
            )
        data = {key: getattr(vn, key, None) for key in _SETTINGS}
        try:
            data.update(format=FORMAT, obs_rms=_rms_data(rms[0]), ret_rms=_rms_data(rms[1]))
        except (TypeError, ValueError) as err:
            raise ValueError(f"{where}: statistics that are not arrays of numbers ({shown(str(err))})") from None
        return _from_data(data, where)

    def normalize_obs(self, obs: np.ndarray) -> np.ndarray:
        if not self.norm_obs:
            return np.array(obs, copy=True)
        rms = self.obs_rms
        return np.clip((obs - rms.mean) / np.sqrt(rms.var + self.epsilon), -self.clip_obs, self.clip_obs).astype(
            np.float32
        )

    def as_data(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            **{key: getattr(self, key) for key in _SETTINGS},
            "obs_rms": _rms_data(self.obs_rms),
            "ret_rms": _rms_data(self.ret_rms),
        }

    def into(self, vn: Any) -> Any:
        """``vn`` (a VecNormalize) with these statistics and settings."""
        for key in _SETTINGS:
            setattr(vn, key, getattr(self, key))
        vn.obs_rms, vn.ret_rms = self.obs_rms, self.ret_rms
        return vn


def stats_path(base: Path) -> Path:
    """The statistics file of ``base`` (a path without suffix, e.g. ``<run>/vecnormalize``): its
    JSON, or an older folder's pickle when only that exists (the JSON's path when neither does)."""
    new, old = base.with_name(base.name + STATS_SUFFIX), base.with_name(base.name + LEGACY_SUFFIX)
    return old if old.is_file() and not new.exists() else new


def save_stats(vn: Any, path: Path) -> Path:
    """Write a VecNormalize's statistics to ``path`` (JSON; through a temporary name)."""
    return write_text_atomic(Path(path), json.dumps(ObsStats.of(vn, str(path)).as_data()) + "\n")


def read_stats(path: Path) -> ObsStats:
    """The statistics in ``path``: JSON (:func:`save_stats`), or an older run's ``vecnormalize.pkl``
    read through :func:`sphere_env.safe_pickle.loads` (VecNormalize's state only).

    :raises ValueError: naming the file: unreadable, too large, not statistics, a wrong value.
    """
    path = Path(path)
    where = str(path)
    try:
        size = path.stat().st_size
        if size > MAX_STATS_BYTES:
            raise ValueError(f"{where}: {size} bytes; statistics files are at most {MAX_STATS_BYTES}")
        raw = path.read_bytes()
    except OSError as err:
        raise ValueError(f"{where}: cannot be read ({err.strerror or err})") from None
    if path.suffix == LEGACY_SUFFIX:
        return ObsStats.of(safe_pickle.loads(raw, where), where)
    try:
        data = json.loads(raw)
    except (ValueError, RecursionError) as err:
        raise ValueError(f"{where}: not JSON ({shown(str(err))})") from None
    return _from_data(data, where)


def _rms_data(r: Any) -> dict[str, Any]:
    mean, var = np.asarray(r.mean, np.float64), np.asarray(r.var, np.float64)
    return {"shape": list(mean.shape), "mean": mean.ravel().tolist(), "var": var.ravel().tolist(), "count": r.count}


def _from_data(data: Any, where: str) -> ObsStats:
    """Statistics from their JSON data, validated (:class:`_StatsFile`)."""
    from stable_baselines3.common.running_mean_std import RunningMeanStd

    spec = validate(_StatsFile, data, where)

    def rms(r: _RunningStats) -> RunningMeanStd:
        out = RunningMeanStd(shape=tuple(r.shape))
        out.mean = np.asarray(r.mean, np.float64).reshape(r.shape)
        out.var = np.asarray(r.var, np.float64).reshape(r.shape)
        out.count = r.count
        return out

    return ObsStats(**spec.model_dump(include=set(_SETTINGS)), obs_rms=rms(spec.obs_rms), ret_rms=rms(spec.ret_rms))


def _entries(path: Path) -> dict[str, Any]:
    """The JSON ``data`` entry of an SB3 model zip."""
    with zipfile.ZipFile(path) as z:
        info = z.getinfo("data")
        if info.file_size > safe_pickle.MAX_BYTES:
            raise ValueError(f"{path}: its data entry is {info.file_size} bytes; at most {safe_pickle.MAX_BYTES}")
        return json.loads(z.read("data"))


def custom_objects(cls: type, path: Path, algo_kwargs: dict[str, Any]) -> dict[str, Any]:
    """Every pickled entry of the model zip ``path``, decoded without running code from it:
    :data:`CONFIGURED` entries from ``algo_kwargs`` (else ``cls``'s defaults), classes as references, the rest as data.

    :raises ValueError: naming the file and the entry that holds anything else.
    """
    from stable_baselines3.common.buffers import BaseBuffer
    from stable_baselines3.common.policies import BasePolicy

    defaults = {k: p.default for k, p in inspect.signature(cls.__init__).parameters.items()}
    out: dict[str, Any] = {}
    for key, value in _entries(path).items():
        if not (isinstance(value, dict) and ":serialized:" in value):
            continue
        where = f"{path}: entry {shown(key)}"
        if key in CONFIGURED:
            out[key] = algo_kwargs.get(key, defaults.get(key))
            if key == "lr_schedule":
                out[key] = algo_kwargs.get("learning_rate", defaults.get("learning_rate"))
            continue
        data = base64.b64decode(value[":serialized:"])
        if key in CLASSES:
            out[key] = safe_pickle.class_reference(data, where, (BasePolicy, BaseBuffer))
        else:
            out[key] = safe_pickle.loads(data, where)
    return out


def load_model(cls: type, path: Path, algo_kwargs: dict[str, Any] | None = None, **kwargs: Any) -> Any:
    """``cls.load(path, **kwargs)`` with :func:`custom_objects`: nothing in the file is run."""
    path = Path(path)
    return cls.load(path, custom_objects=custom_objects(cls, path, dict(algo_kwargs or {})), **kwargs)


#: A replay buffer's pickle may also create the buffer and name its torch device.
_BUFFER_CLASSES = (("stable_baselines3.common.buffers", "ReplayBuffer"),)
_BUFFER_CALLS = (("torch", "device"),)
#: The largest replay buffer read [bytes] (a million transitions of this project's envs: about 400 MB).
MAX_REPLAY_BYTES = 4 * 1024**3


def load_replay_buffer(model: Any, path: Path) -> None:
    """SAC's ``model.load_replay_buffer(path)`` read as data (a ``ReplayBuffer``'s arrays and spaces).

    :raises ValueError: naming the file: too large, unreadable, or holding anything else.
    """
    from stable_baselines3.common.buffers import ReplayBuffer

    path = Path(path)
    if path.stat().st_size > MAX_REPLAY_BYTES:
        raise ValueError(f"{path}: {path.stat().st_size} bytes; a replay buffer of at most {MAX_REPLAY_BYTES} is read")
    buffer = safe_pickle.loads(path.read_bytes(), str(path), _BUFFER_CALLS, _BUFFER_CLASSES, max_bytes=MAX_REPLAY_BYTES)
    if type(buffer) is not ReplayBuffer:
        raise ValueError(f"{path}: holds {shown(type(buffer).__name__)}, not a ReplayBuffer")
    buffer.device = model.device
    model.replay_buffer = buffer
