"""Package data: the robot, friction, calibration and log-manifest assets, and the training YAMLs.

The repository keeps ``assets/`` and ``training/hyperparams/`` at its top level; the package
installs them as ``sphere_env.assets`` and ``sphere_env.training`` (``package-dir`` in
``pyproject.toml``), so the same :mod:`importlib.resources` lookup works from an editable
install, from a wheel and from a source checkout.

    from sphere_env.resources import asset_path
    asset_path("robot", "roboball.urdf")          # -> pathlib.Path of the installed file
"""

from __future__ import annotations

import atexit
import contextlib
from importlib import resources
from pathlib import Path

ASSETS_PACKAGE = "sphere_env.assets"
TRAINING_PACKAGE = "sphere_env.training"

_extracted = contextlib.ExitStack()  # files extracted from a zipped install, removed at exit
atexit.register(_extracted.close)


def _as_path(resource) -> Path:
    """A real file-system path for ``resource``: the file itself when the package is a folder
    (pip, editable and source installs), else a temporary copy that lives until the process
    exits (zipped installs). Drake's parsers need real paths."""
    if isinstance(resource, Path):
        return resource
    return _extracted.enter_context(resources.as_file(resource))


def asset_path(*parts: str) -> Path:
    """Path of an installed asset, e.g. ``asset_path("friction", "presets.yaml")``.

    :raises FileNotFoundError: naming the asset and the folder searched.
    """
    if not parts:
        raise ValueError("asset_path: give at least one path part, e.g. asset_path('robot', 'roboball.urdf')")
    resource = resources.files(ASSETS_PACKAGE).joinpath(*parts)
    if not resource.is_file():
        raise FileNotFoundError(f"asset {'/'.join(parts)!r} not found in {resources.files(ASSETS_PACKAGE)}")
    return _as_path(resource)


def hyperparams_path(algo: str) -> Path:
    """Path of the shipped hyperparameter YAML of ``algo`` (``training/hyperparams/<algo>.yml``).

    :raises FileNotFoundError: naming the algorithm and the files that exist.
    """
    folder = resources.files(TRAINING_PACKAGE).joinpath("hyperparams")
    resource = folder.joinpath(f"{algo}.yml")
    if not resource.is_file():
        shipped = sorted(p.name for p in folder.iterdir() if p.name.endswith(".yml"))
        raise FileNotFoundError(f"no hyperparameter file for algo {algo!r}; shipped: {shipped}")
    return _as_path(resource)


#: Policies shipped with the package: name -> folder under ``assets/policies`` (a training run
#: folder: config.yaml, model.zip, vecnormalize.json, plus card.json with how it was trained and
#: what it scored).
SHIPPED_POLICIES = {"pretrained": "ramp_descent_v3"}


def shipped_policy_path(name: str) -> Path:
    """Folder of a shipped policy (``"pretrained"``), usable wherever a run folder is.

    :raises FileNotFoundError: naming the policy and the shipped ones.
    """
    if name not in SHIPPED_POLICIES:
        raise FileNotFoundError(f"no shipped policy {name!r}; shipped: {sorted(SHIPPED_POLICIES)}")
    folder = resources.files(ASSETS_PACKAGE).joinpath("policies", SHIPPED_POLICIES[name])
    for part in ("config.yaml", "model.zip", "vecnormalize.json"):
        _as_path(folder.joinpath(part))
    return _as_path(folder)
