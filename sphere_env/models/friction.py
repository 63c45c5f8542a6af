"""Joint friction laws (paper §II.B, Table I; docs/design.md §4).

Each law maps joint velocity ``v`` [rad/s] to the *resisting* torque [N m] at the joint. The
friction torque adds to the motor torque. Laws take a math backend ``m`` (numpy by default) so the
physics layer can evaluate the identical law as a Drake symbolic expression in C++.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Annotated, Any, Callable, Literal, Mapping

import yaml
from pydantic import Field

from sphere_env import safe_yaml
from sphere_env.models.mathbackend import NUMPY
from sphere_env.resources import asset_path
from sphere_env.schemas import Schema, allowed, checker, number, validate

DEFAULT_PRESETS = asset_path("friction", "presets.yaml")
#: The friction of a joint when none is named: the Table I Majd–Simaan preset of that joint.
DEFAULT_FRICTION = "majd"


# ---- the inputs: a law's parameters by law name, and the preset file ----------------------------
# Each law has one parameter schema (units as in the law's docstring); FrictionModel loads its
# parameters through it, so a missing, unknown, negative or non-finite parameter is refused by name
# wherever a friction model is built (a preset file, an env kwarg, a fit).
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


#: parameter schema by law name (the laws of FRICTION_LAWS)
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


def none_law(v, m=NUMPY):
    """No friction: τ = 0."""
    return 0.0 * v


def viscous(v, c: float, m=NUMPY):
    """Viscous: τ = −c v.  ``c`` [N m s/rad]."""
    return -c * v


def coulomb(v, mu_s: float, mu_d: float, c: float, v_tol: float = 0.05, m=NUMPY):
    """Coulomb + viscous (eq. 2), regularized so a discrete step does not chatter.

    The paper's law is discontinuous: static μ_s inside |v| < tol, otherwise −μ_d sign(v) − c v.
    We replace sign(v) by tanh(v / (v_tol/3)) (99% of its final value at |v| = v_tol) and blend the
    static level into the kinetic one with a Gaussian Stribeck term of width ``v_tol``:

        τ = −[μ_d + (μ_s − μ_d) exp(−(v/v_tol)²)] tanh(3 v / v_tol) − c v

    The law is smooth and odd; its slope at v = 0 is 3 μ_s / v_tol, which keeps an explicit
    friction torque stable for the 5 ms plant step (docs/design.md §4).
    Units: μ_s, μ_d [N m], c [N m s/rad], v_tol [rad/s].
    """
    level = mu_d + (mu_s - mu_d) * m.exp(-(v / v_tol) * (v / v_tol))
    return -level * m.tanh(3.0 * v / v_tol) - c * v


def majd(v, f_w: float, f_c: float, sigma: float, omega_c: float, n: float, m=NUMPY):
    """Majd–Simaan friction, continuous form (docs/design.md §4):

        τ = −( f_ω v + [f_c + σ e^{−|v/ω_c|} − (σ + f_c) e^{−|n v/ω_c|}] sign(v) )

    The bracket vanishes at v = 0, so the law is continuous, and tends to f_ω v + f_c sign(v)
    at high speed. (The paper's printed eq. 3 multiplies the bracket by f_ω v, a typesetting slip;
    the authors' code uses σ − f_c, which jumps at v = 0.)
    Units: f_ω [N m s/rad], f_c, σ [N m], ω_c [rad/s], n [-].
    """
    a = m.abs(v / omega_c)
    bracket = f_c + sigma * m.exp(-a) - (sigma + f_c) * m.exp(-n * a)
    return -(f_w * v + bracket * m.sign(v))


# law name -> (function, ordered parameter names)
FRICTION_LAWS: dict[str, tuple[Callable[..., Any], tuple[str, ...]]] = {
    "none": (none_law, ()),
    "viscous": (viscous, ("c",)),
    "coulomb": (coulomb, ("mu_s", "mu_d", "c", "v_tol")),
    "majd": (majd, ("f_w", "f_c", "sigma", "omega_c", "n")),
}


@dataclass(frozen=True)
class FrictionModel:
    """A named friction law with its parameters, for one joint.

    :param law: one of ``none``, ``viscous``, ``coulomb``, ``majd``.
    :param params: the law's parameters by name (see each law for units), loaded through the law's
        schema (:data:`LAW_PARAMS`) (``coulomb``'s ``v_tol`` defaults to 0.05).
    """

    law: str = "none"
    params: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        params = self.params if not isinstance(self.params, Mapping) else dict(self.params)
        spec = validate(FrictionSpec, {"law": self.law, "params": params}, "friction model")
        loaded = validate(LAW_PARAMS[spec.law], spec.params, f"friction law {spec.law!r}", root="params")
        object.__setattr__(self, "params", {k: float(getattr(loaded, k)) for k in FRICTION_LAWS[spec.law][1]})

    def torque(self, v, m=NUMPY):
        """Resisting torque [N m] at joint velocity ``v`` [rad/s] (numpy or symbolic)."""
        fn, names = FRICTION_LAWS[self.law]
        return fn(v, *(self.params[k] for k in names), m=m)


def load_friction_presets(path: str | Path | None = None) -> dict[str, FrictionModel]:
    """Load named presets (``"<name>": {law: ..., params: {...}}``) from a YAML file."""
    path = Path(path) if path is not None else DEFAULT_PRESETS
    where = f"friction preset file {str(path)!r}"
    try:
        data = safe_yaml.load_file(path)
    except (OSError, yaml.YAMLError) as err:
        # the reason only: a YAML error quotes the file's text
        raise ValueError(f"{where}: cannot read: {getattr(err, 'strerror', None) or type(err).__name__}") from None
    presets = validate(FrictionPresetFile, data, where).presets
    return {name: FrictionModel(entry.law, entry.params) for name, entry in presets.items()}


def resolve_friction(spec: str | FrictionModel | Mapping[str, Any], joint: str) -> FrictionModel:
    """Turn a user spec into a :class:`FrictionModel`.

    ``spec`` may be a FrictionModel, a mapping ``{law, params}``, a preset name
    (``majd_steer``...), or a bare law name, which picks the Table I preset for ``joint``
    (``majd`` on the drive joint -> ``majd_drive``; ``none`` -> no friction).
    """
    if isinstance(spec, FrictionModel):
        return spec
    if isinstance(spec, Mapping):
        entry = validate(FrictionSpec, spec, f"friction model for joint {joint!r}")
        return FrictionModel(entry.law, entry.params)
    presets = load_friction_presets()
    name = _friction_name(tuple(sorted(presets)), joint)(spec, f"friction model for joint {joint!r}: name")
    if name in presets:
        return presets[name]
    if f"{name}_{joint}" in presets:
        return presets[f"{name}_{joint}"]
    return FrictionModel("none")


@lru_cache(maxsize=None)
def _friction_name(presets: tuple[str, ...], joint: str) -> Callable[[Any, str], str]:
    """The check of a friction name for ``joint``: a preset, a law with a preset for the joint
    (``majd`` -> ``majd_<joint>``) or ``none``."""
    suffix = f"_{joint}"
    names = sorted({*presets, *(p.removesuffix(suffix) for p in presets if p.endswith(suffix)), "none"})
    return checker(
        Annotated[
            Literal[tuple(names)],
            Field(
                json_schema_extra=allowed(  # type: ignore[valid-type]
                    f"a preset or law name {names}, a {{law, params}} mapping or a FrictionModel"
                )
            ),
        ]
    )
