"""Typed schemas of the ``enjoy``, ``export`` and ``demo`` commands' options, checked when loaded,
before any env is built or anything is written (the field types they share with ``evaluate`` are
:mod:`sphere_env.evaluation.schemas`'s)."""

from __future__ import annotations

from typing import Annotated, Any, Literal, Mapping

from pydantic import AfterValidator, Field, model_validator

from sphere_env.evaluation.schemas import (
    ENJOY_KWARGS,
    EXPORT_FORMATS,
    MAX_ENJOY_EPISODES,
    MAX_WORKERS,
    EnvId,
    Seed,
    ShellModel,
    _env_kwargs_without,
)
from sphere_env.files import OutputFolder
from sphere_env.schemas import Built, Finite, Schema, allowed, count, number


def _run_folder(run: str) -> str:
    """The folder of ``<run folder>[@best|@model]`` exists."""
    from sphere_env.evaluation.controller_specs import run_path

    if not run_path(run.partition("@")[0]).is_dir():
        raise ValueError("is not a folder (a training run folder holds config.yaml, model.zip, vecnormalize.json)")
    return run


RunText = Annotated[
    str,
    AfterValidator(_run_folder),
    Field(
        pattern=r"^[^@]*(?:@(?:best|model))?$",
        json_schema_extra=allowed("a training run folder or pretrained, optionally @best"),
    ),
]


class EnjoyFields(Built):
    """What the enjoy command watches (see ``EnjoySpec``). ``None`` fields take the run's own
    values (env id, shell model) or the calibration's nominal pressure [kPa]."""

    run: RunText
    episodes: count(1, MAX_ENJOY_EPISODES) = 1
    pressure_kpa: Finite | None = Field(None, json_schema_extra=allowed("a pressure [kPa] inside the calibrated range"))
    shell_model: ShellModel | None = None
    seed: Seed = 0
    deterministic: bool = True
    env_id: EnvId | None = None
    allow_env_mismatch: bool = False
    env_kwargs: Annotated[dict[str, Any], AfterValidator(_env_kwargs_without(ENJOY_KWARGS, "the enjoy command"))] = (
        Field(default_factory=dict, json_schema_extra=allowed("a mapping of env kwargs"))
    )
    label: Annotated[str, Field(min_length=1)] | None = Field(
        None, json_schema_extra=allowed("a non-empty name (default: the run folder's)")
    )


class ViewOptions(Schema):
    """How the enjoy command shows its episodes."""

    meshcat: bool = False
    video: OutputFolder | None = None
    realtime_rate: number(ge=0.0) = Field(
        1.0, json_schema_extra=allowed("a finite number >= 0 (simulated s per wall-clock s; 0: as fast as possible)")
    )


class ExportOptions(Schema):
    """The export command's options (:func:`sphere_env.evaluation.export.export`); ``out`` defaults
    to ``<run>/export`` (``<run>/export_best`` for ``@best``)."""

    run: RunText
    format: Literal[tuple(EXPORT_FORMATS)] = Field(  # type: ignore[valid-type]
        "onnx", json_schema_extra=allowed(f"one of {list(EXPORT_FORMATS)}")
    )
    out: OutputFolder
    tol: number(gt=0.0) = 1e-5
    env_id: EnvId | None = None
    allow_env_mismatch: bool = False

    @model_validator(mode="before")
    @classmethod
    def _default_out(cls, data: Any) -> Any:
        if isinstance(data, Mapping) and data.get("out") is None and isinstance(data.get("run"), str):
            from sphere_env.evaluation.controller_specs import run_path

            path, _, which = data["run"].partition("@")
            data = {**data, "out": run_path(path) / ("export_best" if which == "best" else "export")}
        return data


class DemoOptions(Schema):
    """The demo's options (``sphere-env demo``), checked before its training starts, so that a bad
    output folder cannot fail the demo after the training ran."""

    train_steps: count(1, 10**9)
    seed: Seed
    seeds: list[Seed] = Field(
        min_length=1, max_length=100, json_schema_extra=allowed("1 to 100 integer seeds in [0, 2**32 - 1]")
    )
    fault_seeds: list[Seed] | None = Field(
        None,
        min_length=1,
        max_length=100,
        json_schema_extra=allowed("1 to 100 integer seeds in [0, 2**32 - 1], or none for the first evaluation seed"),
    )
    out: OutputFolder
    run_dir: OutputFolder | None = None
    workers: count(1, MAX_WORKERS) | None = None
