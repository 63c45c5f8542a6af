"""The drive direction in a calibration file: the ``drive_law`` section (the values in force) and the
``drive_fit`` record (whether the drive direction was fitted, on what, and which values are applied).

A drive fit (``calibrate drive-fit``, :mod:`sphere_env.calibration.drive_fit`) fits, per shell model,
the drive joint's friction scale and the shell's rolling resistance on a driven segment of a robot log.
A shipped calibration records that fit under ``drive_fit`` (or ``fitted: false`` with the reason); the
values it applies are its ``drive_law`` for the models in ``drive_law.shell_models``, and
:func:`check_drive_law_is_the_fit` refuses a file whose two sections disagree.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Optional

from pydantic import BeforeValidator, Field, create_model, field_validator, model_validator

from sphere_env.params import PARAMETERS, SHELL_MODELS
from sphere_env.schemas import Finite, Schema, _as_tuple, allowed, number, ordered_pair

#: The soft shell models (what a drive_law applies to unless it names its ``shell_models``).
SOFT_SHELLS = ("injected", "hydroelastic")
#: The parameters a drive fit reports (``calibrate drive-fit``), those a ``drive_law`` section applies,
#: and the channels of its held-out RMSE.
DRIVE_FIT_PARAMS = (
    "drive_friction_scale",
    "injected_rolling_damping_factor",
    "dissipation_s_per_m",
    "spin_damping_nms_per_rad",
)
DRIVE_LAW_PARAMS = ("drive_friction_scale", "injected_rolling_damping_factor", "spin_damping_nms_per_rad")
DRIVE_FIT_CHANNELS = ("omega_d", "heading_rate", "phi", "theta", "pendulum_pitch")
#: × the drive joint's friction law: the parameter registry's range of ``drive_friction_scale``.
DRIVE_FRICTION_SCALE_RANGE = (PARAMETERS["drive_friction_scale"].low, PARAMETERS["drive_friction_scale"].high)

NonNegative = number(ge=0.0)
NonEmptyText = Annotated[str, Field(min_length=1, json_schema_extra=allowed("a non-empty string"))]
DriveFrictionScale = number(
    ge=DRIVE_FRICTION_SCALE_RANGE[0],
    le=DRIVE_FRICTION_SCALE_RANGE[1],
    words=f"a number within [{DRIVE_FRICTION_SCALE_RANGE[0]:g}, {DRIVE_FRICTION_SCALE_RANGE[1]:g}] (× Table I's drive friction law)",
)
YesNo = Annotated[bool, Field(json_schema_extra=allowed("true or false (a YAML bool)"))]
#: Free-form records (notes).
Notes = Any


class DriveLawSection(Schema):
    """The drive-direction law, opt-in: absent, the injected shell damps rolling with C_inject (paper
    §IV), no shell resists spinning about the ground normal and the drive joint's friction law is
    Table I's (``calibrate drive-fit`` fits all three). ``shell_models``: the models the section
    applies to (the others keep the paper's drive direction)."""

    injected_rolling_damping_factor: NonNegative = 1.0  # C_drive = factor × C_inject(p)
    spin_damping_nms_per_rad: number(ge=0.0, le=100.0) = 0.0  # couple −C_spin (ω_shell·n̂) n̂ on the shell
    drive_friction_scale: DriveFrictionScale = 1.0  # × the drive joint's friction law
    shell_models: Annotated[
        tuple[Literal[SHELL_MODELS], ...],  # type: ignore[valid-type]
        BeforeValidator(_as_tuple),
        Field(min_length=1, json_schema_extra=allowed(f"a non-empty list of shell models out of {list(SHELL_MODELS)}")),
    ] = SOFT_SHELLS
    notes: Notes = None

    @field_validator("shell_models")
    @classmethod
    def _once_each(cls, models: tuple[str, ...]) -> tuple[str, ...]:
        if len(set(models)) != len(models):
            raise ValueError(f"a shell model is named twice in {list(models)}; name each once")
        return models


def _by_name(name: str, item: Any, names: tuple[str, ...], doc: str) -> type[Schema]:
    """A schema with one optional field of type ``item`` per name of ``names`` (an unknown name is
    refused by its path, as every schema's unknown key)."""
    return create_model(
        name, __base__=Schema, __module__=__name__, __doc__=doc, **{n: (Optional[item], None) for n in names}
    )


DriveParams = _by_name("DriveParams", Finite, DRIVE_FIT_PARAMS, "Fitted drive-direction values, by parameter.")
DriveIntervals = _by_name(
    "DriveIntervals", ordered_pair(None, None, ""), DRIVE_FIT_PARAMS, "95 % intervals [low, high], by parameter."
)
DriveUnidentified = _by_name(
    "DriveUnidentified", NonEmptyText, DRIVE_FIT_PARAMS, "Why a parameter is unidentified, by parameter."
)
DriveRmse = _by_name("DriveRmse", NonNegative, DRIVE_FIT_CHANNELS, "RMSE by channel [rad/s for rates, rad for angles].")


class DriveFitModel(Schema):
    """One shell model's drive fit as a calibration records it: the fitted values, their 95 %
    intervals, the unidentified ones (name -> reason), the RMSE on the part the fit never saw
    [rad/s, rad], and whether the values are in force (``applied``; else ``not_applied_because``)."""

    params: DriveParams  # type: ignore[valid-type]
    ci95: DriveIntervals | None = None  # type: ignore[valid-type]
    unidentified: DriveUnidentified | None = None  # type: ignore[valid-type]
    held_out_rmse: DriveRmse | None = None  # type: ignore[valid-type]
    applied: YesNo
    not_applied_because: NonEmptyText | None = None

    def values(self) -> dict[str, float]:
        """The fitted values given, by parameter."""
        return {k: v for k, v in self.params.model_dump().items() if v is not None}

    @model_validator(mode="after")
    def _why(self) -> "DriveFitModel":
        if not self.applied and self.not_applied_because is None:
            raise ValueError("field 'not_applied_because' is missing: a fit not applied says why (applied: false)")
        if self.applied and self.not_applied_because is not None:
            raise ValueError(
                f"field 'not_applied_because' = {self.not_applied_because!r} is given for an applied fit; "
                "allowed: only with applied: false"
            )
        if not self.values():
            raise ValueError(f"field 'params' is empty; allowed: values of {list(DRIVE_FIT_PARAMS)}")
        if self.applied:
            extra = sorted(set(self.values()) - set(DRIVE_LAW_PARAMS))
            if extra:
                raise ValueError(
                    f"field 'params' holds {extra}, which the drive_law section cannot apply; allowed applied: "
                    f"{list(DRIVE_LAW_PARAMS)} (record the others with applied: false)"
                )
        return self


DriveFitModels = _by_name("DriveFitModels", DriveFitModel, SHELL_MODELS, "Each shell model's drive fit.")


class DriveFitRecord(Schema):
    """Whether the drive direction was fitted, and on what: the log, its windows (fitted on and held
    out, in seconds of the log), the commit of the fit, its results file, and per shell model the
    values and whether they are in force (:class:`DriveFitModel`); or ``fitted: false`` with the
    ``reason``."""

    fitted: YesNo
    reason: NonEmptyText | None = None
    log: NonEmptyText | None = None
    fit_on: Annotated[list[NonEmptyText], Field(min_length=1)] | None = None
    held_out: list[NonEmptyText] | None = None
    windows_s: dict[str, ordered_pair(0.0, None, "s", strict=True)] | None = None
    base_calibration: NonEmptyText | None = None
    commit: (
        Annotated[
            str,
            Field(pattern=r"^[0-9a-f]{7,40}$", json_schema_extra=allowed("a git commit id: 7-40 lowercase hex digits")),
        ]
        | None
    ) = None
    results: NonEmptyText | None = None
    how: NonEmptyText | None = None
    models: DriveFitModels | None = None  # type: ignore[valid-type]
    notes: Notes = None

    @model_validator(mode="after")
    def _fitted_or_why(self) -> "DriveFitRecord":
        what = ("log", "fit_on", "commit", "models")
        if not self.fitted:
            if self.reason is None:
                raise ValueError("field 'reason' is missing: a drive direction not fitted says why (fitted: false)")
            given = [k for k in (*what, "held_out", "windows_s", "base_calibration", "results") if getattr(self, k)]
            if given:
                raise ValueError(f"field {given[0]!r} is given with fitted: false; allowed: only 'reason' and 'notes'")
            return self
        for k in what:
            if getattr(self, k) is None:
                raise ValueError(f"field {k!r} is missing: a fitted drive direction records {list(what)}")
        if self.reason is not None:
            raise ValueError(
                f"field 'reason' = {self.reason!r} is given with fitted: true; allowed: only with fitted: false"
            )
        named = [*self.fit_on, *(self.held_out or ())]
        if self.windows_s is not None:
            missing = [w for w in named if w not in self.windows_s]
            if missing:
                raise ValueError(
                    f"field 'windows_s' has no window {missing[0]!r}; allowed: the windows of fit_on and held_out"
                )
        both = sorted(set(self.fit_on) & set(self.held_out or ()))
        if both:
            raise ValueError(f"field 'held_out' = {self.held_out!r} names {both}, which the fit was fitted on")
        return self


def check_drive_law_is_the_fit(law: DriveLawSection | None, fit: DriveFitRecord | None) -> None:
    """A file that records its drive fit applies exactly the values it says are applied: each applied
    model is in ``drive_law.shell_models`` with the fitted values, no other model is, and a file whose
    drive direction was not fitted has no ``drive_law``."""
    if fit is None:
        return
    if not fit.fitted:
        if law is not None:
            raise ValueError(
                "field 'drive_law' is given while 'drive_fit.fitted' is false; allowed: a drive_law only "
                "with a fitted drive direction whose applied values it holds"
            )
        return
    models = {} if fit.models is None else {m: getattr(fit.models, m) for m in SHELL_MODELS}
    applied = {m: rec for m, rec in models.items() if rec is not None and rec.applied}
    if not applied:
        if law is not None:
            raise ValueError("field 'drive_law' is given while no model of 'drive_fit.models' is applied")
        return
    if law is None:
        raise ValueError(
            f"field 'drive_law' is missing: 'drive_fit.models' applies {sorted(applied)}; allowed: a drive_law "
            "holding their values"
        )
    if set(law.shell_models) != set(applied):
        raise ValueError(
            f"field 'drive_law.shell_models' = {list(law.shell_models)} differs from the applied models of "
            f"'drive_fit.models' {sorted(applied)}; allowed: the same models"
        )
    defaults = DriveLawSection()
    for model, rec in applied.items():
        for name in DRIVE_LAW_PARAMS:
            want = rec.values().get(name, getattr(defaults, name))
            if not math.isclose(getattr(law, name), want, rel_tol=1e-9, abs_tol=1e-12):
                raise ValueError(
                    f"field 'drive_law.{name}' = {getattr(law, name)!r} differs from 'drive_fit.models.{model}"
                    f".params.{name}' = {want!r}; allowed: the applied fit's value"
                )
