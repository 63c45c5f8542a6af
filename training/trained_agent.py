"""The model a run continues from (the trainer's ``-i``, rl-zoo3's ``--trained-agent``): where its
files are, and whether it fits the configured env, checked before anything is built."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

from pydantic import BeforeValidator, Field, FilePath

from sphere_env.schemas import allowed, checker
from sphere_env.training.config import TrainConfig, algo_class

#: A saved model: the name of a .zip file, and a file that exists (a run folder is given as its model.zip).
_MODEL_WORDS = allowed("a saved model: a .zip file, or a run folder with model.zip")
_ZIP_NAME = checker(Annotated[str, Field(pattern=r"\.zip$", json_schema_extra=_MODEL_WORDS)])
_EXISTING_FILE = checker(
    Annotated[FilePath, BeforeValidator(lambda text: Path(text)), Field(json_schema_extra=_MODEL_WORDS)]
)


def trained_agent_files(cfg: TrainConfig) -> tuple[Path, Path | None]:
    """The model zip ``cfg.trained_agent`` and the VecNormalize statistics saved with it (None
    without normalization). Statistics are looked for where this trainer and rl-zoo3 put them:
    ``vecnormalize.json`` beside the zip (a run's ``model.zip``, ``best/best_model.zip``),
    ``checkpoints/rl_model_vecnormalize_<n>_steps.json`` for ``rl_model_<n>_steps.zip``, and
    rl-zoo3's ``<dir>/<env id with / as ->/vecnormalize.pkl``; each also as the ``.pkl`` of older
    folders (read as data: :func:`sphere_env.training.saved.read_stats`).

    :raises ValueError: ``trained_agent: ...`` (missing, unreadable, statistics missing).
    """
    import re

    path = Path(str(cfg.trained_agent))
    if path.is_dir() and (path / "model.zip").exists():
        path = path / "model.zip"
    path = _EXISTING_FILE(_ZIP_NAME(str(path), "trained_agent"), "trained_agent")
    if cfg.normalize is None:
        return path, None
    from sphere_env.training.saved import stats_path

    bases = [path.parent / "vecnormalize", path.parent / cfg.env_id.replace("/", "-") / "vecnormalize"]
    m = re.fullmatch(r"(.+)_(\d+)_steps\.zip", path.name)
    if m:
        bases.insert(0, path.parent / f"{m.group(1)}_vecnormalize_{m.group(2)}_steps")
    candidates = [stats_path(b) for b in bases]
    for c in candidates:
        if c.is_file():
            return path, c
    raise ValueError(
        f"trained_agent: no VecNormalize statistics for {str(path)!r} (looked for "
        f"{[str(c) for c in candidates]}); the config normalizes observations, so the model "
        "cannot continue without them (or set normalize: false)"
    )


def check_trained_agent(cfg: TrainConfig, env) -> None:
    """Load ``cfg.trained_agent`` and its statistics; refuse them unless they fit ``env``'s spaces."""
    from sphere_env.training.saved import load_model, read_stats

    path, stats = trained_agent_files(cfg)
    try:
        model = load_model(algo_class(cfg.algo), path, cfg.algo_kwargs(), device="cpu")
    except Exception as err:  # noqa: BLE001 - any failure to read means "not usable"
        raise ValueError(
            f"trained_agent: {str(path)!r} cannot be loaded as {cfg.algo.upper()}: {type(err).__name__}: {err}"
        ) from None
    for name in ("observation_space", "action_space"):
        have, want = getattr(model, name), getattr(env, name)
        if have.shape != want.shape:
            raise ValueError(
                f"trained_agent: {str(path)!r} has {name} shape {have.shape}; "
                f"{cfg.env_id} with these env_kwargs has {want.shape}"
            )
    # -i continues the saved network: policy_kwargs that differ from its own would be recorded in
    # config.yaml as used while the run trains the saved network, so they are refused
    given = cfg.algo_kwargs().get("policy_kwargs")
    saved = dict(getattr(model, "policy_kwargs", {}) or {})
    if given is not None:
        differ = {k: v for k, v in given.items() if k not in saved or saved[k] != v}
        if differ:
            raise ValueError(
                f"hyperparams.policy_kwargs: {differ} differ from the network of trained_agent "
                f"{str(path)!r} ({ {k: saved[k] for k in differ if k in saved} or 'not set there' }), "
                "which -i continues as it is; leave them out or train a new run"
            )
    if stats is not None:
        try:
            vn = read_stats(stats)
        except ValueError as err:
            raise ValueError(f"trained_agent: {err}") from None
        shape = getattr(getattr(vn, "obs_rms", None), "mean", None)
        if shape is None or np_shape(shape) != env.observation_space.shape:
            raise ValueError(
                f"trained_agent: {str(stats)!r} does not hold VecNormalize statistics for "
                f"observations of shape {env.observation_space.shape}"
            )


def np_shape(x: Any) -> tuple[int, ...]:
    import numpy as np

    return tuple(np.shape(x))
