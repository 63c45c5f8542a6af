"""Controllers for evaluation, built from a picklable spec string inside each worker.

=================================  ===============================================================
spec                               controller
=================================  ===============================================================
``zero``                           zero torque: the paper's uncontrolled descent
``pd``                             the hand-written cascaded PD baseline (:mod:`sphere_env.controllers`)
``runs/<run>`` (a run folder)      a trained policy, final model with its VecNormalize statistics
``runs/<run>@best``                the run's best model (``best/``)
``runs/<run>@<steps>``             the run's checkpoint at that step count (``checkpoints/``)
``pretrained``                     the policy shipped with the package (``assets/policies``), trained
                                   by the documented recipe; a run folder like any other
``package.module:attr``            a user callable ``(obs, info) -> action``; a class is
                                   instantiated without arguments; ``reset()`` is called per
                                   episode when present
=================================  ===============================================================

A label can precede any spec: ``ppo=runs/ppo_RampDescent-v2_...``.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any, Callable

import numpy as np

from sphere_env.wrappers import ACTION_COMBINERS, TRAINING_ONLY_WRAPPERS

BASELINES = ("zero", "pd")


def run_path(path: str) -> Path:
    """The folder a run spec's path names: a shipped policy's (``pretrained``) or the path itself."""
    from sphere_env.resources import SHIPPED_POLICIES, shipped_policy_path

    return shipped_policy_path(path) if path in SHIPPED_POLICIES else Path(path)


def split_label(spec: str) -> tuple[str, str]:
    """``"label=spec"`` -> (label, spec); a bare spec gets a label of its own."""
    if "=" in spec:
        label, body = spec.split("=", 1)
        return label.strip(), body.strip()
    if spec in BASELINES:
        return spec, spec
    path, _, which = spec.partition("@")
    from sphere_env.resources import SHIPPED_POLICIES

    if path in SHIPPED_POLICIES:
        return spec, spec
    if Path(path).is_dir():
        name = Path(path).name
        return (name if not which else f"{name}@{which}"), spec
    return spec.rsplit(":", 1)[-1], spec


def run_folder(spec: str) -> tuple[Path, str] | None:
    """(folder, "model"|"best") when ``spec`` names a training run folder, else None."""
    path, _, which = spec.partition("@")
    p = run_path(path)
    if (p / "config.yaml").exists():
        if which not in ("", "best", "model") and not which.isdigit():
            raise ValueError("use <run>, <run>@best or <run>@<checkpoint steps>")
        return p, which or "model"


def model_files(folder: Path, which: str) -> tuple[Path, Path]:
    """(model zip, VecNormalize statistics) of a run folder's final model (``"model"``), best model
    (``"best"``) or checkpoint (its step count, as written by the trainer's checkpoints). The
    statistics are ``vecnormalize.json``, or an older folder's ``vecnormalize.pkl`` when only that
    exists (:func:`sphere_env.training.saved.stats_path`)."""
    from sphere_env.training.saved import stats_path

    if which == "best":
        return folder / "best" / "best_model.zip", stats_path(folder / "best" / "vecnormalize")
    if which.isdigit():
        from sphere_env.training.run_folder import CHECKPOINT_PREFIX

        ck = folder / "checkpoints"
        return ck / f"{CHECKPOINT_PREFIX}_{which}_steps.zip", stats_path(
            ck / f"{CHECKPOINT_PREFIX}_vecnormalize_{which}_steps"
        )
    return folder / "model.zip", stats_path(folder / "vecnormalize")


def check_spec(spec: str, env_id: str | None = None, allow_env_mismatch: bool = False) -> None:
    """Refuse a spec (of the form :class:`sphere_env.evaluation.schemas.ControllerSpec` admits) that
    cannot be resolved, in the main process before a sweep: a callable that does not import, a run
    folder whose model is missing or unreadable, or a policy trained on another env id than
    ``env_id`` (unless ``allow_env_mismatch``)."""
    if spec in BASELINES:
        return
    rf = run_folder(spec)
    if rf is not None:
        from sphere_env.training.config import algo_class
        from sphere_env.training.run_folder import load_config
        from sphere_env.training.saved import load_model, read_stats

        folder, which = rf
        model, vn = model_files(folder, which)
        if not model.exists():
            raise ValueError(f"controller: {spec!r}: {model} is missing (training unfinished?)")
        try:
            cfg = load_config(folder)
        except Exception as err:  # noqa: BLE001 - an unreadable config.yaml
            raise ValueError(f"controller: {spec!r}: {folder / 'config.yaml'} cannot be read: {err}") from None
        if env_id is not None and cfg.env_id != env_id and not allow_env_mismatch:
            raise ValueError(
                f"env: {spec!r} was trained on {cfg.env_id!r}, not on the evaluated env "
                f"{env_id!r}; pass --allow-env-mismatch to evaluate it there anyway"
            )
        try:
            load_model(algo_class(cfg.algo), model, cfg.algo_kwargs(), device="cpu")
        except Exception as err:  # noqa: BLE001 - truncated or foreign zip
            raise ValueError(
                f"controller: {spec!r}: {model} cannot be loaded ({type(err).__name__}: {err}); "
                "a truncated or corrupt model file"
            ) from None
        if cfg.normalize is not None and not vn.exists():
            raise ValueError(
                f"controller: {spec!r}: {vn} is missing: the policy was trained on VecNormalize-d "
                "observations and cannot be evaluated without their statistics"
            )
        if vn.exists():
            try:
                read_stats(vn)
            except ValueError as err:
                raise ValueError(f"controller: {spec!r}: {err}") from None
        return
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

    :param run_dir: training run folder (``config.yaml``, ``model.zip``, ``vecnormalize.json``).
    :param which: ``"model"`` (final), ``"best"`` (best on the eval env) or a checkpoint's step count.
    """

    def __init__(self, run_dir: str | Path, which: str = "model"):
        from sphere_env.training.config import algo_class
        from sphere_env.training.run_folder import load_config
        from sphere_env.training.saved import load_model, read_stats

        run_dir = Path(run_dir)
        self.config = load_config(run_dir)
        zip_path, vn = model_files(run_dir, which)
        self.model = load_model(algo_class(self.config.algo), zip_path, self.config.algo_kwargs(), device="cpu")
        self.vecnormalize = read_stats(vn) if vn.exists() else None  # no venv needed
        # the wrappers that change the action (innermost first); training-only ones choose episodes
        self.env_wrapper = [item for item in self.config.env_wrapper if not set(item) <= set(TRAINING_ONLY_WRAPPERS)]
        unknown = [path for item in self.env_wrapper for path in item if path not in ACTION_COMBINERS]
        if unknown:
            raise ValueError(
                f"run: {str(run_dir)!r} was trained inside env_wrapper {unknown}, whose action "
                f"evaluation cannot reproduce on the bare env; allowed: "
                f"{sorted(ACTION_COMBINERS) + list(TRAINING_ONLY_WRAPPERS)}"
            )
        self._combiners: list[Any] | None = [] if not self.env_wrapper else None

    def check_env(self, env: Any, label: str = "") -> None:
        """Refuse an env whose observations the policy cannot read (another layout or size), with a
        ValueError naming both shapes; bind the run's action combination (e.g. the PD of a residual
        policy, :mod:`sphere_env.wrappers`) to ``env``."""
        want, got = self.model.observation_space.shape, env.observation_space.shape
        if want != got:
            raise ValueError(
                f"controller: {label or 'policy'!r} takes observations of shape {want}, the env "
                f"{getattr(env.spec, 'id', '?')!r} gives {got}: another observation layout"
            )
        # wrappers listed innermost first: the agent's action passes the outermost first
        self._combiners = [
            ACTION_COMBINERS[path](env, **kwargs)
            for item in reversed(self.env_wrapper)
            for path, kwargs in item.items()
        ]

    @property
    def needs_env(self) -> bool:
        """Whether the run's action combination (a residual's PD) is not yet bound to an env
        (:meth:`check_env` binds it)."""
        return self._combiners is None

    def reset(self) -> None:
        for c in self._combiners or ():
            c.reset()

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float32)
        if self.vecnormalize is None:
            return obs
        return self.vecnormalize.normalize_obs(obs)

    def act(self, obs, info: dict | None = None, deterministic: bool = True) -> np.ndarray:
        """The action sent to the env: the network's, passed through the run's action combination."""
        if self._combiners is None:
            raise RuntimeError("controller: a policy trained inside env_wrapper acts only after check_env(env)")
        bad = np.flatnonzero(~np.isfinite(np.asarray(obs, dtype=np.float64)))
        if bad.size:
            raise ValueError(
                f"observation: components {bad.tolist()} are not finite ({np.asarray(obs)[bad].tolist()}); "
                "a policy acts on finite observations only"
            )
        action, _ = self.model.predict(self.normalize(obs), deterministic=deterministic)
        action = np.asarray(action, dtype=np.float32)
        for c in self._combiners:
            action = c(obs, info, action)
        return action

    def __call__(self, obs, info: dict | None = None) -> np.ndarray:
        return self.act(obs, info, deterministic=True)


