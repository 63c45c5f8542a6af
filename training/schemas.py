"""Typed schemas of a training configuration: one hyperparameter-file section per algorithm.

A section of an rl-zoo3 hyperparameter file (``training/hyperparams/ppo.yml``) holds the
algorithm's constructor arguments and the keys of :data:`SPECIAL_KEYS`. :func:`check_section`
validates a section (with ``--hyperparams`` overrides already merged in) against
:class:`PPOSection` or :class:`SACSection`: an unknown key, a value of the wrong type, a count
that is not an integer and a number out of its range are refused, before anything is built, as
``field 'hyperparams.<key>' = <value>: <problem>; allowed: <what>``.

A top-level ``randomization`` (the former layout, now ``env_kwargs.randomization``) and the rl-zoo3
keys this trainer does not implement (:data:`ZOO_ONLY_KEYS`) are refused by name, saying where the
key moved or what to use instead. ``env_wrapper`` takes rl-zoo3's forms (a class path, ``{path:
{kwargs}}`` or a list of these) and is read as a list of ``{path: kwargs}``, each class imported and
checked; ``callback`` takes the same forms for stable-baselines3 callback classes (rl-zoo3's
``callback`` key). The trainer's own options are :mod:`sphere_env.training.run_options`'s.

rl-zoo3's string forms are read as data, never evaluated (:mod:`sphere_env.training.zoo_forms`).
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Mapping

from pydantic import AfterValidator, BeforeValidator, Field, model_validator

from sphere_env.schemas import Finite, Schema, allowed, count, number, validate
from sphere_env.training.zoo_forms import (
    ACTIVATION_NAMES,
    ACTIVATION_PATTERN,
    ACTIVATIONS,
    LIN_PATTERN,
    POSITIVE_TEXT,
    dict_text,
)

#: Keys of a hyperparameter section that are not algorithm constructor arguments.
SPECIAL_KEYS = (
    "n_envs",
    "n_threads",
    "n_workers",
    "n_timesteps",
    "policy",
    "normalize",
    "env_kwargs",
    "env_wrapper",
    "callback",
)
#: rl-zoo3 section keys (popped by its ExpManager) that this trainer does not implement.
ZOO_ONLY_KEYS = ("vec_env_wrapper", "frame_stack", "monitor_kwargs", "noise_type", "noise_std")
#: Former top-level keys of a section and where they live now.
MOVED_KEYS = {"randomization": "env_kwargs.randomization"}
#: Upper bounds: more envs than this is a typo, not a study (each env holds a Drake diagram, ~20 MB;
#: a process per env, ~150 MB more), and budgets beyond these would run for years on this kind of
#: machine.
MAX_N_ENVS = 256
MAX_ENV_PROCESSES = 64  # one process per env (n_workers: null with SubprocVecEnv)
MAX_N_TIMESTEPS = 10**10


#: A positive number or rl-zoo3's linear schedule ``lin_<x>`` (x → 0 over training).
Schedule = number(gt=0.0) | Annotated[str, Field(pattern=LIN_PATTERN)]
PositiveSchedule = Annotated[Schedule, Field(json_schema_extra=allowed("a number > 0 or 'lin_<number > 0>'"))]
Layers = list[count(1, 65536)]


class NetArch(Schema):
    """Separate layer sizes for the actor (``pi``) and the critic (``vf``; SAC: ``qf``)."""

    pi: Layers | None = None
    vf: Layers | None = None
    qf: Layers | None = None


class PolicyKwargs(Schema):
    """SB3 policy keyword arguments a configuration may set."""

    net_arch: Layers | NetArch | None = Field(
        None, json_schema_extra=allowed("a list of layer sizes >= 1, or {pi: [...], vf: [...]}")
    )
    activation_fn: Annotated[str, Field(pattern=ACTIVATION_PATTERN)] | None = Field(
        None, json_schema_extra=allowed(f"one of {sorted(ACTIVATIONS.values())} (as nn.<Name> or a lower-case name)")
    )
    log_std_init: Finite | list[Finite] | None = Field(
        None, json_schema_extra=allowed("a number, or one per action component")
    )
    ortho_init: bool | None = None
    squash_output: bool | None = None
    full_std: bool | None = None
    use_expln: bool | None = None
    share_features_extractor: bool | None = None
    normalize_images: bool | None = None
    n_critics: count(1, 16) | None = None
    privileged_dims: count(0, 1024) | None = None
    optimizer_kwargs: dict[str, Any] | None = None


PolicyKwargsField = Annotated[PolicyKwargs, BeforeValidator(dict_text(ACTIVATION_NAMES))]


class NormalizeArgs(Schema):
    """``VecNormalize`` arguments."""

    norm_obs: bool | None = None
    norm_reward: bool | None = None
    clip_obs: number(gt=0.0) | None = None
    clip_reward: number(gt=0.0) | None = None
    gamma: number(gt=0.0, le=1.0) | None = None
    epsilon: number(gt=0.0) | None = None


VECNORMALIZE_KEYS = tuple(NormalizeArgs.model_fields)


def _class_at(path: str, base: type, what: str) -> type:
    """The subclass of ``base`` at ``path`` (``module.Class``), else ValueError saying why."""
    import importlib

    module, _, name = path.rpartition(".")
    try:
        cls = getattr(importlib.import_module(module), name) if module else None
    except ImportError as err:
        raise ValueError(f"{path!r} cannot be imported: {err}") from None
    except AttributeError:
        cls = None
    if not (isinstance(cls, type) and issubclass(cls, base)):
        raise ValueError(f"{path!r} is not a {what} class")
    return cls


def wrapper_class(path: str) -> type:
    """The gymnasium wrapper class at ``path`` (``module.Class``), else ValueError saying why."""
    import gymnasium as gym

    return _class_at(path, gym.Wrapper, "gymnasium.Wrapper")


def callback_class(path: str) -> type:
    """The stable-baselines3 callback class at ``path`` (``module.Class``), else ValueError saying why."""
    from stable_baselines3.common.callbacks import BaseCallback

    return _class_at(path, BaseCallback, "stable_baselines3 BaseCallback")


def _callback_path(path: str) -> str:
    callback_class(path)
    return path


def _wrapper_path(path: str) -> str:
    wrapper_class(path)
    return path


def _wrapper_list(value: Any) -> Any:
    """rl-zoo3's ``env_wrapper`` forms as a list of entries (null: none; one entry: a list of it)."""
    if value is None:
        return []
    return [value] if isinstance(value, (str, Mapping)) else value


