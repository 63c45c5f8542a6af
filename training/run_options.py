"""Typed schemas of the trainer's own options: env id, torch device, seeds, evaluation and
checkpoint periods (:class:`RunOptions`), where a training writes (:class:`RunFolders`), a run
folder's ``config.yaml`` as far as loading needs (:class:`RunConfigFile`) and a sweep's command
line (:class:`SweepOptions`); each refused by name before anything runs."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BeforeValidator, ConfigDict, Field

from sphere_env.files import OutputFolder
from sphere_env.schemas import Finite, Schema, _integral, allowed, count, validate
from sphere_env.training.schemas import MAX_N_TIMESTEPS, SECTIONS

#: Evaluation episodes per evaluation at the most.
MAX_EVAL_EPISODES = 10_000


def _period_value(value: Any) -> Any:
    """rl-zoo3's "off" (0 or a negative number) as 0; an integer-valued float as an int."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) and value <= 0:
        return 0
    return _integral(value)


#: Steps between evaluations or checkpoints (<= 0: none).
Period = Annotated[
    int,
    BeforeValidator(_period_value),
    Field(ge=0, le=MAX_N_TIMESTEPS, json_schema_extra=allowed("an integer number of env steps (<= 0: none)")),
]


def _registered_env(env_id: str) -> str:
    """An env id gymnasium knows (sphere_env's register on import)."""
    import gymnasium as gym

    import sphere_env  # noqa: F401 - registers the ids

    if env_id not in gym.registry:
        ours = sorted(k for k in gym.registry if k.startswith("sphere_env/"))
        raise ValueError(f"unknown env id; registered sphere_env ids: {ours}")
    return env_id


def _cuda_here(value: str) -> str:
    """A CUDA device only on a machine that has one."""
    if value.startswith("cuda"):
        import torch

        if not torch.cuda.is_available():
            raise ValueError("names a CUDA device and this machine has none")
    return value


#: The algorithms a configuration may name (the keys of :data:`SECTIONS`).
Algo = Annotated[Literal["ppo", "sac"], Field(json_schema_extra=allowed(str(list(SECTIONS))))]


class AlgoChoice(Schema):
    """The algorithm of a configuration, given or read from a run folder."""

    algo: Algo


def check_algo(algo: Any) -> str:
    """``algo`` if it names an algorithm of :data:`SECTIONS`; ``ValueError`` naming ``algo`` otherwise."""
    return validate(AlgoChoice, {"algo": algo}).algo


class RunOptions(Schema):
    """The trainer's own options (command line or :func:`~sphere_env.training.config.resolve_config`)."""

    env_id: Annotated[str, AfterValidator(_registered_env)] = Field(
        json_schema_extra=allowed("a registered env id such as 'sphere_env/RampDescent-v3'")
    )
    device: Annotated[str, Field(pattern=r"^(?:auto|cpu|cuda(?::[0-9]+)?)$"), AfterValidator(_cuda_here)] = Field(
        "cpu", json_schema_extra=allowed("'cpu', 'cuda', 'cuda:<n>' (on a machine with CUDA) or 'auto'")
    )
    seed: count(0)
    eval_freq: Period | None = None
    eval_episodes: count(1, MAX_EVAL_EPISODES) = 6
    checkpoint_freq: Period | None = None
    torch_threads: count(1, 1024) = 1
    env_kwargs: dict[str, Any] = Field(default_factory=dict, json_schema_extra=allowed("a mapping of env kwargs"))
    eval_env_kwargs: dict[str, Any] = Field(default_factory=dict, json_schema_extra=allowed("a mapping of env kwargs"))
    eval_pressures_kpa: list[Finite] | None = Field(None, json_schema_extra=allowed("a list of pressures [kPa]"))
    tensorboard_log: OutputFolder | None = None


class RunFolders(Schema):
    """Where a training writes (``-f/--log-folder``, ``--run-dir``): checked before anything runs."""

    log_folder: OutputFolder
    run_dir: OutputFolder | None = None


class RunConfigFile(Schema):
    """A run folder's ``config.yaml`` as far as loading it needs: the env id and the algorithm, the
    fields of a ``TrainConfig`` without a default (the others are checked when the configuration
    is resolved again; the file's other keys are records: versions, command, seeds, ...)."""

    model_config = ConfigDict(extra="ignore", strict=True, frozen=True)

    env_id: str
    algo: str


def check_run_options(**options: Any) -> RunOptions:
    """The trainer's options as :class:`RunOptions`; ``ValueError`` naming the option otherwise."""
    return validate(RunOptions, options)


def _distinct(seeds: list[int]) -> list[int]:
    if len(set(seeds)) != len(seeds):
        raise ValueError("repeats a seed")
    return seeds


def _not_in_sweep(flag: str) -> Any:
    return Field(
        None, json_schema_extra=allowed(f"none: a sweep does not take {flag} (each trial writes its own run folder)")
    )


class SweepOptions(Schema):
    """The command line of a sweep (``--seeds``, ``--trial``): one run folder per trial and seed."""

    seeds: Annotated[list[int], AfterValidator(_distinct)] = Field(
        json_schema_extra=allowed("distinct integer seeds (-1: draw one)")
    )
    trained_agent: None = _not_in_sweep("-i/--trained-agent")
    tensorboard_log: None = _not_in_sweep("--tensorboard-log")


def check_sweep_options(**options: Any) -> SweepOptions:
    """A sweep's options as :class:`SweepOptions`; ``ValueError`` naming the option otherwise."""
    return validate(SweepOptions, options)