def env_kwargs_of(spec: str) -> dict[str, Any]:
    """Env kwargs a controller needs (a trained policy: its training env kwargs, e.g. observation
    layout and torque limits), without the sweep's own axes and without the training-only contact
    solver (``contact_approximation``): a policy is always evaluated under the reference physics."""
    rf = run_folder(spec)
    if rf is None:
        return {}
    from sphere_env.training.run_folder import load_config

    kw = dict(load_config(rf[0]).env_kwargs)
    for k in (
        "shell_model",
        "friction_model",
        "randomization",
        "render_mode",
        "record_replay",
        "meshcat",
        "contact_approximation",
    ):
        kw.pop(k, None)
    return kw


def check_action(label: str, action: Any) -> np.ndarray:
    """A controller's action as a float array of shape (2,) [τ_steer, τ_drive] (normalized), or a
    ValueError naming the controller and what it returned."""
    try:
        a = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(
            f"controller: {label!r} returned {action!r}; allowed: 2 real numbers [steer, drive] in [-1, 1]"
        ) from None
    if a.size != 2:
        raise ValueError(
            f"controller: {label!r} returned an action of shape {a.shape}; allowed: 2 numbers [steer, drive] in [-1, 1]"
        )
    return a.reshape(2)


def make_controller(spec: str, env: Any) -> Callable:
    """Build the controller for ``spec`` (inside the worker), configured for ``env``."""
    import torch

    torch.set_num_threads(1)
    if spec in BASELINES:
        from sphere_env.controllers import controller_for

        return controller_for(env, spec)
    rf = run_folder(spec)
    if rf is not None:
        policy = PolicyController(*rf)
        policy.check_env(env, spec)
        return policy
    return load_callable(spec)
