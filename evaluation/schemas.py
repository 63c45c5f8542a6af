"""Typed schemas of the evaluation tools' inputs: what ``evaluate``, ``enjoy`` and ``export`` run,
checked when loaded, before any env is built, any worker starts or anything is written.

:class:`ControllerSpec` reads a controller (``label=spec`` text or ``{label, spec}``);
:class:`SweepFields` is the grid of :class:`sphere_env.evaluation.evaluate.SweepSpec`;
:class:`EvaluateOptions` is the rest of the evaluate command's options
(:mod:`sphere_env.evaluation.command_options`: those of ``enjoy``, ``export`` and ``demo``). An unknown key, a value of the wrong type and a value out of
range are refused as ``field '<name>' = <value>: <problem>; allowed: <what>``. What needs a loaded
model or a built env (a policy's training env id, its observation size, a controller's first
action) is checked after loading, by the tools themselves.

A schema deriving from :class:`~sphere_env.schemas.Built` gives the same one-line error when built
directly (``SweepSpec(controllers=[...])``) as through :func:`~sphere_env.schemas.validate`.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Mapping

from pydantic import AfterValidator, BeforeValidator, Field, field_validator, model_validator

from sphere_env.files import InputFile, OutputFolder, file_stem
from sphere_env.params import SHELL_MODELS, SHIPPED_CALIBRATIONS
from sphere_env.schemas import Built, Finite, Schema, allowed, count, shown

#: Env kwargs the sweep sets per cell (refused in ``env_kwargs``) and the option that sets each.
GRID_KWARGS = {
    "shell_model": "--shell-models",
    "friction_model": "--friction",
    "randomization": "off",
    "record_replay": "--replay",
}
#: Env kwargs the enjoy command sets itself (refused in ``--env-kwargs``) and the option for each.
ENJOY_KWARGS = {
    "shell_model": "--shell-model",
    "friction_model": "the run's config",
    "randomization": "off",
    "render_mode": "--meshcat / --video",
    "meshcat": "--meshcat",
    "record_replay": "not used by enjoy",
}
#: Episodes of one sweep at the most: every episode's trace (12 channels per control step, ~60 kB) is
#: held in memory until traces.npz is written.
MAX_SWEEP_EPISODES = 100_000
#: Episodes one enjoy command rolls out at the most (one after the other, in one process).
MAX_ENJOY_EPISODES = 10_000
#: Worker processes at the most: more than this on one machine is a typo (each holds its own Drake
#: diagrams, ~150 MB).
MAX_WORKERS = 1024
#: Seeds are 32-bit, as NumPy's legacy seeding and most RL tooling take them.
MAX_SEED = 2**32 - 1
Seed = count(0, MAX_SEED)
#: Export formats and the file each writes.
EXPORT_FORMATS = {"onnx": "policy.onnx", "torchscript": "policy.pt"}


def _registered(env_id: str) -> str:
    import gymnasium as gym

    import sphere_env  # noqa: F401 - registers the ids

    if env_id not in gym.registry:
        raise ValueError("unknown env id")
    return env_id


EnvId = Annotated[
    str,
    AfterValidator(_registered),
    Field(json_schema_extra=allowed("a registered env id, such as sphere_env/RampDescent-v3")),
]
ShellModel = Annotated[
    Literal[SHELL_MODELS],
    Field(
        json_schema_extra=allowed(  # type: ignore[valid-type]
            f"one of {list(SHELL_MODELS)}"
        )
    ),
]


def _friction(name: str) -> str:
    from sphere_env.models.friction import resolve_friction

    resolve_friction(name, "drive")
    resolve_friction(name, "steer")
    return name


Friction = Annotated[str, AfterValidator(_friction)]


def _fault_names() -> list[str]:
    from sphere_env.evaluation.faults import GRADED_FAULTS

    return list(GRADED_FAULTS)


def _fault(name: str) -> str:
    """A fault's name, or ``all`` (expanded by :class:`SweepFields`)."""
    if name != "all" and name not in _fault_names():
        raise ValueError("not a fault of --faults")
    return name