def _wrapper_entry(value: Any) -> Any:
    """A bare class path as ``{path: {}}``."""
    return {value: {}} if isinstance(value, str) else value


#: One wrapper: ``{module.Class: kwargs}`` (kwargs null: none), read as ``{path: {kwargs}}``.
WrapperEntry = Annotated[
    dict[Annotated[str, AfterValidator(_wrapper_path)], dict[str, Any] | None],
    BeforeValidator(_wrapper_entry),
    Field(min_length=1, max_length=1),
    AfterValidator(lambda entry: {path: dict(kwargs or {}) for path, kwargs in entry.items()}),
]
#: One callback: ``{module.Class: kwargs}`` (kwargs null: none), read as ``{path: {kwargs}}``.
CallbackEntry = Annotated[
    dict[Annotated[str, AfterValidator(_callback_path)], dict[str, Any] | None],
    BeforeValidator(_wrapper_entry),
    Field(min_length=1, max_length=1),
    AfterValidator(lambda entry: {path: dict(kwargs or {}) for path, kwargs in entry.items()}),
]
Layout = count(1, MAX_N_ENVS) | Literal["auto"] | None


class Section(Schema):
    """The keys every section may hold besides the algorithm's arguments."""

    n_envs: count(1, MAX_N_ENVS) = 1
    n_timesteps: count(1, MAX_N_TIMESTEPS) = 100_000
    n_workers: Layout = Field("auto", json_schema_extra=allowed("an integer within [1, n_envs], 'auto' or null"))
    n_threads: Layout = Field(None, json_schema_extra=allowed("an integer within [1, n_envs], 'auto' or null"))
    policy: str = "MlpPolicy"
    normalize: bool | Annotated[NormalizeArgs, BeforeValidator(dict_text())] | None = False
    env_kwargs: dict[str, Any] = Field(default_factory=dict, json_schema_extra=allowed("a mapping of env kwargs"))
    env_wrapper: Annotated[list[WrapperEntry], BeforeValidator(_wrapper_list)] = Field(
        default_factory=list,
        json_schema_extra=allowed(
            "a gymnasium.Wrapper class path 'module.Class' (such as 'sphere_env.wrappers.PDResidualAction'), "
            "{path: {kwargs}} with a mapping of kwargs, or a list of these (the first innermost)"
        ),
    )
    callback: Annotated[list[CallbackEntry], BeforeValidator(_wrapper_list)] = Field(
        default_factory=list,
        json_schema_extra=allowed(
            "a stable_baselines3 BaseCallback class path 'module.Class' (such as "
            "'sphere_env.training.curriculum.SuccessCurriculum'), {path: {kwargs}} with a mapping of kwargs, "
            "or a list of these"
        ),
    )
    # arguments PPO and SAC share
    learning_rate: PositiveSchedule = 3e-4
    gamma: number(gt=0.0, le=1.0) = 0.99
    batch_size: count(1) = 64
    use_sde: bool = False
    sde_sample_freq: count(-1) = -1
    stats_window_size: count(1) = 100
    policy_kwargs: PolicyKwargsField | None = None

    @model_validator(mode="before")
    @classmethod
    def _refuse_foreign_keys(cls, data: Any) -> Any:
        """A key that moved (:data:`MOVED_KEYS`) or that only rl-zoo3 implements, named with what to do."""
        for key in data if isinstance(data, Mapping) else ():
            if key in MOVED_KEYS:
                now = MOVED_KEYS[key]
                raise ValueError(
                    f"field {key!r}: a top-level key (in the file's section or --hyperparams); it moved to {now} "
                    f"(rl-zoo3's layout, which passes env_kwargs to gymnasium.make): in a YAML section write "
                    f"'env_kwargs: {{{key}: ...}}', on the command line '--env-kwargs {key}:...'"
                )
            if key in ZOO_ONLY_KEYS:
                raise ValueError(
                    f"field {key!r}: an rl-zoo3 key this trainer does not implement; train with "
                    "python -m rl_zoo3.train for it, or remove it"
                )
        return data

    @model_validator(mode="before")
    @classmethod
    def _default_layout(cls, data: Any) -> Any:
        """Without either layout key, one block of envs per usable core (``n_workers: auto``, the
        fastest measured); with ``n_threads`` alone, no worker processes."""
        if isinstance(data, Mapping) and data.get("n_threads") is not None and "n_workers" not in data:
            data = {**data, "n_workers": None}
        return data

    @model_validator(mode="after")
    def _layout(self) -> "Section":
        for key in ("n_workers", "n_threads"):
            v = getattr(self, key)
            if isinstance(v, int) and v > self.n_envs:
                raise ValueError(f"field {key!r} = {v} must be <= n_envs={self.n_envs} (or 'auto')")
        if self.n_threads is not None and self.n_workers is not None:
            raise ValueError(
                f"field 'n_threads' = {self.n_threads!r} cannot be combined with n_workers="
                f"{self.n_workers!r}; set one of them to null (threads in this process, or worker processes)"
            )
        if self.n_threads is None and self.n_workers is None and self.n_envs > MAX_ENV_PROCESSES:
            raise ValueError(
                f"field 'n_envs' = {self.n_envs} with n_workers: null starts one process per env; allowed: "
                f"at most {MAX_ENV_PROCESSES} (or set n_workers to step blocks of envs per process)"
            )
        return self


