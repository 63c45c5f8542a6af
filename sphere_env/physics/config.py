"""Twin configuration and plain state types (no Drake objects; pydrake is not imported here).

Frames (Drake notation): W world, PC pitch center (floating root, origin at the sphere centre),
P pipe assembly (shell), G ground. x_PC is forward, y_PC the driveshaft, z_PC up at rest.
Sign conventions (``docs/design.md``):
  θ      steer joint angle [rad] (pendulum vs driveshaft), URDF joint ``steer`` (axis +x_PC)
  q_d    drive joint angle [rad], URDF joint ``drive`` (axis −y_PC); + drive torque rolls backward
  α      pendulum pitch [rad]: pitch of the pitch center (and pendulum) against gravity about the
         driveshaft, + about +y_PC, i.e. > 0 when the pendulum is lifted backward (toward −x_PC)
  φ      pipe angle [rad]: asin(ŷ_PC · n_G), the driveshaft's tilt against the ground
  ω_d    drive velocity [rad/s]: ω_WP · ŷ_PC, + when the shell rolls toward +x_PC
  ψ      heading [rad]: yaw of the horizontal forward direction ŷ_PC × ẑ_W
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sphere_env.params import DEFAULT_TIME_STEP_S, PARAMETERS
from sphere_env.schemas import validate
from sphere_env.schemas.twin import FIXTURES, InitialStateFields, TwinConfigFields

__all__ = ["FIXTURES", "InitialState", "TwinConfig", "TwinState", "DEFAULT_CONTACT_APPROXIMATION"]
DEFAULT_CONTACT_APPROXIMATION = {"point": "sap", "injected": "sap", "hydroelastic": "lagged"}


@dataclass(frozen=True)
class TwinConfig:
    """Everything that defines one twin. Frozen; loaded through
    :class:`~sphere_env.schemas.twin.TwinConfigFields` on construction.

    :param fixture: ``free`` | ``locked_steer`` | ``steer_plane`` | ``stand`` (``docs/design.md``).
    :param shell_model: ``point`` | ``injected`` | ``hydroelastic``.
    :param steer_friction: law name (Table I preset for this joint), preset name, mapping
        ``{law, params}`` or :class:`FrictionModel`.
    :param drive_friction: as ``steer_friction``, for the drive joint.
    :param pressure_kpa: initial gauge pressure [kPa]; ``None`` = the calibration's nominal.
    :param incline_deg: ground incline [deg], downhill along +x_W.
    :param ramp_length_m: if set, the incline is a ramp of this length [m] (starting at the origin)
        followed by a flat run-out; if ``None`` the incline is an infinite plane.
    :param time_step_s: plant time step [s] (see ``evaluation/results/timestep_study.md``).
    :param ground_friction: effective Coulomb friction coefficient of shell and ground [-]
        (the shell keeps :data:`~sphere_env.params.SHELL_FRICTION`; the ground's is solved for).
    :param calibration: path of a shell calibration YAML, or the name of a shipped one
        (``"hydroelastic_fast"``; ``None`` = shipped default).
    :param urdf: robot URDF path (``None`` = shipped model).
    :param resolution_hint_m: hydroelastic mesh resolution [m]; ``None`` = calibration's value.
    :param contact_approximation: Drake discrete contact approximation; ``None`` picks ``sap``
        for point/injected and ``lagged`` (honours Hunt–Crossley dissipation) for hydroelastic.
    :param bare_plant: build without the friction/injected-torque system: the benchmark's
        bare-Drake floor (no joint friction, no injected shell torques).
    :param inclines_deg: inclines [deg] the twin can switch among with
        :meth:`~sphere_env.physics.Twin.set_incline` without a rebuild (``incline_deg`` is always
        one of them; stored sorted, without duplicates). Each adds one shell-kinematics system to
        the diagram (the ground normal is a constant of its expressions); the ground geometry
        moves in the context. Empty: ``incline_deg`` only.
    :param pressure_extrapolation_kpa: accept pressures this far outside the calibration's range
        [kPa], within [0, 5] (:meth:`~sphere_env.models.shell.ShellCalibration.extrapolated`); 0 =
        the calibrated range only.
    """

    fixture: str = "free"
    shell_model: str = "injected"
    steer_friction: Any = "majd"
    drive_friction: Any = "majd"
    pressure_kpa: float | None = None
    incline_deg: float = 0.0
    ramp_length_m: float | None = None
    time_step_s: float = DEFAULT_TIME_STEP_S
    ground_friction: float = PARAMETERS["ground_friction"].nominal
    calibration: str | Path | None = None
    urdf: str | Path | None = None
    resolution_hint_m: float | None = None
    contact_approximation: str | None = None
    bare_plant: bool = False
    inclines_deg: tuple[float, ...] = ()
    pressure_extrapolation_kpa: float = 0.0

    def __post_init__(self) -> None:
        # Loaded through the schema, so bad names and values fail here, before anything is built;
        # the frictions come back resolved and inclines_deg sorted, without duplicates.
        fields = validate(TwinConfigFields, vars(self), "TwinConfig")
        for name in ("steer_friction", "drive_friction", "inclines_deg"):
            object.__setattr__(self, name, getattr(fields, name))


@dataclass
class InitialState:
    """A full initial state. Angles in rad, rates in rad/s, positions in m, velocities in m/s.

    Orientation of the pitch center is R_W,PC = Rz(ψ) Ry(pitch) Rx(roll) (world-referenced);
    ``position_m`` is the sphere centre in W (``None``: resting on the ground at the origin).
    Fixtures use the parts they have: ``steer_plane`` uses roll, position (y, z) and their
    rates; ``stand`` only θ, θ̇.
    """

    theta: float = 0.0
    drive_angle: float = 0.0
    roll: float = 0.0
    pitch: float = 0.0
    heading: float = 0.0
    position_m: tuple[float, float, float] | None = None
    theta_dot: float = 0.0
    drive_rate: float = 0.0
    angular_velocity_rad_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    velocity_m_s: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def validate(self) -> "InitialState":
        """This state loaded through :class:`~sphere_env.schemas.twin.InitialStateFields`: a copy
        with plain floats and tuples, or ``ValueError`` naming the field."""
        return InitialState(**validate(InitialStateFields, vars(self), root="initial_state").model_dump())


@dataclass(frozen=True)
class TwinState:
    """A plain snapshot of the robot state (no Drake objects). Names and signs: module docstring
    and ``docs/design.md``; log channels in brackets."""

    time_s: float
    theta: float  # θ, steer joint angle [rad]
    theta_dot: float  # [rad/s]
    drive_angle: float  # q_d, drive joint angle [rad] (drive motor encoder, drive_shaft)
    drive_rate: float  # q̇_d [rad/s]
    phi: float  # φ, pipe angle against the ground [rad]
    phi_dot: float  # [rad/s]
    omega_d: float  # ω_d, drive velocity [rad/s]
    heading: float  # ψ [rad]
    heading_rate: float  # ψ̇ [rad/s]
    position_m: np.ndarray  # sphere centre in W [m]
    velocity_m_s: np.ndarray  # sphere centre velocity in W [m/s]
    gravity_in_pipe: np.ndarray  # unit gravity direction in the pipe frame (IMU-like) [-]
    pressure_kpa: float
    # α, pendulum pitch against gravity about the driveshaft [rad] (IMU, pitch_joint): the pitch
    # center's rotation about +y_PC out of the upright, atan2(−ẑ_W·x̂_PC, ẑ_W·ẑ_PC); 0 with the
    # pendulum hanging straight down, < 0 when it is lifted forward (toward +x_PC) to drive forward.
    # On the real robot's free_robot log pitch_joint is likewise < 0 while drive_shaft turns > 0.
    # α̇ = ω_WPC·ŷ_PC when upright, so ω_d = α̇ − q̇_d. Fixtures without a free base: 0.
    pendulum_pitch: float = 0.0
    pendulum_pitch_rate: float = 0.0  # α̇ [rad/s]

    def as_dict(self) -> dict:
        return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.__dict__.items()}