FaultName = Annotated[
    str,
    AfterValidator(_fault),
    Field(
        json_schema_extra=allowed(
            "all (the graded grid, alone) or fault names of sphere_env.evaluation.faults.GRADED_FAULTS: "
            + ", ".join(_fault_names())
        )
    ),
]


def _shipped_calibration(name: str) -> str:
    if name not in SHIPPED_CALIBRATIONS:
        raise ValueError("not a shipped calibration of --calibrations")
    return name


CalibrationName = Annotated[
    str,
    AfterValidator(_shipped_calibration),
    Field(json_schema_extra=allowed(f"names of shipped calibrations {list(SHIPPED_CALIBRATIONS)}")),
]


def _env_kwargs_without(own: Mapping[str, str], command: str):
    """An after-validator refusing env kwargs that ``command`` sets itself (``own``: kwarg -> the
    option that sets it)."""

    def check(value: dict[str, Any]) -> dict[str, Any]:
        for k in value:
            if k in own:
                raise ValueError(f"field {k!r} is set by {command} itself ({own[k]}); not allowed in --env-kwargs")
        return value

    return check


def _controller_form(spec: str) -> str:
    """A baseline, a run folder (``<run>``, ``<run>@best``, ``<run>@<checkpoint steps>``) or
    ``module:function``; whether the model loads or the function imports is checked later."""
    from sphere_env.evaluation.controller_specs import BASELINES, run_folder

    if spec in BASELINES or run_folder(spec) is not None:  # run_folder refuses another @suffix
        return spec
    module, sep, attr = spec.partition(":")
    if sep and all(p.isidentifier() for p in module.split(".")) and attr.isidentifier():
        return spec
    raise ValueError(f"not a baseline {list(BASELINES)}, a run folder with config.yaml, or module:function")


class ControllerSpec(Schema):
    """A controller of a sweep: ``label=spec`` text (a bare spec names itself,
    :func:`sphere_env.evaluation.controller_specs.split_label`) or a mapping ``{label, spec}``."""

    label: Annotated[str, Field(pattern=r"^[^,]+$", json_schema_extra=allowed("a non-empty name without ','"))]
    spec: Annotated[
        str,
        AfterValidator(_controller_form),
        Field(
            json_schema_extra=allowed(
                "zero | pd | pretrained | <run folder>[@best|@<checkpoint steps>] | module:function"
            )
        ),
    ]

    @model_validator(mode="before")
    @classmethod
    def _from_text(cls, data: Any) -> Any:
        if isinstance(data, str):
            from sphere_env.evaluation.controller_specs import split_label

            label, spec = split_label(data)
            return {"label": label, "spec": spec}
        return data

    def __str__(self) -> str:
        return f"{self.label}={self.spec}"


