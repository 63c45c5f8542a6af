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

from sphere_env.checks import finite_number
from sphere_env.models.friction import resolve_friction
from sphere_env.models.shell import check_shell_model
from sphere_env.params import DEFAULT_TIME_STEP_S, PARAMETERS
from sphere_env.params import check as check_param

FIXTURES = ("free", "locked_steer", "steer_plane", "stand")
CONTACT_APPROXIMATIONS = ("sap", "lagged", "similar", "tamsi")
DEFAULT_CONTACT_APPROXIMATION = {"point": "sap", "injected": "sap", "hydroelastic": "lagged"}


@dataclass(frozen=True)
class TwinConfig:
    """Everything that defines one twin. Frozen; validated on construction.

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
        if self.fixture not in FIXTURES:
            raise ValueError(f"fixture: unknown value {self.fixture!r}; allowed: {list(FIXTURES)}")
        check_shell_model(self.shell_model)
        inc = check_param("incline_deg", self.incline_deg)
        if self.fixture in ("steer_plane", "stand") and inc != 0.0:
            raise ValueError(f"incline_deg: value {inc} not allowed for fixture {self.fixture!r}; allowed: 0")
        if isinstance(self.inclines_deg, (str, bytes)) or not hasattr(self.inclines_deg, "__iter__"):
            raise ValueError(f"inclines_deg: value {self.inclines_deg!r} must be a sequence of inclines [deg]")
        incs = {check_param("incline_deg", v, "inclines_deg") for v in self.inclines_deg}
        if incs and self.fixture in ("steer_plane", "stand") and incs != {0.0}:
            raise ValueError(f"inclines_deg: value {tuple(self.inclines_deg)!r} not allowed for fixture "
                             f"{self.fixture!r}; allowed: () or (0,)")
        object.__setattr__(self, "inclines_deg", tuple(sorted(incs | {inc})) if incs else ())
        if self.ramp_length_m is not None:
            check_param("ramp_length_m", self.ramp_length_m)
        check_param("time_step_s", self.time_step_s)
        check_param("ground_friction", self.ground_friction)
        check_param("pressure_extrapolation_kpa", self.pressure_extrapolation_kpa)
        if self.resolution_hint_m is not None and not finite_number("resolution_hint_m", self.resolution_hint_m) > 0:
            raise ValueError(f"resolution_hint_m: value {self.resolution_hint_m!r} must be > 0 m")
        if self.contact_approximation is not None and self.contact_approximation not in CONTACT_APPROXIMATIONS:
            raise ValueError(
                f"contact_approximation: unknown value {self.contact_approximation!r}; "
                f"allowed: {list(CONTACT_APPROXIMATIONS)}"
            )
        # Resolve friction early so bad names fail here, before anything is built.
        object.__setattr__(self, "steer_friction", resolve_friction(self.steer_friction, "steer"))
        object.__setattr__(self, "drive_friction", resolve_friction(self.drive_friction, "drive"))


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
        for name in ("theta", "drive_angle", "roll", "pitch", "heading", "theta_dot", "drive_rate"):
            finite_number(f"initial_state.{name}", getattr(self, name))
        for name in ("position_m", "angular_velocity_rad_s", "velocity_m_s"):
            val = getattr(self, name)
            if val is None:
                continue
            try:
                arr = np.asarray(val, dtype=float)
            except (TypeError, ValueError):
                arr = None
            if arr is None or arr.shape != (3,) or not np.all(np.isfinite(arr)):
                raise ValueError(f"initial_state.{name}: value {val!r} must be 3 finite numbers")
        return self


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


