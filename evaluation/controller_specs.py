"""Controllers for evaluation, built from a picklable spec string inside each worker.

=================================  ===============================================================
spec                               controller
=================================  ===============================================================
``zero``                           zero torque: the paper's uncontrolled descent
``pd``                             the hand-written cascaded PD baseline (:mod:`sphere_env.controllers`)
``runs/<run>`` (a run folder)      a trained policy, final model with its VecNormalize statistics
``runs/<run>@best``                the run's best model (``best/``)
``package.module:attr``            a user callable ``(obs, info) -> action``; a class is
                                   instantiated without arguments; ``reset()`` is called per
                                   episode when present
=================================  ===============================================================

A label can precede any spec: ``ppo=runs/ppo_RampDescent-v0_...``.
"""

from __future__ import annotations

import importlib
import pickle
from pathlib import Path
from typing import Any, Callable

import numpy as np

BASELINES = ("zero", "pd")


def split_label(spec: str) -> tuple[str, str]:
    """``"label=spec"`` -> (label, spec); a bare spec gets a label of its own."""
    if "=" in spec:
        label, body = spec.split("=", 1)
        return label.strip(), body.strip()
    if spec in BASELINES:
        return spec, spec
    path, _, which = spec.partition("@")
    if Path(path).is_dir():
        name = Path(path).name
        return (name if not which else f"{name}@{which}"), spec
    return spec.rsplit(":", 1)[-1], spec


def run_folder(spec: str) -> tuple[Path, str] | None:
    """(folder, "model"|"best") when ``spec`` names a training run folder, else None."""
    path, _, which = spec.partition("@")
    p = Path(path)
    if (p / "config.yaml").exists():
        if which not in ("", "best", "model"):
            raise ValueError(f"controller: {spec!r}: use <run> or <run>@best")
        return p, which or "model"
    return None


def check_spec(spec: str) -> None:
    """Refuse a spec that cannot be resolved (called in the main process before a sweep)."""
    if spec in BASELINES:
        return
    rf = run_folder(spec)
    if rf is not None:
        folder, which = rf
        model = folder / ("best/best_model.zip" if which == "best" else "model.zip")
        if not model.exists():
            raise ValueError(f"controller: {spec!r}: {model} is missing (training unfinished?)")
        return
    if ":" not in spec:
        raise ValueError(f"controller: {spec!r} is not a baseline {list(BASELINES)}, a run folder with config.yaml, "
                         "or module:function")
    load_callable(spec)


def load_callable(spec: str) -> Callable:
    mod, _, attr = spec.partition(":")
    try:
        obj = getattr(importlib.import_module(mod), attr)
    except (ImportError, AttributeError) as err:
        raise ValueError(f"controller: cannot import {spec!r}: {err}") from None
    if isinstance(obj, type):
        obj = obj()
    if not callable(obj):
        raise ValueError(f"controller: {spec!r} is not callable")
    return obj


class PolicyController:
    """A trained SB3 policy with its VecNormalize observation statistics; deterministic actions.

    :param run_dir: training run folder (``config.yaml``, ``model.zip``, ``vecnormalize.pkl``).
    :param which: ``"model"`` (final) or ``"best"`` (best on the eval env).
    """

    def __init__(self, run_dir: str | Path, which: str = "model"):
        from sphere_env.training.config import algo_class
        from sphere_env.training.train import load_config

        run_dir = Path(run_dir)
        self.config = load_config(run_dir)
        folder = run_dir / "best" if which == "best" else run_dir
        zip_path = folder / ("best_model.zip" if which == "best" else "model.zip")
        self.model = algo_class(self.config.algo).load(zip_path, device="cpu")
        vn = folder / "vecnormalize.pkl"
        self.vecnormalize = None
        if vn.exists():
            with open(vn, "rb") as f:
                self.vecnormalize = pickle.load(f)  # only obs_rms/clip_obs are used: no venv needed
            self.vecnormalize.training = False

    def reset(self) -> None:
        pass

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float32)
        if self.vecnormalize is None:
            return obs
        return self.vecnormalize.normalize_obs(obs)

    def __call__(self, obs, info: dict | None = None) -> np.ndarray:
        action, _ = self.model.predict(self.normalize(obs), deterministic=True)
        return np.asarray(action, dtype=np.float32)


def env_kwargs_of(spec: str) -> dict[str, Any]:
    """Env kwargs a controller needs (a trained policy: its training env kwargs, e.g. observation
    layout and torque limits), without the sweep's own axes."""
    rf = run_folder(spec)
    if rf is None:
        return {}
    from sphere_env.training.train import load_config

    kw = dict(load_config(rf[0]).env_kwargs)
    for k in ("shell_model", "friction_model", "randomization", "render_mode", "record_replay", "meshcat"):
        kw.pop(k, None)
    return kw


def make_controller(spec: str, env: Any) -> Callable:
    """Build the controller for ``spec`` (inside the worker), configured for ``env``."""
    import torch

    torch.set_num_threads(1)
    if spec in BASELINES:
        from sphere_env.controllers import controller_for

        return controller_for(env, spec)
    rf = run_folder(spec)
    if rf is not None:
        return PolicyController(*rf)
    return load_callable(spec)