class SweepFields(Built):
    """A grid to evaluate (see ``SweepSpec``): every controller × shell model × friction preset ×
    pressure [kPa] × seed, and the conditions added to it (``faults``, ``calibrations``: each once
    more over the grid, for ``condition_controllers``; the faults at ``fault_seeds``)."""

    controllers: list[ControllerSpec] = Field(
        min_length=1, json_schema_extra=allowed("at least one controller, each label once")
    )
    env_id: EnvId = "sphere_env/RampDescent-v3"
    pressures_kpa: list[Finite] = Field(
        [3.0, 8.5, 14.0],
        min_length=1,
        json_schema_extra=allowed("at least one pressure [kPa] inside the calibrated range"),
    )
    shell_models: list[ShellModel] = Field(
        list(SHELL_MODELS), min_length=1, json_schema_extra=allowed(f"a non-empty list of {list(SHELL_MODELS)}")
    )
    frictions: list[Friction] = Field(
        ["majd"],
        min_length=1,
        json_schema_extra=allowed("at least one friction preset or law (majd, viscous, coulomb, none, ...)"),
    )
    seeds: list[Seed] = Field(
        [0, 1, 2], min_length=1, json_schema_extra=allowed(f"at least one integer within [0, {MAX_SEED}]")
    )
    env_kwargs: Annotated[dict[str, Any], AfterValidator(_env_kwargs_without(GRID_KWARGS, "the sweep"))] = Field(
        default_factory=dict, json_schema_extra=allowed("a mapping of env kwargs")
    )
    allow_env_mismatch: bool = False  # evaluate a policy on an env id it was not trained on
    #: Conditions added to the grid, each evaluated over it: faults (``all``: the graded grid) and
    #: shipped calibrations (:mod:`sphere_env.evaluation.conditions`).
    faults: list[FaultName] = Field(default_factory=list)
    calibrations: list[CalibrationName] = Field(default_factory=list)
    fault_seeds: list[Seed] | None = Field(
        None,
        min_length=1,
        json_schema_extra=allowed(
            f"at least one integer within [0, {MAX_SEED}] (the seeds of the fault conditions), or none for the grid's"
        ),
    )
    condition_controllers: list[str] | None = Field(
        None,
        min_length=1,
        json_schema_extra=allowed("labels of the sweep's controllers, or none for every controller"),
    )

    @field_validator("faults")
    @classmethod
    def _all_alone(cls, value: list[str]) -> list[str]:
        if "all" in value:
            if len(value) > 1:
                raise ValueError("'all' (the graded grid) stands alone")
            return _fault_names()
        if len(set(value)) != len(value):
            raise ValueError("each fault once")
        return value

    @field_validator("calibrations")
    @classmethod
    def _each_calibration_once(cls, value: list[str]) -> list[str]:
        if len(set(value)) != len(value):
            raise ValueError("each calibration once")
        return value

    @field_validator("controllers")
    @classmethod
    def _unique_labels(cls, value: list[ControllerSpec]) -> list[ControllerSpec]:
        labels = [c.label for c in value]
        if len(set(labels)) != len(labels):
            raise ValueError(f"labels must be unique, got {shown(labels)}")
        stems: dict[str, str] = {}
        for label in labels:  # each label names its replay and video files
            other = stems.setdefault(file_stem(label), label)
            if other != label:
                raise ValueError(
                    f"labels {shown(other)} and {shown(label)} make the same file name part "
                    f"{file_stem(label)!r} (replays, videos); allowed: labels whose file names differ "
                    "(letters, digits, '.', '-', '@' and '_' are kept, any other character becomes '-')"
                )
        return value

    @model_validator(mode="after")
    def _grid(self) -> "SweepFields":
        from sphere_env.models.shell import ShellCalibration

        for i, label in enumerate(self.condition_controllers or ()):
            if label not in self.labels:
                raise ValueError(
                    f"field 'condition_controllers[{i}]' = {label!r}: not a controller of the sweep; "
                    f"allowed: labels of the sweep's controllers {self.labels}"
                )
        axes = ("controllers", "shell_models", "frictions", "pressures_kpa", "seeds")
        sizes = [len(getattr(self, a)) for a in axes]
        if math.prod(sizes) > MAX_SWEEP_EPISODES:
            raise ValueError(
                f"field '{' × '.join(axes)}' = {' × '.join(map(str, sizes))} = {math.prod(sizes)} "
                f"episodes; allowed: at most {MAX_SWEEP_EPISODES} per sweep"
            )
        n = self.episodes()
        if n > MAX_SWEEP_EPISODES:
            raise ValueError(
                f"field 'faults' = {self.faults}: with the grid and the calibrations {self.calibrations}, {n} "
                f"episodes; allowed: at most {MAX_SWEEP_EPISODES} per sweep"
            )
        for cal_name in [self.env_kwargs.get("calibration"), *self.calibrations]:
            cal = ShellCalibration.load(cal_name)
            for i, p in enumerate(self.pressures_kpa):
                cal.check_pressure(p, f"field 'pressures_kpa[{i}]'")
        from sphere_env.envs.kwargs import check_episode_length

        check_episode_length(self.env_id, self.env_kwargs)
        return self

    def episodes(self) -> int:
        """The sweep's episodes: the grid per controller, and per controller with conditions the
        grid under each calibration and each fault (at the fault's pressures and ``fault_seeds``)."""
        from sphere_env.evaluation.faults import GRADED_FAULTS

        cells = len(self.shell_models) * len(self.frictions)
        grid = cells * len(self.pressures_kpa) * len(self.seeds)
        seeds = len(self.fault_seeds or self.seeds)
        per_fault = sum(cells * len(GRADED_FAULTS[f].pressures_kpa or self.pressures_kpa) * seeds for f in self.faults)
        with_conditions = len(self.condition_controllers or self.controllers)
        return len(self.controllers) * grid + with_conditions * (len(self.calibrations) * grid + per_fault)

    @property
    def labels(self) -> list[str]:
        return [c.label for c in self.controllers]


