"""Typed schemas of an environment's inputs: its keyword arguments and its ``reset`` options.

:class:`EnvKwargs` holds :class:`~sphere_env.envs.SphereEnv`'s keyword arguments;
:class:`RampDescentEnvKwargs` and :class:`RollEnvKwargs` join them with a task's
(:class:`~sphere_env.tasks.ramp_descent.RampDescentKwargs`,
:class:`~sphere_env.tasks.roll.RollKwargs`), as ``gym.make(id, **kwargs)`` passes them.
:func:`reset_options` gives the schema of a task's ``reset(options=...)``. Loading is the only
place these inputs are checked: an unknown key, a string or a bool where a number belongs, a
non-finite or out-of-range value is refused, before anything is built or changed, as a
``ValueError`` naming the kwarg or option, its value and what is allowed.

What needs the built environment stays with it: reading the ``randomization`` spec and the
randomized option values (:meth:`~sphere_env.tasks.randomization.RandomizationSpec.parse`, against
the calibration's pressure range), loading the calibration file, the explicit-torque stability of
the friction and the shell, and an initial sphere centre above the ground.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Annotated, Any, Literal, Mapping

from pydantic import AfterValidator, BeforeValidator, Field, create_model, field_validator, model_validator

from sphere_env.models.friction import DEFAULT_FRICTION
from sphere_env.parameter import Parameter
from sphere_env.params import (
    DEFAULT_TIME_STEP_S,
    MAX_EPISODE_S,
    MAX_PLANT_STEPS_PER_ACTION,
    PARAMETERS,
    RANDOMIZABLE,
    SHELL_MODELS,
    ParameterSpace,
)
from sphere_env.physics.config import CONTACT_APPROXIMATIONS, DEFAULT_SHELL_MODEL, InitialState, joint_friction
from sphere_env.schemas import Finite, Schema, allowed, count, fixed_tuple, number, shown
from sphere_env.tasks.ramp_descent import RampDescentKwargs
from sphere_env.tasks.roll import RollKwargs
from sphere_env.tasks.task import Task
from sphere_env.tasks.termination import MAX_RATE_RAD_S, MAX_SPEED_M_S
from sphere_env.tasks.terms import fixed_value

RENDER_MODES = ("human", "rgb_array")
#: Largest hydroelastic pressure grid step [kPa].
MAX_PRESSURE_STEP_KPA = 5.0
#: Parameters an env may append to its observation (``observe_params``): the numeric scalar
#: randomizable ones but the pressure (``observe_pressure``), and the calibration (as an index).
OBSERVABLE_PARAMETERS = tuple(
    n for n, rec in PARAMETERS.items() if rec.randomizable and rec.size == 1 and not rec.choices and n != "pressure_kpa"
) + ("calibration",)
#: Allowed frame sizes [px], each of width and height.
RENDER_SIZE_PX = (16, 4096)


class EnvKwargs(Schema):
    """Keyword arguments common to every sphere_env environment (``gym.make(id, **kwargs)``).
    Bounds and nominal values of the physical ones are the records of :mod:`sphere_env.params`.

    :param shell_model: ``"point"`` | ``"injected"`` (default) | ``"hydroelastic"`` (``docs/design.md``).
    :param friction_model: joint friction: a law/preset name for both joints (``"majd"`` default,
        ``"viscous"``, ``"coulomb"``, ``"none"``: the Table I presets) or ``{"steer": ..., "drive": ...}``;
        read as the resolved (steer, drive) pair of friction models.
    :param calibration: path of a shell calibration YAML, or the name of a shipped one
        (``"hydroelastic_fast"``: hydroelastic RL at a 10 ms step); ``None`` = the shipped default.
    :param calibration_drive_law: apply the calibration's fitted drive direction (its ``drive_law``
        section: drive friction scale, rolling and spin damping; default); False: the paper's drive
        direction whatever the calibration holds, as ``RampDescent-v0``-``v3`` and ``Roll-v0``/``v1``
        are registered (the versions from before the drive fit).
    :param control_frequency_hz: policy rate [Hz], default 50; its period must be a multiple of
        ``time_step_s``.
    :param time_step_s: plant time step [s], default 0.005.
    :param steer_torque_limit_nm: steer motor torque at action ±1 [N m], default 20.
    :param drive_torque_limit_nm: drive motor torque at action ±1 [N m], default 22 (gravity caps
        the useful pendulum torque near 21.9 N m).
    :param randomization: domain randomization spec (:mod:`sphere_env.tasks.randomization`):
        ``"default"`` (pressure uniform over the calibration range per reset), ``"off"``,
        ``"full"``, a mapping, or a :class:`RandomizationSpec`; read by ``RandomizationSpec.parse``
        against the calibration. Sampled values are in ``info["params"]``.
    :param observe_pressure: append the (privileged) pressure [kPa] to the observation; default False.
    :param pressure_reading: which pressure the observation's pressure component reports:
        ``"current"`` (default; the pressure the physics uses, a pressure sensor in the shell) or
        ``"at_reset"`` (the episode's starting pressure, an operator's gauge reading before the
        run, which a leak or any other pressure event during the episode leaves behind). Only
        read with ``observe_pressure``.
    :param observe_params: names of randomizable parameters whose episode values are appended,
        privileged, after the shell one-hot (for an asymmetric critic, ``privileged_dims`` counting
        them): numeric scalar ones, and ``calibration`` as its index among the shipped calibrations.
    :param observe_shell_model: append the (privileged) shell model as a one-hot [point, injected,
        hydroelastic] after the pressure; default False. With both, a critic can tell the episodes
        of a shell and pressure mixture apart while the actor drops them
        (:class:`sphere_env.training.policies.AsymmetricActorCriticPolicy`).
    :param observation_history_steps: also observe the last this many control steps' observations
        (every non-privileged component) and actions, most recent first, within [0, 20]; default 0.
        A memoryless policy then sees how the robot answered its recent torques, which tells the
        shell models apart; a real robot keeps the same history of its own measurements.
    :param observation_noise_scale: × default per-component noise σ, within [0, 100] (0 = off,
        default; 100× already buries every measured signal, larger values overflow float32); the
        nominal value of the randomizable parameter of that name.
    :param pressure_extrapolation_kpa: accept pressures up to this far outside the shell
        calibration's range [kPa], within [0, 5] (default 0): the pressure laws are evaluated beyond
        the range they were fitted on (the fault grid's pressures), and the ``default``
        randomization draws from the widened range.
    :param contact_approximation: Drake's discrete contact solver, one of ``sap``, ``lagged``,
        ``similar``, ``tamsi`` (default ``None``: ``sap`` for point/injected, ``lagged`` for
        hydroelastic). ``tamsi`` steps the twin about twice as fast as SAP and is offered for
        training only; SAP stays the reference physics of evaluation (speed and accuracy:
        ``docs/results/speed.md``). A solver the installed Drake no longer offers falls back to
        ``sap`` with a warning.
    :param incline_deg: ground incline [deg] within [0, 30] (ramp tasks).
    :param ramp_length_m: ramp length along the slope [m] within (0, 100]; ``None`` = infinite plane.
    :param render_mode: ``None`` | ``"human"`` (Meshcat) | ``"rgb_array"`` (VTK/EGL frames).
    :param meshcat: ``True`` or a Meshcat (:func:`sphere_env.physics.start_meshcat`) to visualize without
        ``render_mode="human"``; default False (never created in vector workers unless asked).
    :param record_replay: record every episode for :meth:`SphereEnv.save_replay` (creates a Meshcat).
    :param render_size: (width, height) of ``rgb_array`` frames [px], default (480, 360).
    :param hydroelastic_pressure_step_kpa: hydroelastic pressures snap to this grid [kPa], default
        0.5, so re-meshed shells (≈90 ms each) are cached (≈2 ms); 0 = exact pressures.
    """

    shell_model: Literal[SHELL_MODELS] = DEFAULT_SHELL_MODEL  # type: ignore[valid-type]
    friction_model: Any = Field(
        DEFAULT_FRICTION,
        validate_default=True,
        json_schema_extra=allowed(
            "a friction law or preset name, a {law, params} mapping, or {steer: ..., drive: ...}"
        ),
    )
    calibration: str | Path | None = Field(
        None, json_schema_extra=allowed("the path of a shell calibration YAML, the name of a shipped one, or None")
    )
    calibration_drive_law: bool = True
    control_frequency_hz: PARAMETERS["control_frequency_hz"].value_type = PARAMETERS["control_frequency_hz"].nominal
    time_step_s: PARAMETERS["time_step_s"].value_type = DEFAULT_TIME_STEP_S
    steer_torque_limit_nm: PARAMETERS["steer_torque_limit_nm"].value_type = PARAMETERS["steer_torque_limit_nm"].nominal
    drive_torque_limit_nm: PARAMETERS["drive_torque_limit_nm"].value_type = PARAMETERS["drive_torque_limit_nm"].nominal
    randomization: Any = "default"
    observe_pressure: bool = False
    pressure_reading: Literal["current", "at_reset"] = "current"
    observe_shell_model: bool = False
    observe_params: Annotated[
        tuple[Literal[OBSERVABLE_PARAMETERS], ...],  # type: ignore[valid-type]
        BeforeValidator(lambda v: tuple(v) if isinstance(v, list) else v),  # a YAML list
    ] = ()
    observation_history_steps: count(0, 20) = 0
    observation_noise_scale: PARAMETERS["observation_noise_scale"].value_type = 0.0
    incline_deg: PARAMETERS["incline_deg"].value_type = 0.0
    ramp_length_m: PARAMETERS["ramp_length_m"].value_type | None = None
    render_mode: Literal[RENDER_MODES] | None = None  # type: ignore[valid-type]
    meshcat: Any = False
    record_replay: bool = False
    render_size: fixed_tuple(count(*RENDER_SIZE_PX), 2, f"(width, height) within {list(RENDER_SIZE_PX)} px") = (
        480,
        360,
    )
    hydroelastic_pressure_step_kpa: number(
        ge=0.0, le=MAX_PRESSURE_STEP_KPA, words=f"[0, {MAX_PRESSURE_STEP_KPA:g}] kPa"
    ) = 0.5
    pressure_extrapolation_kpa: PARAMETERS["pressure_extrapolation_kpa"].value_type = 0.0
    contact_approximation: Literal[CONTACT_APPROXIMATIONS] | None = None  # type: ignore[valid-type]

    @field_validator("friction_model")
    @classmethod
    def _joint_frictions(cls, spec: Any) -> tuple[Any, Any]:
        """(steer, drive) friction models: a mapping whose keys are among steer/drive gives each
        joint its own (``majd`` where missing); anything else is both joints' law."""
        if isinstance(spec, Mapping) and spec and set(spec) <= {"steer", "drive"}:
            steer, drive = spec.get("steer", DEFAULT_FRICTION), spec.get("drive", DEFAULT_FRICTION)
        else:
            steer = drive = spec
        return joint_friction(steer, "steer"), joint_friction(drive, "drive")

    @model_validator(mode="after")
    def _control_period(self) -> "EnvKwargs":
        ratio = (1.0 / self.control_frequency_hz) / self.time_step_s
        if abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
            raise ValueError(
                f"field 'control_frequency_hz' = {self.control_frequency_hz!r} must make the control "
                f"period an integer multiple of time_step_s = {self.time_step_s} s"
            )
        if round(ratio) > MAX_PLANT_STEPS_PER_ACTION:
            raise ValueError(
                f"field 'control_frequency_hz' = {self.control_frequency_hz!r} with time_step_s = "
                f"{self.time_step_s} s makes every env step simulate {round(ratio)} plant steps; allowed: at "
                f"most {MAX_PLANT_STEPS_PER_ACTION} (cost: about 0.2-0.5 ms of compute per plant step)"
            )
        return self


class RampDescentEnvKwargs(EnvKwargs, RampDescentKwargs):
    """``gym.make("sphere_env/RampDescent-v2", **kwargs)``: the environment's and the task's
    kwargs, on an 8° ramp of 6 m by default."""

    incline_deg: PARAMETERS["incline_deg"].value_type = 8.0
    ramp_length_m: PARAMETERS["ramp_length_m"].value_type = 6.0


class RollEnvKwargs(EnvKwargs, RollKwargs):
    """``gym.make("sphere_env/Roll-v1", **kwargs)``: the environment's and the task's kwargs, on
    flat ground (no ramp)."""

    ramp_length_m: None = Field(None, json_schema_extra=allowed("None (Roll runs on flat ground)"))


def check_ground(task: Task, ramp_length_m: float | None) -> None:
    """Refuse a ground the task does not run on: a ramp task (``task.ramp``) needs a finite ramp,
    any other runs on flat ground (``ramp_length_m`` None); a ``ValueError`` naming the kwarg."""
    if task.ramp and ramp_length_m is None:
        raise ValueError(
            f"{task.name} kwargs: field 'ramp_length_m' = None: the task runs on a finite ramp; "
            f"allowed: {PARAMETERS['ramp_length_m'].allowed}"
        )
    if not task.ramp and ramp_length_m is not None:
        raise ValueError(
            f"{task.name} kwargs: field 'ramp_length_m' = {ramp_length_m!r}: the task has no ramp; "
            f"allowed: None ({task.name} runs on flat ground)"
        )


# ---- reset options ------------------------------------------------------------------------------
RATE_WORDS = f"[-{MAX_RATE_RAD_S:g}, {MAX_RATE_RAD_S:g}] rad/s (beyond, the state counts as a physics failure)"
SPEED_WORDS = f"[-{MAX_SPEED_M_S:g}, {MAX_SPEED_M_S:g}] m/s (beyond, the state counts as a physics failure)"
Rate = number(ge=-MAX_RATE_RAD_S, le=MAX_RATE_RAD_S, words=RATE_WORDS)
Speed = number(ge=-MAX_SPEED_M_S, le=MAX_SPEED_M_S, words=SPEED_WORDS)


class InitialStateOption(InitialState):
    """The ``initial_state`` option: an :class:`~sphere_env.physics.InitialState` or a mapping of
    its fields, with speeds and rates within the physics-failure limits (such an episode would end
    at its first step, and rates far beyond overflow the float32 observation)."""

    theta_dot: Rate = 0.0
    drive_rate: Rate = 0.0
    angular_velocity_rad_s: fixed_tuple(Rate, 3, "3 rates within " + RATE_WORDS) = (0.0, 0.0, 0.0)
    velocity_m_s: fixed_tuple(Speed, 3, "3 speeds within " + SPEED_WORDS) = (0.0, 0.0, 0.0)


class ResetOptions(Schema):
    """Options of ``reset(options=...)`` every task takes; :func:`reset_options` adds each
    randomization parameter (a fixed value for this episode, read by the env's
    ``RandomizationSpec.parse``) and the task's command values."""

    initial_state: InitialStateOption | None = Field(
        None, json_schema_extra=allowed("an InitialState or a mapping of its fields")
    )
    pressure_rate_kpa_per_s: Finite = Field(0.0, json_schema_extra=allowed("a finite number [kPa/s]"))


def reset_options(task: Task, space: ParameterSpace | None = None) -> type[ResetOptions]:
    """The schema of ``task``'s reset options: :class:`ResetOptions`, the randomization parameters
    within their bounds in ``space`` (the pressure: the calibration's range; without a space, the
    registry's records, the pressure a finite number) and the task's ``command_options`` within
    its ``command_option_bounds``."""
    records = PARAMETERS if space is None else space
    resolved = tuple(records[name] for name in RANDOMIZABLE)
    return _reset_options(tuple((k, *task.command_option_bounds[k]) for k in task.command_options), resolved)


@lru_cache(maxsize=None)
def _reset_options(
    commands: tuple[tuple[str, float, float], ...], resolved: tuple[Parameter, ...]
) -> type[ResetOptions]:
    fields: dict[str, Any] = {rec.name: (fixed_value(rec), None) for rec in resolved}
    for name, lo, hi in commands:
        fields[name] = (number(ge=lo, le=hi, words=f"[{lo:g}, {hi:g}]"), None)
    return create_model("ResetOptions", __base__=ResetOptions, **fields)


def _distinct(models: list[str]) -> list[str]:
    if len(set(models)) != len(models):
        raise ValueError("names a shell model twice")
    return models


class ShellModelMixtureKwargs(Schema):
    """The kwargs of :class:`sphere_env.wrappers.ShellModelMixture`."""

    shell_models: Annotated[
        list[Literal[SHELL_MODELS]],
        AfterValidator(_distinct),
        BeforeValidator(  # type: ignore[valid-type]
            lambda v: list(v) if isinstance(v, tuple) else v
        ),
        Field(min_length=1, json_schema_extra=allowed(f"a non-empty list of distinct names from {list(SHELL_MODELS)}")),
    ] = ["point", "injected"]


class ResidualKwargs(Schema):
    """The kwargs of :class:`sphere_env.wrappers.PDResidualAction` (and its evaluation combiner)."""

    scale: number(gt=0.0, le=2.0, words="a number in (0, 2]") = 0.5


def check_episode_length(env_id: str, kwargs: Mapping[str, Any], where: str = "env_kwargs") -> None:
    """Refuse env kwargs whose episode, ``max_episode_steps`` (gymnasium's ``make`` kwarg, else the
    registered length) control steps at ``control_frequency_hz``, lasts longer than
    :data:`~sphere_env.params.MAX_EPISODE_S` simulated seconds: its cost is that duration over the
    time step in plant steps.

    :raises ValueError: naming ``<where>.max_episode_steps`` (or ``.control_frequency_hz`` when the
        registered length is kept), the value and the longest allowed.
    """
    import gymnasium as gym

    registered = gym.spec(env_id).max_episode_steps
    steps = kwargs.get("max_episode_steps", registered)
    rate = kwargs.get("control_frequency_hz", PARAMETERS["control_frequency_hz"].nominal)
    step_s = kwargs.get("time_step_s", DEFAULT_TIME_STEP_S)
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (rate, step_s)) or rate <= 0:
        return  # refused by name when the env is built
    longest = int(MAX_EPISODE_S * rate)
    field = "max_episode_steps" if "max_episode_steps" in kwargs else "control_frequency_hz"
    shown_value = shown(kwargs.get(field))
    if not isinstance(steps, int) or isinstance(steps, bool) or not 1 <= steps <= longest:
        cost = f"{MAX_EPISODE_S * (1 / step_s if step_s > 0 else 0):.0f} plant steps at time_step_s = {step_s:g} s"
        raise ValueError(
            f"field '{where}.{field}' = {shown_value}: an episode of {shown(steps)} control steps at "
            f"{rate:g} Hz; allowed: whole episodes of at most {MAX_EPISODE_S:g} simulated s ({longest} "
            f"control steps at {rate:g} Hz; cost: {cost})"
        )