class PPOSection(Section):
    """A PPO section."""

    n_steps: count(1) = 2048
    n_epochs: count(1) = 10
    gae_lambda: number(ge=0.0, le=1.0) = 0.95
    clip_range: PositiveSchedule = 0.2
    clip_range_vf: PositiveSchedule | None = None
    normalize_advantage: bool = True
    ent_coef: number(ge=0.0) = 0.0
    vf_coef: number(ge=0.0) = 0.5
    max_grad_norm: number(gt=0.0) = 0.5
    target_kl: number(gt=0.0) | None = None
    rollout_buffer_kwargs: dict[str, Any] | None = None


class SACSection(Section):
    """A SAC section."""

    buffer_size: count(1) = 1_000_000
    learning_starts: count(0) = 100
    tau: number(gt=0.0, le=1.0) = 0.005
    train_freq: count(1) | tuple[count(1), Literal["step", "episode"]] = Field(
        1, json_schema_extra=allowed("an integer >= 1 or [n, 'step'|'episode']")
    )
    gradient_steps: count(1) | Literal[-1] = Field(
        1, json_schema_extra=allowed("an integer >= 1 or -1 (as many as env steps)")
    )
    n_steps: count(1) = 1
    ent_coef: number(ge=0.0) | Literal["auto"] | Annotated[str, Field(pattern=rf"^auto_{POSITIVE_TEXT}$")] = Field(
        "auto", json_schema_extra=allowed("a number >= 0, 'auto' or 'auto_<number > 0>'")
    )
    target_update_interval: count(1) = 1
    target_entropy: Finite | Literal["auto"] = "auto"
    use_sde_at_warmup: bool = False
    optimize_memory_usage: bool = False
    replay_buffer_kwargs: dict[str, Any] | None = None

    @model_validator(mode="before")
    @classmethod
    def _train_freq_list(cls, data: Any) -> Any:
        """YAML has no tuples: ``train_freq: [1, episode]`` is read as the (n, unit) pair."""
        if isinstance(data, Mapping) and isinstance(data.get("train_freq"), list):
            data = {**data, "train_freq": tuple(data["train_freq"])}
        return data


SECTIONS: dict[str, type[Section]] = {"ppo": PPOSection, "sac": SACSection}


def numbers_from_yaml_strings(section: Mapping[str, Any]) -> dict[str, Any]:
    """YAML 1.1 reads ``1e-3`` (no dot) as a string: such top-level values that read as finite
    numbers become floats (rl-zoo3 files write ``!!float 1e-3`` for the same reason)."""
    out = dict(section)
    for key, val in section.items():
        if isinstance(val, str):
            try:
                x = float(val)
            except ValueError:
                continue
            if math.isfinite(x) and "e" in val.lower():
                out[key] = x
    return out


def check_section(algo: str, section: Any, where: str = "") -> Section:
    """The section (overrides merged) as ``algo``'s schema; ``ValueError`` naming
    ``hyperparams.<key>`` otherwise (a section that is no mapping: ``<where>: field 'hyperparams'``)."""
    if isinstance(section, Mapping):
        return validate(SECTIONS[algo], numbers_from_yaml_strings(section), root="hyperparams")
    return validate(SECTIONS[algo], section, where, root="hyperparams")