def _replay_parts(data: Any) -> Any:
    """``controller,shell_model,pressure_kpa,seed`` text as a mapping (blank or missing parts:
    None, the grid's defaults); the numbers read as numbers where they are ones."""
    if not isinstance(data, str):
        return data
    parts = [p.strip() for p in data.split(",")] if data.strip() else []
    if len(parts) > 4:
        raise ValueError(f"{data!r} has {len(parts)} parts; allowed: controller,shell_model,pressure_kpa,seed")
    out: dict[str, Any] = {}
    for key, text, kind in zip(("controller", "shell_model", "pressure_kpa", "seed"), parts, (str, str, float, int)):
        if text:
            try:
                out[key] = kind(text)
            except ValueError:
                out[key] = text  # the typed field refuses it by name
    return out


class ReplayCell(Schema):
    """An episode to save as a Meshcat replay; None fields take the grid's first controller, shell
    model and seed and its middle pressure."""

    controller: str | None = Field(None, json_schema_extra=allowed("a label of the sweep's controllers"))
    shell_model: ShellModel | None = Field(None, json_schema_extra=allowed(f"one of {list(SHELL_MODELS)}"))
    pressure_kpa: Finite | None = Field(None, json_schema_extra=allowed("a pressure [kPa] inside the calibrated range"))
    seed: Seed | None = Field(None, json_schema_extra=allowed(f"an integer within [0, {MAX_SEED}]"))


Replay = Annotated[
    ReplayCell,
    BeforeValidator(_replay_parts),
    Field(json_schema_extra=allowed("controller,shell_model,pressure_kpa,seed (blank parts: the grid's)")),
]


class EvaluateOptions(Schema):
    """The sweep's options besides the grid (:func:`sphere_env.evaluation.evaluate.evaluate`)."""

    out: OutputFolder
    workers: count(1, MAX_WORKERS) | None = Field(
        None, json_schema_extra=allowed(f"an integer within [1, {MAX_WORKERS}], or none for every usable core")
    )
    ray_address: Annotated[str, Field(min_length=1)] | None = Field(
        None, json_schema_extra=allowed("local, auto or ray://host:port")
    )
    replays: list[Replay] = Field(default_factory=lambda: [ReplayCell()])
    pme_log: InputFile | None = None
    pme_log_pressure_kpa: Finite | None = Field(None, json_schema_extra=allowed("a finite pressure [kPa]"))
    pme_reference: Literal[(*SHELL_MODELS, "log")] = Field(  # type: ignore[valid-type]
        "hydroelastic", json_schema_extra=allowed(f"one of {[*SHELL_MODELS, 'log']}")
    )
    plots: bool = True
    progress: bool = False
    extra_report: str = ""
    video: OutputFolder | None = None

    @model_validator(mode="after")
    def _video_local(self) -> "EvaluateOptions":
        if self.video is not None and self.ray_address is not None:
            raise ValueError(
                f"field 'video' = {str(self.video)!r}: not available with --ray-address (Ray workers "
                "may not share this file system); record videos with the local process pool"
            )
        return self
