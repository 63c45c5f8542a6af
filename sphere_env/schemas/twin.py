"""Typed schemas of a twin's configuration and initial state (pure Python: no Drake).

:class:`TwinConfigFields` holds the fields of :class:`sphere_env.physics.TwinConfig`,
:class:`InitialStateFields` those of :class:`sphere_env.physics.InitialState`; both dataclasses load
themselves through these schemas, so an unknown fixture, a string or a bool where a number belongs,
a non-finite or out-of-range value is refused with the field's name, its value and what is allowed.
:func:`parameter` turns a record of :mod:`sphere_env.params` into a field type with the record's
bounds.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field, field_validator, model_validator

from sphere_env.models.friction import resolve_friction
from sphere_env.params import DEFAULT_TIME_STEP_S, PARAMETERS, SHELL_MODELS
from sphere_env.schemas import Finite, Schema, _as_tuple, _real, allowed, fixed_tuple
from sphere_env.schemas.calibration import ResolutionHint

FIXTURES = ("free", "locked_steer", "steer_plane", "stand")
CONTACT_APPROXIMATIONS = ("sap", "lagged", "similar", "tamsi")
#: Fixtures without a ground incline (the pipe on a stand, the steer plane).
LEVEL_FIXTURES = ("steer_plane", "stand")


def parameter(name: str) -> Any:
    """A finite number within the bounds of the parameter record ``name`` (its allowed range and
    unit quoted by error messages)."""
    rec = PARAMETERS[name]
    bounds = {("gt" if rec.low_open else "ge"): rec.low, ("lt" if rec.high_open else "le"): rec.high}
    return Annotated[
        float,
        BeforeValidator(_real),
        Field(
            **{k: v for k, v in bounds.items() if v is not None},
            allow_inf_nan=False,
            json_schema_extra=allowed(rec.allowed),
        ),
    ]


def joint_friction(spec: Any, joint: str) -> Any:
    """``spec`` resolved as the friction model of ``joint``; any failure is a ``ValueError``."""
    try:
        return resolve_friction(spec, joint)
    except (TypeError, ValueError) as err:
        raise ValueError(str(err)) from None


Incline = parameter("incline_deg")
Vector3 = fixed_tuple(Finite, 3, "3 finite numbers")


class TwinConfigFields(Schema):
    """The fields of :class:`~sphere_env.physics.TwinConfig` (documented there). The joint
    frictions are read as resolved :class:`~sphere_env.models.friction.FrictionModel` s and
    ``inclines_deg`` as a sorted tuple without duplicates that holds ``incline_deg``."""

    fixture: Literal[FIXTURES] = "free"  # type: ignore[valid-type]
    shell_model: Literal[SHELL_MODELS] = "injected"  # type: ignore[valid-type]
    steer_friction: Any = "majd"
    drive_friction: Any = "majd"
    pressure_kpa: Finite | None = None
    incline_deg: Incline = 0.0
    ramp_length_m: parameter("ramp_length_m") | None = None
    time_step_s: parameter("time_step_s") = DEFAULT_TIME_STEP_S
    ground_friction: parameter("ground_friction") = PARAMETERS["ground_friction"].nominal
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
    pressure_extrapolation_kpa: parameter("pressure_extrapolation_kpa") = 0.0

    @field_validator("steer_friction", "drive_friction")
    @classmethod
    def _friction(cls, spec: Any, info) -> Any:
        return joint_friction(spec, info.field_name.removesuffix("_friction"))

    @model_validator(mode="after")
    def _level_fixtures(self) -> "TwinConfigFields":
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


class InitialStateFields(Schema):
    """The fields of :class:`~sphere_env.physics.InitialState`: angles [rad], rates [rad/s], the
    sphere centre [m] (``None``: resting at the origin) and its velocity [m/s], all finite."""

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
