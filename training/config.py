"""Training configuration: rl-zoo3-style hyperparameter YAML, resolved and validated up front.

Everything that can be wrong with a configuration (algorithm, env id, device, hyperparameter
names and values, env kwargs, randomization ranges) is refused here, in the main process, before
any worker starts, with a ``ValueError`` whose message begins with the offending field. The inputs
load through the typed schemas of :mod:`sphere_env.training.schemas` (a section, the trainer's own
options); env kwargs and randomization are checked by the env itself, built once in-process.

A hyperparameter file is an rl-zoo3 file: it maps env ids to mappings of SB3 constructor
arguments plus these keys, and the shipped files hold nothing else, so
``python -m rl_zoo3.train --gym-packages sphere_env --env <id> -conf <file>`` reads them as they are:

==================  ==========================================================================
``n_envs``          parallel envs
``n_timesteps``     total environment steps (``!!float 3e5`` is fine)
``policy``          SB3 policy name (``MlpPolicy``)
``normalize``       ``true``/``false`` or a mapping of ``VecNormalize`` arguments
``env_kwargs``      keyword arguments of ``gymnasium.make`` (see the env docstrings), including
                    ``randomization``: the env's spec (:mod:`sphere_env.tasks.randomization`)
``callback``        stable-baselines3 callbacks, as rl-zoo3 names them: a class path,
                    ``{path: {kwargs}}`` or a list of these (e.g.
                    ``sphere_env.training.curriculum.SuccessCurriculum``)
==================  ==========================================================================

Two more keys choose how this trainer steps the envs; rl-zoo3 does not know them (it would pass
them to the algorithm and fail), so they belong in ``--hyperparams`` overrides or in files meant
for this trainer only. Without either, the envs are split into one block per usable core, the
training process stepping the first and one worker process each of the others (``n_workers:
auto``, the fastest measured layout):

==================  ==========================================================================
``n_workers``       blocks of envs stepped in parallel, the training process included
                    (:class:`sphere_env.training.vec_env.BatchedSubprocVecEnv`); ``auto``: one per
                    usable core, at most ``n_envs``; ``null`` (with no ``n_threads``): one
                    process per env (``SubprocVecEnv``)
``n_threads``       step the ``n_envs`` envs in the training process with this many threads
                    (:class:`sphere_env.training.vec_env.ThreadedVecEnv`); ``auto``: one per usable
                    core; excludes ``n_workers``
==================  ==========================================================================

A top-level ``randomization`` key (the former layout) is refused with a message saying where it
moved; rl-zoo3 keys this trainer does not implement (``frame_stack``, ``callback``, ...) are
refused too. ``env_wrapper`` and ``callback`` are read as rl-zoo3 reads them: a class path, ``{path: {kwargs}}``, or a
list of these (applied in order, the first innermost), e.g. ``sphere_env.wrappers.PDResidualAction``.

``learning_rate`` and ``clip_range`` accept ``"lin_<value>"`` (linear decay to 0);
``policy_kwargs`` may be a mapping or rl-zoo3's ``"dict(...)"`` string.
"""

from __future__ import annotations

import copy
import re
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import yaml

from sphere_env import safe_yaml
from sphere_env.envs.kwargs import check_episode_length
from sphere_env.resources import hyperparams_path
from sphere_env.training.run_options import check_algo, check_run_options
from sphere_env.training.schemas import (
    SECTIONS,
    SPECIAL_KEYS,
    check_section,
    wrapper_class,
)
from sphere_env.training.zoo_forms import activation_class_name, lin_value

ALGOS = tuple(SECTIONS)
MONITOR_KEYWORDS = ("pressure_kpa", "shell_model", "is_success")


def algo_class(algo: str):
    """The SB3 class for ``algo`` (``"ppo"``/``"sac"``; anything else: ``ValueError`` naming ``algo``)."""
    algo = check_algo(algo)
    from stable_baselines3 import PPO, SAC

    from sphere_env.training.policies import register

    register()  # the policy name AsymmetricMlpPolicy
    return {"ppo": PPO, "sac": SAC}[algo]


def linear_schedule(initial: float) -> Callable[[float], float]:
    """rl-zoo3's ``lin_<x>``: value × progress_remaining (1 → 0 over training)."""

    def schedule(progress_remaining: float) -> float:
        return progress_remaining * initial

    return schedule


