"""The observation as the robot computes it from its own sensors.

An exported policy takes the env's raw observation (``policy.json`` beside it lists the
components). :data:`FROM_SENSORS` says, for every component, which sensor channels of the robot
(the RoboBall log columns, ``docs/design.md`` §3) it comes from, how, in which frame and unit;
:class:`SensorObserver` is that computation, runnable: sensor samples in, the observation out.
A test feeds a real log through it and checks it against the env's observation at the same state.

Frames (``docs/design.md`` §2): the IMU on the pitch center PC reads R_W,PC = Rz(ψ) Rx(φ) Ry(α),
ψ the heading (shell_yaw), φ the pipe angle (pipe_roll), α the pendulum pitch (pitch_joint); the
drive encoder counts the shell against the pendulum the other way round from the twin's drive
joint q_d (axis −y_PC), so q_d = −drive_shaft. The lane frame is the ramp's: x down the fall line
from the run's start, y to the left, ψ = 0 pointing down the fall line.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Mapping, Sequence

import numpy as np
from pydantic import Field

from sphere_env.schemas import allowed, checker
from sphere_env.tasks.observation import wrap_angle

#: Each observation component: the sensor channels it reads, the computation, frame and unit.
FROM_SENSORS: dict[str, dict[str, Any]] = {
    "theta": {
        "channels": ["roll_joint.position"],
        "unit": "rad",
        "frame": "steer joint, axis +x_PC",
        "computation": "θ = roll_joint.position",
    },
    "theta_dot": {
        "channels": ["roll_joint.velocity"],
        "unit": "rad/s",
        "frame": "steer joint, axis +x_PC",
        "computation": "θ̇ = roll_joint.velocity",
    },
    "drive_angle": {
        "channels": ["drive_shaft.position"],
        "unit": "rad",
        "frame": "drive joint, axis −y_PC",
        "computation": "q_d = wrap(−(drive_shaft.position − drive_shaft.position at the run's start)) "
        "to [−π, π): the encoder's zero is arbitrary (a multi-turn count), the env starts "
        "every episode at q_d = 0",
    },
    "drive_rate": {
        "channels": ["drive_shaft.velocity"],
        "unit": "rad/s",
        "frame": "drive joint, axis −y_PC",
        "computation": "q̇_d = −drive_shaft.velocity",
    },
    "phi": {
        "channels": ["pipe_roll.position", "pitch_joint.position", "shell_yaw.position"],
        "unit": "rad",
        "frame": "driveshaft tilt against the ground, + about ŷ_PC × n",
        "computation": "φ = asin(ŷ_PC · n), ŷ_PC = Rz(ψ) Rx(φ_IMU) ŷ the driveshaft in the world, n = (sin β, 0, "
        "cos β) the ground normal of a ramp inclined β down +x; on flat ground φ = φ_IMU = "
        "pipe_roll.position (alias ball_roll)",
    },
    "phi_dot": {
        "channels": [
            "pipe_roll.position",
            "pipe_roll.velocity",
            "pitch_joint.velocity",
            "shell_yaw.position",
            "shell_yaw.velocity",
        ],
        "unit": "rad/s",
        "frame": "as φ",
        "computation": "φ̇ = ((ω × ŷ_PC) · n) / cos φ, ω = ψ̇ ẑ + φ̇_IMU Rz(ψ) x̂ + α̇ Rz(ψ) Rx(φ_IMU) ŷ the "
        "IMU's angular velocity in the world; on flat ground φ̇ = pipe_roll.velocity",
    },
    "omega_d": {
        "channels": ["pitch_joint.velocity", "shell_yaw.velocity", "pipe_roll.position", "drive_shaft.velocity"],
        "unit": "rad/s",
        "frame": "shell angular velocity about the driveshaft ŷ_PC, + rolling forward",
        "computation": "ω_d = α̇ + ψ̇ sin φ − q̇_d = pitch_joint.velocity + shell_yaw.velocity · "
        "sin(pipe_roll.position) + drive_shaft.velocity (ω_WPC · ŷ_PC = α̇ + ψ̇ sin φ under "
        "R_W,PC = Rz(ψ) Rx(φ) Ry(α))",
    },
    "heading_rate": {
        "channels": ["shell_yaw.velocity"],
        "unit": "rad/s",
        "frame": "yaw of ŷ_PC × ẑ_W, + counter-clockwise",
        "computation": "ψ̇ = shell_yaw.velocity (alias ball_yaw)",
    },
    "gravity_x": {
        "channels": ["pipe_roll.position", "pitch_joint.position", "drive_shaft.position"],
        "unit": "-",
        "frame": "unit gravity direction in the pipe (shell) frame P",
        "computation": "g_P = −(r₀ cos q_d + r₂ sin q_d, r₁, −r₀ sin q_d + r₂ cos q_d) with (r₀, r₁, r₂) = "
        "(−cos φ sin α, sin φ, cos φ cos α), ẑ_W in PC; gravity_x = g_P[0]",
    },
    "gravity_y": {
        "channels": ["pipe_roll.position"],
        "unit": "-",
        "frame": "as gravity_x",
        "computation": "gravity_y = g_P[1] = −sin φ",
    },
    "gravity_z": {
        "channels": ["pipe_roll.position", "pitch_joint.position", "drive_shaft.position"],
        "unit": "-",
        "frame": "as gravity_x",
        "computation": "gravity_z = g_P[2]",
    },
    "omega_ref": {
        "channels": [],
        "unit": "rad/s",
        "frame": "as ω_d",
        "computation": "the operator's speed command now in force",
    },
    "heading_error": {
        "channels": ["shell_yaw.position"],
        "unit": "rad",
        "frame": "lane frame",
        "computation": "wrap(0 − ψ) to [−π, π), ψ = shell_yaw.position − the IMU yaw of the fall line "
        "(heading measured from the lane's direction)",
    },
    "lateral_error": {
        "channels": ["localization"],
        "unit": "m",
        "frame": "lane frame",
        "computation": "−y: the sphere centre's offset to the left of the lane's centre line (the fall "
        "line through the start), negated; from the robot's localization (external "
        "tracking, or odometry ẋ = R ω_d cos ψ, ẏ = R ω_d sin ψ with R the shell radius)",
    },
    "speed_error_integral": {
        "channels": ["omega_d"],
        "unit": "rad",
        "frame": "-",
        "computation": "I ← clip(I + (ω_ref − ω_d) T, −3, 3) at every control step after the "
        "first, T the control period, I = 0 at the run's start; ω_ref the command "
        "in force after the step",
    },
    "omega_d_rate": {
        "channels": ["omega_d"],
        "unit": "rad/s^2",
        "frame": "-",
        "computation": "(ω_d − ω_d of the previous control step) / T; 0 at the run's start",
    },
    "pendulum_pitch": {
        "channels": ["pitch_joint.position"],
        "unit": "rad",
        "frame": "pitch of PC about ŷ_PC against the vertical, + lifted backward",
        "computation": "α = pitch_joint.position (IMU pitch: not a joint angle)",
    },
    "pendulum_pitch_rate": {
        "channels": ["pitch_joint.velocity"],
        "unit": "rad/s",
        "frame": "as α",
        "computation": "α̇ = pitch_joint.velocity",
    },
}

#: Observation components no sensor of the robot gives, which an actor may still take (an
#: asymmetric actor-critic with ``privileged_dims: 3`` keeps the pressure): where they come from.
FROM_OPERATOR: dict[str, dict[str, Any]] = {
    "pressure_kpa": {
        "unit": "kPa",
        "source": "the shell's gauge pressure, read by the operator before the run and held for the whole run "
        "(the env's pressure_reading='at_reset'); the robot logs no pressure channel, so a leak during the "
        "run goes unseen",
    },
}

#: The one table of channel aliases: a log may name a RoboBall channel either way (the log loader
#: of :mod:`sphere_env.calibration.logs` reads it too).
CHANNEL_ALIASES = {"pipe_roll": "ball_roll", "shell_yaw": "ball_yaw"}
SPEED_ERROR_INTEGRAL_LIMIT_RAD = 3.0


def channel(sample: Mapping[str, float], name: str) -> float:
    """A sensor value by its :data:`FROM_SENSORS` name, or by its alias."""
    if name in sample:
        return float(sample[name])
    base, _, field = name.partition(".")
    alias = CHANNEL_ALIASES.get(base)
    if alias is not None and f"{alias}.{field}" in sample:
        return float(sample[f"{alias}.{field}"])
    raise KeyError(f"sensor channel {name!r} (or its alias) is missing; got {sorted(sample)}")


#: Observation component names the sensors give (the keys of :data:`FROM_SENSORS`), in any order.
_SENSOR_NAMES = checker(
    Annotated[
        tuple[Literal[tuple(FROM_SENSORS)], ...],
        Field(  # type: ignore[valid-type]
            json_schema_extra=allowed(f"component names with a sensor computation: {sorted(FROM_SENSORS)}")
        ),
    ]
)


class SensorObserver:
    """The env's observation computed from sensor samples at the control rate, as :data:`FROM_SENSORS`
    documents. Privileged components (pressure, shell model) are never computed: an exported policy
    does not take them.

    :param names: the observation's component names in order (``observation_layout.names``).
    :param control_period_s: the policy's control period T [s].
    :param fall_line_yaw_rad: the IMU yaw (shell_yaw) when pointing down the fall line [rad].
    :param incline_deg: the ground's incline β [deg] (the ramp; 0 on flat ground).
    """

    def __init__(
        self, names: Sequence[str], control_period_s: float, fall_line_yaw_rad: float = 0.0, incline_deg: float = 0.0
    ):
        names = _SENSOR_NAMES(tuple(names), "field 'names'")
        self.names, self.period_s, self.fall_line_yaw_rad = tuple(names), float(control_period_s), fall_line_yaw_rad
        self._encoder0: float | None = None
        self._integral = self._rate = self._omega_prev = 0.0  # the speed loop's state
        b = math.radians(incline_deg)
        self._normal = np.array([math.sin(b), 0.0, math.cos(b)])

    def reset(self) -> None:
        """A run starts: the next sample sets the encoder's zero and the tracking state restarts."""
        self._encoder0 = None

    def observe(self, sample: Mapping[str, float], omega_ref_rad_s: float, lateral_offset_m: float = 0.0) -> np.ndarray:
        """The observation at one control step from a sensor sample (log column → value), the
        speed command in force and the robot's offset to the left of the lane's centre line [m]."""
        first = self._encoder0 is None
        if first:
            self._encoder0 = channel(sample, "drive_shaft.position")
        phi_imu = channel(sample, "pipe_roll.position")
        alpha = channel(sample, "pitch_joint.position")
        q_d = -(channel(sample, "drive_shaft.position") - self._encoder0)
        qd_dot = -channel(sample, "drive_shaft.velocity")
        psi = channel(sample, "shell_yaw.position") - self.fall_line_yaw_rad
        psi_dot = channel(sample, "shell_yaw.velocity")
        alpha_dot = channel(sample, "pitch_joint.velocity")
        omega_d = alpha_dot + psi_dot * math.sin(phi_imu) - qd_dot
        # the driveshaft ŷ_PC and the IMU's angular velocity in the world, R_W,PC = Rz(ψ) Rx(φ) Ry(α)
        cp, sp, cf, sf = math.cos(psi), math.sin(psi), math.cos(phi_imu), math.sin(phi_imu)
        y_w = np.array([-sp * cf, cp * cf, sf])
        w = (
            psi_dot * np.array([0.0, 0.0, 1.0])
            + channel(sample, "pipe_roll.velocity") * np.array([cp, sp, 0.0])
            + alpha_dot * y_w
        )
        s_n = float(y_w @ self._normal)
        phi = math.asin(max(-1.0, min(1.0, s_n)))
        phi_dot = float(np.cross(w, y_w) @ self._normal) / max(math.sqrt(max(1.0 - s_n * s_n, 0.0)), 1e-9)
        r0, r1, r2 = -cf * math.sin(alpha), sf, cf * math.cos(alpha)
        c, s = math.cos(q_d), -math.sin(q_d)
        gravity = (-(r0 * c - r2 * s), -r1, -(r0 * s + r2 * c))
        if first:
            self._integral, self._rate = 0.0, 0.0
        else:
            self._rate = (omega_d - self._omega_prev) / self.period_s
            lim = SPEED_ERROR_INTEGRAL_LIMIT_RAD
            self._integral = min(max(self._integral + (omega_ref_rad_s - omega_d) * self.period_s, -lim), lim)
        self._omega_prev = omega_d
        values = {
            "theta": channel(sample, "roll_joint.position"),
            "theta_dot": channel(sample, "roll_joint.velocity"),
            "drive_angle": wrap_angle(q_d),
            "drive_rate": qd_dot,
            "phi": phi,
            "phi_dot": phi_dot,
            "omega_d": omega_d,
            "heading_rate": psi_dot,
            "gravity_x": gravity[0],
            "gravity_y": gravity[1],
            "gravity_z": gravity[2],
            "omega_ref": omega_ref_rad_s,
            "heading_error": wrap_angle(-psi),
            "lateral_error": -lateral_offset_m,
            "speed_error_integral": self._integral,
            "omega_d_rate": self._rate,
            "pendulum_pitch": alpha,
            "pendulum_pitch_rate": alpha_dot,
        }
        return np.array([values[n] for n in self.names], dtype=np.float32)
