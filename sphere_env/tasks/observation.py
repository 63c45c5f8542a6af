"""Observation assembly: plain functions of a :class:`~sphere_env.physics.TwinState`.

Only quantities the real robot measures (its log channels, ``docs/design.md``, plus an IMU-like gravity
direction) enter the measured part; the task command and optional privileged pressure follow.
No Drake Context is touched here.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field

from sphere_env.schemas import allowed, checker

TWO_PI = 2.0 * math.pi

#: Measured components: (name, unit, meaning, log channel). Order = observation index.
MEASURED_COMPONENTS: tuple[tuple[str, str, str], ...] = (
    ("theta", "rad", "steer joint angle θ (roll_joint)"),
    ("theta_dot", "rad/s", "steer joint rate θ̇ (roll_joint.velocity)"),
    ("drive_angle", "rad", "drive joint angle q_d (shell vs pendulum; −drive_shaft), wrapped to [-π, π)"),
    ("drive_rate", "rad/s", "drive joint rate q̇_d (−drive_shaft.velocity)"),
    ("phi", "rad", "pipe angle φ against the ground (pipe_roll)"),
    ("phi_dot", "rad/s", "pipe angle rate φ̇"),
    ("omega_d", "rad/s", "drive velocity ω_d, + rolling forward (≈ drive_shaft.velocity when rolling steadily)"),
    ("heading_rate", "rad/s", "heading rate ψ̇ (shell_yaw rate / IMU gyro)"),
    ("gravity_x", "-", "unit gravity direction in the pipe frame, x (IMU)"),
    ("gravity_y", "-", "unit gravity direction in the pipe frame, y (IMU)"),
    ("gravity_z", "-", "unit gravity direction in the pipe frame, z (IMU)"),
)
N_MEASURED = len(MEASURED_COMPONENTS)
#: Measured components a task may add after its command: (name, unit, meaning, default 1-σ noise).
#: The name is the :class:`~sphere_env.physics.TwinState` attribute it reads.
EXTRA_COMPONENTS: dict[str, tuple[str, str, float]] = {
    "pendulum_pitch": (
        "rad",
        "pendulum pitch α against the vertical, + = lifted backward (IMU on the "
        "pendulum, pitch_joint); the PD baseline's β = −α",
        0.005,
    ),
    "pendulum_pitch_rate": ("rad/s", "pendulum pitch rate α̇ (pitch_joint.velocity)", 0.05),
}
#: Unit and meaning of the task command components and the privileged pressure, by name (a task
#: may add its own command names; :meth:`ObservationLayout.describe` reports those without a unit).
OTHER_COMPONENTS: dict[str, tuple[str, str]] = {
    "omega_ref": ("rad/s", "command: target drive velocity ω_ref"),
    "heading_error": ("rad", "command: heading error wrap(ψ_ref − ψ)"),
    "lateral_error": ("m", "command: cross-track error −y back to the lane's centre line"),
    "yaw_rate_ref": ("rad/s", "command: target heading rate ψ̇_ref"),
    "speed_error_integral": ("rad", "tracking state: ∫(ω_ref − ω_d) dt since the episode start, clipped to ±3 rad"),
    "omega_d_rate": ("rad/s^2", "tracking state: ω̇_d, change of ω_d over the last control period / period"),
    "pressure_kpa": ("kPa", "privileged: shell inflation pressure"),
    "shell_point": ("-", "privileged: 1 if the episode runs on rigid point contact, else 0"),
    "shell_injected": ("-", "privileged: 1 if the episode runs on the injected shell, else 0"),
    "shell_hydroelastic": ("-", "privileged: 1 if the episode runs on the hydroelastic shell, else 0"),
}
#: Privileged one-hot components of the shell model (``observe_shell_model``), in order.
SHELL_ONE_HOT: tuple[str, ...] = ("shell_point", "shell_injected", "shell_hydroelastic")
#: Observation index of each measured component (the same in every task).
MEASURED_INDEX: dict[str, int] = {c[0]: i for i, c in enumerate(MEASURED_COMPONENTS)}


#: Names of extra measured components a task may observe (the keys of :data:`EXTRA_COMPONENTS`).
_EXTRA_NAMES = checker(
    Annotated[
        tuple[Literal[tuple(EXTRA_COMPONENTS)], ...],
        Field(  # type: ignore[valid-type]
            json_schema_extra=allowed(f"names from {list(EXTRA_COMPONENTS)}")
        ),
    ]
)


class ObservationLayout:
    """Names of the observation components in order, exported by each task so controllers and
    evaluation index observations by name: ``obs[layout["omega_d"]]``, ``obs[layout.command]``.

    Layout: the measured components (:data:`MEASURED_COMPONENTS`), then the task's command
    components, then the task's extra measured components (:data:`EXTRA_COMPONENTS`), then
    ``history_steps`` earlier observations of all these (:attr:`own`) and the ``history_steps``
    earlier actions (:func:`history_names`, slice :attr:`history`), then ``pressure_kpa`` if the
    privileged pressure is observed, then the shell model's one-hot (:data:`SHELL_ONE_HOT`) if it is
    observed, then the episode's values of the parameters in ``observe_params`` (privileged: what
    the randomization drew; ``calibration`` as its index in
    :data:`~sphere_env.params.SHIPPED_CALIBRATIONS`). The privileged components come last, so :attr:`privileged` is a trailing slice a
    policy's actor can drop (asymmetric actor-critic).
    """

    def __init__(
        self,
        command_names: tuple[str, ...] = (),
        observe_pressure: bool = False,
        extra_names: tuple[str, ...] = (),
        observe_shell_model: bool = False,
        history_steps: int = 0,
        observe_params: tuple[str, ...] = (),
    ):
        self.command_names = tuple(command_names)
        self.extra_names = _EXTRA_NAMES(tuple(extra_names), "field 'extra_names'")
        own = tuple(c[0] for c in MEASURED_COMPONENTS) + self.command_names + self.extra_names
        self.history_steps = history_steps
        self.names: tuple[str, ...] = (
            own
            + history_names(own, history_steps)
            + (("pressure_kpa",) if observe_pressure else ())
            + (SHELL_ONE_HOT if observe_shell_model else ())
            + tuple(observe_params)
        )
        self.index: dict[str, int] = {n: i for i, n in enumerate(self.names)}
        self.measured = slice(0, N_MEASURED)
        self.command = slice(N_MEASURED, N_MEASURED + len(self.command_names))
        self.extra = slice(self.command.stop, self.command.stop + len(self.extra_names))
        self.own = slice(0, len(own))  # what one control step observes (no history, nothing privileged)
        self.history = slice(self.extra.stop, self.extra.stop + (len(own) + len(ACTION_NAMES)) * history_steps)
        self.privileged = slice(self.history.stop, len(self.names))

    def noise_std(self) -> np.ndarray:
        """Default 1-σ noise of the measured and extra components, in observation order."""
        return np.concatenate([DEFAULT_NOISE_STD, [EXTRA_COMPONENTS[n][2] for n in self.extra_names]])

    def __getitem__(self, name: str) -> int:
        try:
            return self.index[name]
        except KeyError:
            raise KeyError(f"observation: no component {name!r}; components: {list(self.names)}") from None

    def __contains__(self, name: str) -> bool:
        return name in self.index

    def __len__(self) -> int:
        return len(self.names)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, ObservationLayout) and other.names == self.names

    def __repr__(self) -> str:
        return f"ObservationLayout({list(self.names)})"

    def describe(self) -> list[dict[str, Any]]:
        """One record per component in observation order: ``index``, ``name``, ``unit`` (None when
        the task's command is not in :data:`OTHER_COMPONENTS`; see the task's docstring) and ``meaning``."""
        known = (
            {c[0]: (c[1], c[2]) for c in MEASURED_COMPONENTS}
            | {n: (c[0], c[1]) for n, c in EXTRA_COMPONENTS.items()}
            | OTHER_COMPONENTS
            | ACTION_NAMES
        )
        out = []
        for i, n in enumerate(self.names):
            base, _, ago = n.partition("@-")
            unit, meaning = known.get(base, (None, "task command (see the task's docstring)"))
            if ago:
                when = "sent" if base in ACTION_NAMES else "as observed"
                meaning = f"{meaning}; {when} {ago} control step{'s' if ago != '1' else ''} earlier"
            out.append({"index": i, "name": n, "unit": unit, "meaning": meaning})
        return out


#: The actions a history holds (``observation_history_steps``): name -> (unit, meaning).
ACTION_NAMES: dict[str, tuple[str, str]] = {
    "action_steer": ("-", "the agent's steer action in [-1, 1] (before latency and saturation)"),
    "action_drive": ("-", "the agent's drive action in [-1, 1] (before latency and saturation)"),
}


def history_names(own: tuple[str, ...], steps: int) -> tuple[str, ...]:
    """Names of a ``steps``-long history: each earlier observation of the ``own`` components, most
    recent first (``omega_d@-1``: one control step ago), then each earlier action the same way."""
    return tuple(f"{n}@-{j}" for j in range(1, steps + 1) for n in own) + tuple(
        f"{a}@-{j}" for j in range(1, steps + 1) for a in ACTION_NAMES
    )


#: Default 1-σ measurement noise per measured component, in the component's unit. Scaled by the
#: env's ``observation_noise_scale`` (0 = noise off). Assumed encoder/IMU-grade values.
DEFAULT_NOISE_STD = np.array([0.005, 0.05, 0.005, 0.05, 0.01, 0.05, 0.05, 0.05, 0.01, 0.01, 0.01])


def wrap_angle(angle_rad: float) -> float:
    """Wrap an angle to [-π, π) [rad]."""
    return (angle_rad + math.pi) % TWO_PI - math.pi


def measured_values(state: Any) -> list[float]:
    """The measured components of a TwinState as plain floats (order of MEASURED_COMPONENTS)."""
    g = state.gravity_in_pipe
    return [
        state.theta,
        state.theta_dot,
        wrap_angle(state.drive_angle),
        state.drive_rate,
        state.phi,
        state.phi_dot,
        state.omega_d,
        state.heading_rate,
        float(g[0]),
        float(g[1]),
        float(g[2]),
    ]


def sensor_readings(state: Any, extra_names: tuple[str, ...] = ()) -> list[float]:
    """What the sensors read of a TwinState, as plain floats: the measured components
    (:data:`MEASURED_COMPONENTS`), then the extra ones named (:data:`EXTRA_COMPONENTS`)."""
    return measured_values(state) + [float(getattr(state, n)) for n in extra_names]


def observation_vector(
    readings: list[float],
    command: list[float],
    pressure_kpa: float | None = None,
    shell_one_hot: tuple[float, ...] = (),
    param_values: tuple[float, ...] = (),
) -> np.ndarray:
    """[measured (11) | command | extra components | pressure_kpa if given | shell one-hot |
    parameter values] as float32, from the sensor readings (:func:`sensor_readings`, after any
    sensor noise) and the rest (see :func:`assemble_observation`)."""
    values = readings[:N_MEASURED]
    values += command
    values += readings[N_MEASURED:]
    if pressure_kpa is not None:
        values.append(pressure_kpa)
    values += shell_one_hot
    values += param_values
    return np.array(values, dtype=np.float32)


def assemble_observation(
    state: Any,
    command: list[float],
    pressure_kpa: float | None = None,
    noise: np.ndarray | None = None,
    extra_names: tuple[str, ...] = (),
    shell_one_hot: tuple[float, ...] = (),
    param_values: tuple[float, ...] = (),
) -> np.ndarray:
    """[measured (11) | command | extra components | pressure_kpa if given | shell one-hot |
    parameter values] as float32.

    :param command: task command values, appended unchanged (not noised).
    :param pressure_kpa: privileged inflation pressure [kPa], appended if not ``None``.
    :param noise: additive noise for the measured and extra components (len 11 + len(extra_names)),
        or ``None``.
    :param extra_names: :data:`EXTRA_COMPONENTS` to append after the command.
    :param shell_one_hot: privileged shell-model one-hot (:data:`SHELL_ONE_HOT` order).
    :param param_values: privileged parameter values (``observe_params``), appended last.
    """
    readings = sensor_readings(state, extra_names)
    if noise is not None:
        readings = [v + n for v, n in zip(readings, noise.tolist())]
    return observation_vector(readings, command, pressure_kpa, shell_one_hot, param_values)