@dataclass
class TrainConfig:
    """A resolved, validated training configuration (what ``config.yaml`` of a run holds)."""

    env_id: str
    algo: str
    seed: int = 0
    n_timesteps: int = 100_000
    n_envs: int = 2
    n_workers: int | str | None = None  # env blocks stepped in parallel (BatchedSubprocVecEnv); "auto"
    n_threads: int | str | None = None  # threads stepping the envs in-process (ThreadedVecEnv); "auto"
    policy: str = "MlpPolicy"
    normalize: dict[str, Any] | None = field(default_factory=dict)  # None: no VecNormalize
    env_kwargs: dict[str, Any] = field(default_factory=dict)  # incl. "randomization"
    hyperparams: dict[str, Any] = field(default_factory=dict)  # algorithm constructor arguments
    eval_freq: int = 10_000  # env steps between evaluations (summed over workers); <= 0: none
    eval_episodes: int = 6  # per evaluation, cycling over eval_pressures_kpa
    eval_env_kwargs: dict[str, Any] = field(default_factory=lambda: {"randomization": "off"})  # over env_kwargs
    eval_pressures_kpa: list[float] | None = None  # resolved: a list; []: the eval env draws its own
    checkpoint_freq: int = 20_000  # env steps between checkpoints; <= 0: only the final one
    device: str = "cpu"
    torch_threads: int = 1
    hyperparams_file: str = ""
    tensorboard_log: str | None = None  # None: <run>/tb
    trained_agent: str | None = None  # model.zip the run continues from (-i)
    # SAC: checkpoints also hold the replay buffer (hundreds of MB) only when asked, as rl-zoo3's
    # --save-replay-buffer; without it a resumed SAC run refills an empty buffer
    save_replay_buffer: bool = False
    # gymnasium wrappers around each env, innermost first: [{"module.Class": {kwargs}}] (rl-zoo3's env_wrapper)
    env_wrapper: list[dict[str, dict[str, Any]]] = field(default_factory=list)
    # stable-baselines3 callbacks of the training run: [{"module.Class": {kwargs}}] (rl-zoo3's callback)
    callback: list[dict[str, dict[str, Any]]] = field(default_factory=list)

    @property
    def randomization(self) -> Any:
        """The training env's randomization spec (``env_kwargs["randomization"]``; the env's default
        when absent)."""
        return self.env_kwargs.get("randomization", "default")

    def as_dict(self) -> dict[str, Any]:
        return copy.deepcopy(asdict(self))

    @property
    def worker_seeds(self) -> list[int]:
        """Seed of each training worker (seed + rank); the eval env uses seed + 10_000."""
        return [self.seed + rank for rank in range(self.n_envs)]

    @property
    def eval_seed(self) -> int:
        return self.seed + 10_000

    def make_kwargs(self, evaluation: bool = False) -> dict[str, Any]:
        """kwargs for ``gymnasium.make``: the env kwargs, with the evaluation overrides on top for
        the evaluation env."""
        kwargs = copy.deepcopy(self.env_kwargs)
        if evaluation:
            kwargs.update(copy.deepcopy(self.eval_env_kwargs))
        return kwargs

    def algo_kwargs(self) -> dict[str, Any]:
        """Hyperparameters turned into constructor arguments: ``lin_<x>`` schedules into
        functions, activation names into torch classes, ``train_freq`` pairs into tuples."""
        out: dict[str, Any] = {}
        for key, val in self.hyperparams.items():
            if key in ("learning_rate", "clip_range", "clip_range_vf") and isinstance(val, str):
                out[key] = linear_schedule(lin_value(val))
            elif key == "policy_kwargs" and isinstance(val, Mapping) and isinstance(val.get("activation_fn"), str):
                import torch.nn as nn

                out[key] = {**val, "activation_fn": getattr(nn, activation_class_name(val["activation_fn"]))}
            elif key == "train_freq" and isinstance(val, list):
                out[key] = tuple(val)
            else:
                out[key] = val
        return out


def load_section(path: str | Path, env_id: str) -> Any:
    """The section for ``env_id`` in a hyperparameter YAML file, as written (a mapping, else refused
    by :func:`~sphere_env.training.schemas.check_section`)."""
    path = Path(path)
    try:
        data = safe_yaml.load_file(path)
    except (OSError, yaml.YAMLError) as err:
        raise ValueError(f"hyperparams: cannot read {str(path)!r}: {err}") from None
    if not isinstance(data, Mapping) or env_id not in data:
        have = sorted(data) if isinstance(data, Mapping) else []
        raise ValueError(f"env: no section for {env_id!r} in {str(path)!r}; sections: {have}")
    return copy.deepcopy(data[env_id])


