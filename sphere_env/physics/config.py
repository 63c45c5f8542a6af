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
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BeforeValidator, Field, field_validator, model_validator

from sphere_env.models.calibration_schema import ResolutionHint
from sphere_env.models.friction import DEFAULT_FRICTION, resolve_friction
from sphere_env.params import PARAMETERS, SHELL_MODELS
from sphere_env.schemas import Built, Finite, _as_tuple, allowed, fixed_tuple

__all__ = ["FIXTURES", "InitialState", "TwinConfig", "TwinState", "DEFAULT_CONTACT_APPROXIMATION"]

FIXTURES = ("free", "locked_steer", "steer_plane", "stand")
CONTACT_APPROXIMATIONS = ("sap", "lagged", "similar", "tamsi")
DEFAULT_CONTACT_APPROXIMATION = {"point": "sap", "injected": "sap", "hydroelastic": "lagged"}
#: Fixtures without a ground incline (the pipe on a stand, the steer plane).
LEVEL_FIXTURES = ("steer_plane", "stand")
#: The shell model of a twin or an environment when none is named.
DEFAULT_SHELL_MODEL = "injected"


def joint_friction(spec: Any, joint: str) -> Any:
    """``spec`` resolved as the friction model of ``joint``; any failure is a ``ValueError``."""
    try:
        return resolve_friction(spec, joint)
    except (TypeError, ValueError) as err:
        raise ValueError(str(err)) from None


Incline = PARAMETERS["incline_deg"].value_type
Vector3 = fixed_tuple(Finite, 3, "3 finite numbers")


class TwinConfig(Built):
    """Everything that defines one twin. Frozen; a bad name or value is refused on construction,
    before anything is built (``TwinConfig: field '<name>' = <value>: <problem>; allowed: ...``).
    :meth:`~sphere_env.schemas.Built.replace` gives a changed copy.

    :param fixture: ``free`` | ``locked_steer`` | ``steer_plane`` | ``stand`` (``docs/design.md``).
    :param shell_model: ``point`` | ``injected`` | ``hydroelastic``.
    :param steer_friction: law name (Table I preset for this joint), preset name, mapping
        ``{law, params}`` or :class:`FrictionModel`; held as the resolved :class:`FrictionModel`.
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
    :param calibration_drive_law: apply the calibration's ``drive_law`` section (default); False:
        the paper's drive direction whatever the calibration says
        (:meth:`~sphere_env.models.shell.ShellCalibration.without_drive_law`), as the envs
        registered before the drive fit have it.
    """

    where = "TwinConfig"

    fixture: Literal[FIXTURES] = "free"  # type: ignore[valid-type]
    shell_model: Literal[SHELL_MODELS] = DEFAULT_SHELL_MODEL  # type: ignore[valid-type]
    steer_friction: Any = Field(DEFAULT_FRICTION, validate_default=True)
    drive_friction: Any = Field(DEFAULT_FRICTION, validate_default=True)
    pressure_kpa: Finite | None = None
    incline_deg: Incline = PARAMETERS["incline_deg"].nominal
    ramp_length_m: PARAMETERS["ramp_length_m"].value_type | None = PARAMETERS["ramp_length_m"].nominal
    time_step_s: PARAMETERS["time_step_s"].value_type = PARAMETERS["time_step_s"].nominal
    ground_friction: PARAMETERS["ground_friction"].value_type = PARAMETERS["ground_friction"].nominal
    calibration: str | Path | None = Field(
        None, json_schema_extra=allowed("the path of a shell calibration YAML, the name of a shipped one, or None")
    )
    urdf: str | Path | None = Field(None, json_schema_extra=allowed("the path of a URDF, or None"))
    resolution_hint_m: ResolutionHint | None = None  # a calibration's bounds: the mesh's cost
    contact_approximation: Literal[CONTACT_APPROXIMATIONS] | None = None  # type: ignore[valid-type]
    bare_plant: bool = False
    inclines_deg: Annotated[
        tuple[Incline, ...],
        BeforeValidator(_as_tuple),
        Field(json_schema_extra=allowed(f"a sequence of inclines within {PARAMETERS['incline_deg'].allowed}")),
    ] = ()
    pressure_extrapolation_kpa: PARAMETERS["pressure_extrapolation_kpa"].value_type = PARAMETERS[
        "pressure_extrapolation_kpa"
    ].nominal
    calibration_drive_law: bool = True

    @field_validator("steer_friction", "drive_friction")
    @classmethod
    def _friction(cls, spec: Any, info) -> Any:
        return joint_friction(spec, info.field_name.removesuffix("_friction"))

    @model_validator(mode="after")
    def _level_fixtures(self) -> "TwinConfig":
        if self.fixture in LEVEL_FIXTURES:
            if self.incline_deg != 0.0:
                raise ValueError(
                    f"field 'incline_deg' = {self.incline_deg!r} not allowed for fixture {self.fixture!r}; allowed: 0"
                )
            if set(self.inclines_deg) - {0.0}:
                raise ValueError(
                    f"field 'inclines_deg' = {self.inclines_deg!r} not allowed for fixture "
                    f"{self.fixture!r}; allowed: () or (0,)"
                )
        if self.inclines_deg:
            object.__setattr__(self, "inclines_deg", tuple(sorted(set(self.inclines_deg) | {self.incline_deg})))
        return self


class InitialState(Built):
    """A full initial state, all finite. Angles in rad, rates in rad/s, positions in m, velocities
    in m/s; frozen, and a bad value is refused on construction (``field 'initial_state.<name>'``).

    Orientation of the pitch center is R_W,PC = Rz(ψ) Ry(pitch) Rx(roll) (world-referenced);
    ``position_m`` is the sphere centre in W (``None``: resting on the ground at the origin).
    Fixtures use the parts they have: ``steer_plane`` uses roll, position (y, z) and their
    rates; ``stand`` only θ, θ̇.
    """

    root = "initial_state"

    theta: Finite = 0.0
    drive_angle: Finite = 0.0
    roll: Finite = 0.0
    pitch: Finite = 0.0
    heading: Finite = 0.0
    position_m: Vector3 | None = None
    theta_dot: Finite = 0.0
    drive_rate: Finite = 0.0
    angular_velocity_rad_s: Vector3 = (0.0, 0.0, 0.0)
    velocity_m_s: Vector3 = (0.0, 0.0, 0.0)

    @model_validator(mode="before")
    @classmethod
    def _fields_of_a_state(cls, data: Any) -> Any:
        """Another state (an :class:`InitialState` given where a subclass is asked for) as the
        mapping of its fields."""
        return data.fields() if isinstance(data, InitialState) else data


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
