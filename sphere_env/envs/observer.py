"""What an environment observes each control step: the task's components of the physics state
(the sensor readings through the env's :class:`~sphere_env.envs.stages.SensorPipeline`), the
pressure reading, the shell model's one-hot and the privileged parameters it is asked to observe,
and the last observations and actions when it keeps a history (the order is the task's
:class:`~sphere_env.tasks.ObservationLayout`)."""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from sphere_env.envs.stages import SensorPipeline
from sphere_env.params import SHELL_MODELS, SHIPPED_CALIBRATIONS
from sphere_env.tasks.observation import ObservationLayout, observation_vector, sensor_readings
from sphere_env.tasks.task import Task


def shell_one_hot(shell_model: str) -> tuple[float, ...]:
    return tuple(float(m == shell_model) for m in SHELL_MODELS)


def observed_value(params: Mapping[str, Any], name: str) -> float:
    """A privileged parameter's value in the observation (``calibration``: its index among the
    shipped ones, -1 for another file)."""
    value = params[name]
    if name == "calibration":
        return float(SHIPPED_CALIBRATIONS.index(value)) if value in SHIPPED_CALIBRATIONS else -1.0
    return float(value)


class EnvObserver:
    """The observations of one environment's episodes.

    :param task: the env's task (its command).
    :param layout: the observation layout the env exports.
    :param sensors: the env's sensor stages (noise), applied to each observation's readings.
    :param shell_model: the env's shell model (the one-hot until an episode draws another).
    :param observe_pressure, pressure_reading, observe_shell_model, observe_params: the env's kwargs.
    """

    def __init__(
        self,
        task: Task,
        layout: ObservationLayout,
        sensors: SensorPipeline,
        shell_model: str,
        observe_pressure: bool,
        pressure_reading: str,
        observe_shell_model: bool,
        observe_params: tuple[str, ...],
    ):
        self.task, self.layout, self.sensors = task, layout, sensors
        self.observe_pressure, self.pressure_reading = observe_pressure, pressure_reading
        self.observe_shell_model, self.observe_params = observe_shell_model, observe_params
        self._shell_one_hot = shell_one_hot(shell_model) if observe_shell_model else ()
        k = layout.history_steps
        # the last k observations (own components) and actions, most recent first
        self._obs_history = np.zeros((k, layout.own.stop), dtype=np.float32)
        self._action_history = np.zeros((k, 2), dtype=np.float32)
        self._history_empty = True
        self._pressure_at_reset_kpa = 0.0
        #: the last observation made
        self.last = np.zeros(len(layout), dtype=np.float32)

    def reset(self, params: Mapping[str, Any]) -> None:
        """Start an episode with the parameters ``params`` drew: its shell one-hot and starting
        pressure, its sensor stages; no action yet, and the history filled with the first observation."""
        self.sensors.reset(params)
        self._pressure_at_reset_kpa = params["pressure_kpa"]
        if self.observe_shell_model:
            self._shell_one_hot = shell_one_hot(params["shell_model"])
        self._action_history[:] = 0.0
        self._history_empty = True

    def act(self, a0: float, a1: float) -> None:
        """Keep a step's action in the history."""
        if self.layout.history_steps:
            self._action_history[1:] = self._action_history[:-1]
            self._action_history[0] = (a0, a1)

    def pressure_kpa(self, params: Mapping[str, Any]) -> float:
        """The pressure the observation reports [kPa]: the physics' current one, or the episode's
        starting one under ``pressure_reading="at_reset"``."""
        return self._pressure_at_reset_kpa if self.pressure_reading == "at_reset" else params["pressure_kpa"]

    def observe(self, state, params: Mapping[str, Any], rng: np.random.Generator) -> np.ndarray:
        """The observation of ``state`` under the episode's parameters ``params`` (the sensor
        stages' draws from ``rng``)."""
        readings = self.sensors(sensor_readings(state, self.layout.extra_names), params, rng)
        obs = observation_vector(
            readings,
            self.task.command(state),
            self.pressure_kpa(params) if self.observe_pressure else None,
            self._shell_one_hot,
            tuple(observed_value(params, n) for n in self.observe_params),
        )
        if self.layout.history_steps:
            own = obs[self.layout.own]
            hist = self._obs_history
            if self._history_empty:  # at reset: the robot has been where it starts
                hist[:] = own
                self._history_empty = False
            obs = np.concatenate([own, hist.ravel(), self._action_history.ravel(), obs[self.layout.own.stop :]])
            hist[1:] = hist[:-1]
            hist[0] = own
        self.last = obs
        return obs