def _normalize(value: Any) -> dict[str, Any] | None:
    """The validated ``normalize`` value as VecNormalize arguments (None: no VecNormalize)."""
    if value is None or value is False:
        return None
    if value is True:
        return {}
    return value.model_dump(exclude_unset=True)


def _plain_mapping(value: Any) -> Any:
    """A given mapping as a dict ({} for None); anything else unchanged, for the schema to refuse."""
    if value is None:
        return {}
    return dict(value) if isinstance(value, Mapping) else value


def plain_data(x: Any) -> Any:
    """Dataclasses, tuples, numpy scalars and paths as plain YAML-ready data."""
    from dataclasses import is_dataclass

    import numpy as np

    if is_dataclass(x) and not isinstance(x, type):
        return plain_data(asdict(x))
    if isinstance(x, Mapping):
        return {str(k): plain_data(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [plain_data(v) for v in x]
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, Path):
        return str(x)
    return x


def resolve_config(
    env_id: str,
    algo: str,
    hyperparams_file: str | Path | None = None,
    overrides: Mapping[str, Any] | None = None,
    seed: int = 0,
    eval_freq: int | None = None,
    eval_episodes: int = 6,
    eval_env_kwargs: Mapping[str, Any] | None = None,
    eval_pressures_kpa: Sequence[float] | None = None,
    checkpoint_freq: int | None = None,
    device: str = "cpu",
    torch_threads: int = 1,
    env_kwargs: Mapping[str, Any] | None = None,
    tensorboard_log: str | Path | None = None,
    trained_agent: str | Path | None = None,
    build_env: bool = True,
    save_replay_buffer: bool = False,
) -> TrainConfig:
    """Read the YAML section for ``env_id``, apply ``overrides`` (same keys as the YAML, rl-zoo3's
    ``--hyperparams``) and ``env_kwargs`` (merged key by key over the section's), and validate
    everything. Builds one env in-process (``build_env``) so env kwargs and randomization are
    checked by the env itself, the model once on it so hyperparameter values are too, and the
    evaluation env at every evaluation pressure.

    The evaluation env takes ``env_kwargs`` with ``eval_env_kwargs`` on top (default
    ``{"randomization": "off"}``; given ones are merged over that default). Its episodes cycle over
    ``eval_pressures_kpa`` (default: the calibration's low, nominal and high pressures; ``[]``: the
    eval env's own randomization decides), episode k at pressure ``k mod len`` with seed
    ``eval_seed + k``, the same episodes at every evaluation. ``eval_freq``/``checkpoint_freq`` <= 0
    turn evaluations / periodic checkpoints off (rl-zoo3's negative values).

    :raises ValueError: naming the field (``algo``, ``env``, ``hyperparams.<key>``,
        ``env_kwargs.<kwarg>``, ``env_kwargs.randomization.<parameter>``, ``eval_env_kwargs...``,
        ``eval_pressures_kpa``, ``n_envs``, ...).
    """
    algo_class(algo)  # refuses an unknown algorithm; registers the project policies
    opts = check_run_options(
        env_id=env_id,
        device=device,
        seed=seed,
        eval_freq=eval_freq,
        eval_episodes=eval_episodes,
        checkpoint_freq=checkpoint_freq,
        torch_threads=torch_threads,
        env_kwargs=_plain_mapping(env_kwargs),
        eval_env_kwargs=_plain_mapping(eval_env_kwargs),
        eval_pressures_kpa=(list(eval_pressures_kpa) if isinstance(eval_pressures_kpa, tuple) else eval_pressures_kpa),
        tensorboard_log=tensorboard_log,
    )
    path = Path(hyperparams_file) if hyperparams_file else hyperparams_path(algo)
    section = _overridden(load_section(path, env_id), overrides)
    spec = check_section(algo, section, f"hyperparams file {str(path)!r}, section {env_id!r}")
    given = spec.model_dump(exclude_unset=True)
    hyper = {k: plain_data(v) for k, v in given.items() if k not in SPECIAL_KEYS}
    kwargs = dict(spec.env_kwargs)
    kwargs.update(copy.deepcopy(opts.env_kwargs))
    eval_kwargs = {"randomization": "off", **copy.deepcopy(opts.eval_env_kwargs)}
    check_episode_length(env_id, kwargs)
    check_episode_length(env_id, {**kwargs, **eval_kwargs}, "eval_env_kwargs")
    n_envs, n_timesteps = spec.n_envs, spec.n_timesteps
    # Steps the algorithm takes at the least (PPO collects whole rollouts of n_steps per env): the
    # default evaluation and checkpoint periods are never shorter, so a tiny budget (--n-timesteps 10)
    # gives a handful of checkpoints, not one per env step of the first rollout.
    chunk = n_envs * (hyper.get("n_steps", 2048) if algo == "ppo" else 1)
    cfg = TrainConfig(
        env_id=env_id,
        algo=algo,
        seed=opts.seed,
        n_timesteps=n_timesteps,
        n_envs=n_envs,
        n_workers=spec.n_workers,
        n_threads=spec.n_threads,
        policy=spec.policy,
        normalize=_normalize(spec.normalize),
        env_kwargs=kwargs,
        hyperparams=hyper,
        eval_freq=max(n_timesteps // 10, chunk) if opts.eval_freq is None else opts.eval_freq,
        eval_episodes=opts.eval_episodes,
        eval_env_kwargs=eval_kwargs,
        eval_pressures_kpa=_eval_pressures({**kwargs, **eval_kwargs}, opts.eval_pressures_kpa),
        checkpoint_freq=max(n_timesteps // 5, chunk) if opts.checkpoint_freq is None else opts.checkpoint_freq,
        device=opts.device,
        torch_threads=opts.torch_threads,
        hyperparams_file=str(path),
        tensorboard_log=None if tensorboard_log is None else str(tensorboard_log),
        trained_agent=None if trained_agent is None else str(trained_agent),
        save_replay_buffer=bool(save_replay_buffer),
        env_wrapper=copy.deepcopy(spec.env_wrapper),
        callback=copy.deepcopy(spec.callback),
    )
    cfg.algo_kwargs()  # schedules and policy_kwargs parse
    if build_env:
        validate_with_env(cfg)
    return cfg


def _overridden(section: Any, overrides: Mapping[str, Any] | None) -> Any:
    """The YAML ``section`` with ``overrides`` set key by key (copies); an override choosing one
    layout replaces the section's other one (``n_threads`` vs ``n_workers``). A section that is not
    a mapping comes back as it is, for :func:`check_section` to refuse naming the file's section."""
    if not isinstance(section, Mapping):
        return section
    section = dict(section)
    overrides = dict(overrides or {})
    for key, other in (("n_workers", "n_threads"), ("n_threads", "n_workers")):
        if overrides.get(key) is not None and other not in overrides:
            section.pop(other, None)
    for key, val in overrides.items():
        section[key] = copy.deepcopy(val)
    return section


def _eval_pressures(kwargs: Mapping[str, Any], pressures: Sequence[float] | None) -> list[float]:
    """The evaluation pressures [kPa]: given (each within the calibrated range) or the
    calibration's low, nominal and high pressures."""
    from sphere_env.models.shell import ShellCalibration

    try:
        cal = ShellCalibration.load(kwargs.get("calibration"))
    except ValueError as err:
        raise ValueError(f"env_kwargs.calibration: {err}") from None
    if pressures is None:
        lo, hi = cal.pressure_range_kpa
        return [float(lo), float(cal.nominal_pressure_kpa), float(hi)]
    return [cal.check_pressure(p, "field 'eval_pressures_kpa'") for p in pressures]


def _env_error(err: Exception, prefix: str) -> ValueError:
    """An env's ValueError as one naming the configuration field (``env_kwargs.<kwarg>``)."""
    msg = str(err)
    named = _named_field(msg, prefix)
    if named is not None:
        return ValueError(named)
    return ValueError(f"{prefix}.{msg}" if not msg.startswith(("options", prefix)) else msg)


def _named_field(msg: str, prefix: str) -> str | None:
    """A schema's one-line error with the configuration's own path in front of the field's:
    the env kwargs schema names fields from the kwargs' top (``RampDescent kwargs: field
    'shell_model'`` -> ``field 'env_kwargs.shell_model'``), the randomization schema from the
    spec's (``randomization: field 'pressure_kpa'`` -> ``field
    'env_kwargs.randomization.pressure_kpa'``); None for any other message."""
    m = re.match(r"^(?:\w+ kwargs|(randomization)): (unknown )?field '", msg)
    if m is None:
        return None
    root = f"{prefix}.randomization." if m.group(1) else f"{prefix}."
    return f"{m.group(2) or ''}field '{root}{msg[m.end() :]}"


def _try_episode_start(env, seed: int, where: str, options: Mapping[str, Any] | None = None) -> None:
    """Reset and step the env once, so values that only fail when sampled (a pressure schedule,
    a distribution) are refused here rather than inside a worker."""
    import numpy as np

    try:
        env.reset(seed=seed, options=dict(options) if options else None)
        env.step(np.zeros(env.action_space.shape, dtype=env.action_space.dtype))
    except Exception as err:  # noqa: BLE001 - whatever the env raises, the configuration is at fault
        env.close()
        msg = str(err)
        named = _named_field(msg, where)
        if named is not None or msg.startswith("randomization"):
            raise ValueError(named or f"{where}.{msg}") from None
        raise ValueError(
            f"{where}: the env failed its first reset/step with this configuration: {type(err).__name__}: {msg}"
        ) from None


def _make_checked(
    env_id: str, kwargs: Mapping[str, Any], where: str, env_wrapper: Sequence[Mapping[str, Mapping[str, Any]]] = ()
):
    import gymnasium as gym

    try:
        env = gym.make(env_id, **kwargs)
    except ValueError as err:
        raise _env_error(err, where) from None
    except TypeError as err:
        raise ValueError(f"{where}: {err}") from None
    try:
        return apply_env_wrappers(env, env_wrapper)
    except (ValueError, TypeError) as err:
        env.close()
        raise ValueError(f"env_wrapper: {err}") from None


def apply_env_wrappers(env: Any, env_wrapper: Sequence[Mapping[str, Mapping[str, Any]]]) -> Any:
    """``env`` inside the ``env_wrapper`` entries (the first innermost)."""
    for item in env_wrapper:
        ((path, kwargs),) = item.items()
        env = wrapper_class(path)(env, **dict(kwargs))
    return env


def make_callbacks(cfg: TrainConfig) -> list[Any]:
    """The run's ``callback`` entries as callback objects; ``ValueError`` naming the field when a
    class refuses its kwargs."""
    from sphere_env.training.schemas import callback_class

    out = []
    for item in cfg.callback:
        for path, kwargs in item.items():
            try:
                out.append(callback_class(path)(**kwargs))
            except (TypeError, ValueError) as err:
                raise ValueError(f"callback: {path}: {err}") from None
    return out


def validate_with_env(cfg: TrainConfig) -> None:
    """Build one training env and the model on it in-process, and check the evaluation env at each
    evaluation pressure (the same env with the evaluation spec set when only the randomization
    differs: one Drake build); errors become ValueErrors naming the field."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    env = _make_checked(cfg.env_id, cfg.make_kwargs(), "env_kwargs", cfg.env_wrapper)
    _try_episode_start(env, cfg.seed, "env_kwargs")
    for callback in make_callbacks(cfg):  # kwargs refused by name; a check against the env where it has one
        if hasattr(callback, "check_env"):
            callback.check_env(env.unwrapped, cfg.n_envs)
    if cfg.trained_agent is not None:
        from sphere_env.training.trained_agent import check_trained_agent

        check_trained_agent(cfg, env)
    venv = DummyVecEnv([lambda env=env: env])
    try:
        try:
            with warnings.catch_warnings():  # e.g. PPO's batch-size hint for this 1-env stand-in
                warnings.simplefilter("ignore")
                algo_class(cfg.algo)(cfg.policy, venv, device="cpu", **cfg.algo_kwargs())
        except (ValueError, TypeError, AssertionError, KeyError) as err:
            raise ValueError(f"hyperparams: {cfg.algo.upper()} refused the values: {err}") from None
        if cfg.eval_freq <= 0:
            return
        train_kw, eval_kw = cfg.make_kwargs(), cfg.make_kwargs(evaluation=True)
        same_env = {k: v for k, v in train_kw.items() if k != "randomization"} == {
            k: v for k, v in eval_kw.items() if k != "randomization"
        }
        if same_env:
            eval_env = env
            try:
                env.unwrapped.set_randomization(eval_kw.get("randomization", "default"))
            except ValueError as err:
                raise _env_error(err, "eval_env_kwargs") from None
        else:
            eval_env = _make_checked(cfg.env_id, eval_kw, "eval_env_kwargs", cfg.env_wrapper)
        for p in cfg.eval_pressures_kpa or [None]:
            _try_episode_start(eval_env, cfg.eval_seed, "eval_env_kwargs", None if p is None else {"pressure_kpa": p})
        eval_env.close()
    finally:
        venv.close()
