"""The shell fit's parameters: for each shell model and steer-law form, the names
:func:`~sphere_env.calibration.shell_fit.fit_shell` fits, their search bounds and start values, the
held values checked against those bounds, and the least ω_n(p₀) at which the robot can stand."""

from __future__ import annotations

import math
from typing import Annotated, Literal, Mapping

from pydantic import BeforeValidator, Field

from sphere_env.models.calibration_schema import STEER_LAW_FORMS
from sphere_env.models.rigid_body import RobotParameters
from sphere_env.models.shell import ShellCalibration
from sphere_env.schemas import Schema, _as_tuple, allowed, checker

# name -> (lower bound, upper bound); ω_n, ζ at p₀; the amplitude terms in the file's units.
BOUNDS = {
    "omega_n": (0.5, 8.0),
    "zeta": (0.0, 0.95),
    "rest_angle_rad": (-0.2, 0.2),
    "amplitude_stiffness_nm_per_rad": (-60.0, 400.0),
    "amplitude_scale_rad": (0.03, 1.5),
    "quadratic_stiffness_nm_per_rad2": (-40.0, 120.0),
    "couple_stiffness_factor": (0.0, 3.0),
    "couple_damping_factor": (0.0, 3.0),
    "log10_modulus_pa": (4.0, 7.0),
    "dissipation_s_per_m": (0.0, 20.0),
}
HYDRO_PARAMS = ("couple_stiffness_factor", "couple_damping_factor")


Form = Annotated[
    Literal[tuple(STEER_LAW_FORMS)],
    Field(  # type: ignore[valid-type]
        json_schema_extra=allowed(str(list(STEER_LAW_FORMS)))
    ),
]
_FORM = checker(Form)


class ShellFitOptions(Schema):
    """The choices of :func:`~sphere_env.calibration.shell_fit.fit_shell`: the shell model, the steer-law form and the fitted parameters."""

    model: Literal["injected", "hydroelastic"] = Field(json_schema_extra=allowed("['injected', 'hydroelastic']"))
    form: Form | None = None
    params: Annotated[tuple[Literal[tuple(BOUNDS)], ...], BeforeValidator(_as_tuple)] | None = Field(  # type: ignore[valid-type]
        None, json_schema_extra=allowed(f"names from {sorted(BOUNDS)}")
    )


def law_params(form: str) -> tuple[str, ...]:
    """The injected model's fitted parameters for a steer-law form (:data:`Form`)."""
    return ("omega_n", "zeta", "rest_angle_rad", *STEER_LAW_FORMS[_FORM(form, "field 'form'")])


def check_hold(hold: Mapping[str, float], where: str = "hold") -> dict[str, float]:
    """``hold`` (parameter name -> value held instead of fitted) checked against :data:`BOUNDS`:
    every name a fitted parameter of some model and form, every value finite and inside its search
    range. Raises ValueError naming the parameter, the value and what is allowed."""
    out = {}
    for name, value in hold.items():
        if name not in BOUNDS:
            raise ValueError(f"{where}: unknown parameter {name!r}; allowed: {sorted(BOUNDS)}")
        lo, hi = BOUNDS[name]
        v = float(value)
        if not (math.isfinite(v) and lo <= v <= hi):
            raise ValueError(f"{where}: {name} = {value!r} is outside its search range [{lo}, {hi}]")
        out[name] = v
    return out


def model_params(model: str, form: str, hold: Mapping[str, float] | None = None) -> tuple[str, ...]:
    """The parameters :func:`~sphere_env.calibration.shell_fit.fit_shell` fits by default for ``model``: :func:`law_params` of ``form``
    (injected) or :data:`HYDRO_PARAMS` (hydroelastic), without the ``hold`` names."""
    names = law_params(form) if model == "injected" else HYDRO_PARAMS
    return tuple(n for n in names if n not in (hold or {}))


def start_value(name: str, base: ShellCalibration, p0: float, robot: RobotParameters) -> float:
    """The start of the search for ``name`` at p₀: the value ``base`` gives it, or a neutral one."""
    law = base.steer_law
    if name == "omega_n":
        return float(base.omega_n(p0))
    if name == "zeta":
        return float(base.zeta(p0))
    if name == "log10_modulus_pa":
        return math.log10(base.bind(robot).hydroelastic(p0)[0])
    if name == "dissipation_s_per_m":
        return base.bind(robot).hydroelastic(p0)[1]
    if name in HYDRO_PARAMS:
        return getattr(base, name) or 1.0
    defaults = {
        "amplitude_stiffness_nm_per_rad": 0.0,
        "amplitude_scale_rad": 0.2,
        "quadratic_stiffness_nm_per_rad2": 0.0,
    }
    return float(getattr(law, name)) if law.form != "linear" or name == "rest_angle_rad" else defaults[name]


def omega_n_floor(base: ShellCalibration, p0: float, robot: RobotParameters, margin: float = 0.9) -> float:
    """The least ω_n(p₀) [rad/s] whose linear stiffness stays stable at the reach of φ at every pressure.

    Every form's extra stiffness vanishes (saturating) or may be negative (softening quadratic) at
    large |φ|, so the linear part alone must keep K_inject(p) + K_g cos φ_max > 0 over the range, with
    K_g the free-pendulum gravity stiffness; ``margin`` < 1 keeps a little positive stiffness there.
    The slope of ω_n(p) carries p₀ to the weakest end of the range.
    """
    from sphere_env.models.steer_law import PHI_REACH_RAD, gravity_stiffness_free_pendulum

    k_min = -margin * gravity_stiffness_free_pendulum(robot) * math.cos(PHI_REACH_RAD)
    w_min = math.sqrt(max(robot.K_eq + k_min, 0.0) / robot.M_eq)
    lo, hi = base.pressure_range_kpa
    return w_min + max(base.omega_n_slope * (p0 - lo), base.omega_n_slope * (p0 - hi), 0.0)
