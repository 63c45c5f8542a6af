"""Joint friction inputs: a law's parameters by law name, and the preset file.

Each law of :mod:`sphere_env.models.friction` has one parameter schema here (units as in the law's
docstring); :class:`~sphere_env.models.friction.FrictionModel` loads its parameters through it, so a
missing, unknown, negative or non-finite parameter is refused by name wherever a friction model is
built (a preset file, an env kwarg, a fit).
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from sphere_env.schemas import Schema, allowed, number

NonNegative = number(ge=0.0)
Positive = number(gt=0.0)


class NoParams(Schema):
    """``none``: no parameters."""


class ViscousParams(Schema):
    """``viscous``: c [N m s/rad]."""

    c: NonNegative


class CoulombParams(Schema):
    """``coulomb`` (Coulomb + viscous, eq. 2): μ_s, μ_d [N m], c [N m s/rad], v_tol [rad/s]."""

    mu_s: NonNegative
    mu_d: NonNegative
    c: NonNegative
    v_tol: Positive = 0.05


class MajdParams(Schema):
    """``majd`` (Majd–Simaan): f_ω [N m s/rad], f_c, σ [N m], ω_c [rad/s], n [-]."""

    f_w: NonNegative
    f_c: NonNegative
    sigma: NonNegative
    omega_c: Positive
    n: Positive


#: parameter schema by law name (the laws of sphere_env.models.friction.FRICTION_LAWS)
LAW_PARAMS: dict[str, type[Schema]] = {
    "none": NoParams,
    "viscous": ViscousParams,
    "coulomb": CoulombParams,
    "majd": MajdParams,
}

LawName = Literal["none", "viscous", "coulomb", "majd"]


class FrictionSpec(Schema):
    """One joint's friction: a law and its parameters (checked by the law's schema)."""

    law: LawName = Field("none", json_schema_extra=allowed(str(sorted(LAW_PARAMS))))
    params: dict[str, Any] = Field(default_factory=dict, json_schema_extra=allowed("a mapping of the law's parameters"))


class FrictionPresetFile(Schema):
    """A friction preset file: ``presets: {<name>: {law: ..., params: {...}}}``."""

    presets: dict[str, FrictionSpec] = Field(
        min_length=1, json_schema_extra=allowed("a non-empty mapping of preset name -> {law, params}")
    )
