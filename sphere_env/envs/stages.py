"""The parameters the environment applies itself, as stages between the policy and the physics.

Every record of :mod:`sphere_env.params` with ``applied_by="env"`` has one stage here, registered
under the parameter's name (:func:`stage`). An :class:`ActionStage` sits on the way from the
policy's action to the motors' joint torques [N m]; a :class:`SensorStage` on the way from the
sensors' readings to the observation. Like Gymnasium's ``ActionWrapper`` and
``ObservationWrapper`` each stage maps one value to the next, and like Isaac Lab's event terms it
is named by what it applies: :class:`ActionPipeline` and :class:`SensorPipeline` run every
registered stage in registration order (this module's order), reading the values in force from
the episode's parameter set (the one the event manager draws at reset and updates within the
episode, reported in ``info["params"]``). A stage whose parameter is at its neutral value passes
its input through unchanged and draws nothing.

Adding a sensing or actuation parameter is its registry record and its stage here; the
environment never reads these parameters by name.

Order of the generator's draws (a seeded episode is reproducible): a sensor stage that draws does
so when the observation is made, after the task's step; the action stages draw nothing.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any, ClassVar, Mapping, TypeVar

import numpy as np

from sphere_env.params import PARAMETERS


@dataclass(frozen=True)
class StageContext:
    """What a stage may know of its environment.

    :param torque_limit_nm: (steer, drive) motor torque at action ±1 [N m].
    :param noise_std: default 1-σ noise of each sensor reading, in reading order (the measured
        components, then the task's extra ones), in the reading's unit.
    """

    torque_limit_nm: tuple[float, float]
    noise_std: np.ndarray


class Stage:
    """One parameter's effect. Subclasses set :attr:`parameter` (a registry name) and are made
    once per environment from its :class:`StageContext`."""

    #: the registry parameter the stage applies
    parameter: ClassVar[str]

    def __init__(self, context: StageContext):
        self.context = context

    def reset(self, params: Mapping[str, Any]) -> None:
        """Start an episode whose parameter set at reset is ``params`` (default: nothing to do)."""


class ActionStage(Stage):
    """A stage on the way to the motors: (steer, drive) joint torques [N m] in, the same out."""

    def __call__(self, tau: tuple[float, float], params: Mapping[str, Any]) -> tuple[float, float]:
        raise NotImplementedError


class SensorStage(Stage):
    """A stage on the way to the observation: the sensor readings (the measured components, then
    the task's extra ones) in, the same out; it may draw from the environment's generator."""

    def __call__(self, readings: list[float], params: Mapping[str, Any], rng: np.random.Generator) -> list[float]:
        raise NotImplementedError


#: The action stages by the parameter they apply, in the order they act.
ACTION_STAGES: dict[str, type[ActionStage]] = {}
#: The sensor stages by the parameter they apply, in the order they act.
SENSOR_STAGES: dict[str, type[SensorStage]] = {}

S = TypeVar("S", bound=type[Stage])


def stage(cls: S) -> S:
    """Register a stage class under its parameter (after the stages already registered)."""
    name = cls.parameter
    if PARAMETERS[name].applied_by != "env":
        raise ValueError(f"stage {cls.__name__}: parameter {name!r} is not applied by the environment")
    if name in ACTION_STAGES or name in SENSOR_STAGES:
        raise ValueError(f"stage {cls.__name__}: parameter {name!r} already has a stage")
    table: dict[str, Any] = ACTION_STAGES if issubclass(cls, ActionStage) else SENSOR_STAGES
    table[name] = cls
    return cls


def motor_torques(a0: float, a1: float, torque_limit_nm: tuple[float, float]) -> tuple[float, float]:
    """The joint torques [N m] of an action in [-1, 1]²: +1 drive = forward, and the drive joint's
    axis is −y, so τ_drive = −a · limit."""
    return a0 * torque_limit_nm[0], -a1 * torque_limit_nm[1]


# ---- actuation --------------------------------------------------------------------------------
@stage
class ActionLatency(ActionStage):
    """Torques reach the motors ``action_latency_steps`` control steps late; until the first
    action arrives, the motors get a zero action's torque."""

    parameter = "action_latency_steps"

    def reset(self, params: Mapping[str, Any]) -> None:
        self._steps = params[self.parameter]
        self._pending = deque([motor_torques(0.0, 0.0, self.context.torque_limit_nm)] * self._steps)

    def __call__(self, tau: tuple[float, float], params: Mapping[str, Any]) -> tuple[float, float]:
        if not self._steps:
            return tau
        self._pending.append(tau)
        return self._pending.popleft()


@stage
class MotorSaturation(ActionStage):
    """Each motor's |torque| at most ``motor_torque_scale`` × its torque limit."""

    parameter = "motor_torque_scale"

    def __call__(self, tau: tuple[float, float], params: Mapping[str, Any]) -> tuple[float, float]:
        cap = params[self.parameter]
        if cap >= 1.0:
            return tau
        steer, drive = cap * self.context.torque_limit_nm[0], cap * self.context.torque_limit_nm[1]
        return min(max(tau[0], -steer), steer), min(max(tau[1], -drive), drive)


@stage
class SteerTorqueOffset(ActionStage):
    """A bias in the steer motor's torque loop (a current-sensor offset): added to the commanded
    torque, the sum still within the motor's saturation (``motor_torque_scale`` × the limit)."""

    parameter = "steer_torque_offset_nm"

    def __call__(self, tau: tuple[float, float], params: Mapping[str, Any]) -> tuple[float, float]:
        offset = params[self.parameter]
        if not offset:
            return tau
        lim = params[MotorSaturation.parameter] * self.context.torque_limit_nm[0]
        return min(max(tau[0] + offset, -lim), lim), tau[1]


# ---- sensing ----------------------------------------------------------------------------------
@stage
class ObservationNoise(SensorStage):
    """Gaussian noise on every reading: σ = ``observation_noise_scale`` × the reading's default σ
    (:data:`~sphere_env.tasks.observation.DEFAULT_NOISE_STD`), drawn fresh at each observation."""

    parameter = "observation_noise_scale"

    def __call__(self, readings: list[float], params: Mapping[str, Any], rng: np.random.Generator) -> list[float]:
        scale = params[self.parameter]
        if scale <= 0.0:
            return readings
        noise = rng.normal(0.0, self.context.noise_std * scale).tolist()
        return [v + n for v, n in zip(readings, noise)]


# ---- pipelines --------------------------------------------------------------------------------
class ActionPipeline:
    """The action stages of one environment, in order: an action's way to the motor torques."""

    def __init__(self, context: StageContext):
        self._limits = context.torque_limit_nm
        self.stages = [cls(context) for cls in ACTION_STAGES.values()]

    def reset(self, params: Mapping[str, Any]) -> None:
        """Start an episode with the parameter set ``params`` drew at reset."""
        for s in self.stages:
            s.reset(params)

    def __call__(self, a0: float, a1: float, params: Mapping[str, Any]) -> tuple[float, float]:
        """The (steer, drive) joint torques [N m] the motors apply for the action (``a0``, ``a1``)
        in [-1, 1]² under the parameters in force ``params``."""
        tau = motor_torques(a0, a1, self._limits)
        for s in self.stages:
            tau = s(tau, params)
        return tau


class SensorPipeline:
    """The sensor stages of one environment, in order: the sensors' way to the observation."""

    def __init__(self, context: StageContext):
        self.stages = [cls(context) for cls in SENSOR_STAGES.values()]

    def reset(self, params: Mapping[str, Any]) -> None:
        """Start an episode with the parameter set ``params`` drew at reset."""
        for s in self.stages:
            s.reset(params)

    def __call__(self, readings: list[float], params: Mapping[str, Any], rng: np.random.Generator) -> list[float]:
        """The readings as the observation reports them under the parameters in force ``params``."""
        for s in self.stages:
            readings = s(readings, params, rng)
        return readings
