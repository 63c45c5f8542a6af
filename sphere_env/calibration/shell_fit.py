"""Shell calibration from free-motion segments: robot on flat ground, pendulum free, no torque.

Segments are ``steer_plane`` trials (robot confined to the steer plane, drive locked) and ``free``
windows of a long log (whole robot free, e.g. a release or a push followed by free rocking). The
pressure of the segments is unknown; the fit is expressed at one pressure p₀ (by default the
calibration's nominal pressure): whatever the true pressure was, the file then says "at p₀ the
shell behaves like this", and the slopes of ω_n(p), ζ(p) carry it to other pressures.

* ``injected``: ω_n(p₀) [rad/s], ζ(p₀) [-] (K_inject, C_inject of eqs. 7–8) and the steer law's
  numbers for the chosen form (:data:`~sphere_env.models.calibration_schema.STEER_LAW_FORMS`): the rest angle
  φ_0 and the amplitude term.
* ``hydroelastic``: the factors on the steer couple it carries on top of Drake's hydroelastic
  contact (``couple_stiffness_factor``, ``couple_damping_factor``; law form and φ_0 from the
  injected fit), or the contact's modulus [Pa] and Hunt–Crossley dissipation [s/m].

Everything is expressed through a :class:`ShellCalibration`, never by touching the twin's
internals: ω_n and ζ move the intercept/scale of the curves (slopes kept), the modulus becomes a
contact-volume table V(p) = f_n / modulus scaled along the membrane shape, the dissipation becomes
k_d = d / C_inject(p₀). A candidate calibration is installed in one twin per fixture
(``twin.set_calibration(cal, p₀)``), so the Drake diagram is built once per model and fixture.

Several segments are fitted at once, each weighted by its length (every sample counts the same).
Fitted values carry 95 % confidence intervals from the Jacobian at the optimum (residual variance
× (JᵀJ)⁻¹; the residuals of one decay are correlated, so these intervals are optimistic); a value
whose interval is wider than the value itself, or that sits at a bound of the search, is marked
unidentified (:func:`unidentified`). The law's form is chosen by held-out error, never by training
error, and with two or more segments each segment's error is reported when it is left out of the
fit (leave-one-window-out): :mod:`sphere_env.calibration.steer_fit`.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np
from scipy.optimize import brentq, least_squares

from sphere_env.analysis.metrics import rmse
from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.shell_params import (
    BOUNDS,
    HYDRO_PARAMS,
    ShellFitOptions,
    check_hold,
    model_params,
    omega_n_floor,
    start_value,
)
from sphere_env.calibration.simulate import simulate_log
from sphere_env.models.calibration_schema import STEER_LAW_FORMS
from sphere_env.models.friction import FrictionModel
from sphere_env.models.rigid_body import RobotParameters
from sphere_env.models.shell import ShellCalibration, membrane_contact_volume_m3
from sphere_env.physics import Twin, TwinConfig
from sphere_env.schemas import validate


def pressure_for_modulus(
    modulus_pa: float, robot: RobotParameters | None = None, bracket_kpa: tuple[float, float] = (0.2, 200.0)
) -> float:
    """The gauge pressure [kPa] at which the membrane estimate gives m_hydro = f_n / V(p) = ``modulus_pa``."""
    r = robot or RobotParameters.from_urdf()
    f = lambda p: r.weight_n / membrane_contact_volume_m3(p, r.weight_n, r.radius_m) - modulus_pa  # noqa: E731
    return float(brentq(f, *bracket_kpa))


def calibration_at(
    base: ShellCalibration,
    pressure_kpa: float,
    omega_n: float | None = None,
    zeta: float | None = None,
    modulus_pa: float | None = None,
    dissipation_s_per_m: float | None = None,
    robot: RobotParameters | None = None,
    table_points: int = 12,
) -> dict[str, Any]:
    """A calibration mapping equal to ``base`` except that, at ``pressure_kpa``:

    ω_n = ``omega_n`` (intercept moved, slope kept), ζ = ``zeta`` (scale moved, rate kept),
    modulus = ``modulus_pa`` (V(p) becomes a table: the base V(p) times one factor so that
    f_n / V(p₀) = modulus), dissipation d = ``dissipation_s_per_m`` (k_d = d / C_inject(p₀); the k_d refits at other
    plant steps, ``k_d_by_time_step``, and ``k_d_by_pressure`` are dropped).
    """
    r = robot or RobotParameters.from_urdf()
    raw = copy.deepcopy(dict(base.raw))
    p0 = float(pressure_kpa)
    if omega_n is not None:
        raw["omega_n"] = {
            "model": "linear",
            "intercept_rad_s": float(omega_n - base.omega_n_slope * p0),
            "slope_rad_s_per_kpa": base.omega_n_slope,
        }
    if zeta is not None:
        raw["zeta"] = {
            "model": "exponential",
            "scale": float(zeta * math.exp(-base.zeta_rate * p0)),
            "rate_per_kpa": base.zeta_rate,
        }
    if modulus_pa is not None:
        lo, hi = base.pressure_range_kpa
        grid = np.unique(np.concatenate([np.linspace(lo, hi, table_points), [p0]]))
        v_base = np.array([base.volume_m3(p, r.weight_n, r.radius_m) for p in grid])
        factor = (r.weight_n / modulus_pa) / base.volume_m3(p0, r.weight_n, r.radius_m)
        raw["contact_volume"] = {
            "model": "table",
            "pressure_kpa": [float(x) for x in grid],
            "volume_m3": [float(v) for v in v_base * factor],
        }
    if dissipation_s_per_m is not None:
        cal = ShellCalibration.from_dict(raw, source="<fit>", check_stand_still=False)
        _, c_inject = cal.bind(r).injected_gains(p0)
        raw["hydroelastic"] = dict(raw["hydroelastic"], k_d=float(dissipation_s_per_m / c_inject))
        # k_d refitted at other steps, and any k_d against pressure, belonged to the old k_d: the
        # dissipation given here is the one at p0, held at every pressure
        raw["hydroelastic"].pop("k_d_by_time_step", None)
        raw["hydroelastic"].pop("k_d_by_pressure", None)
    return raw


class FitError(ValueError):
    """A shell fit that cannot be used (no free motion, no convergence, a robot that cannot stand)."""


@dataclass
class ShellFit:
    """Fitted shell parameters at p₀, their 95 % CIs, the parameters the data do not pin down
    (name -> reason, :func:`unidentified`), and per-trial RMSE [rad] of φ and θ on the fit trials."""

    model: str
    pressure_kpa: float
    params: dict[str, float]
    rmse: dict[str, dict[str, float]]
    calibration: dict[str, Any]
    ci95: dict[str, tuple[float, float]] = field(default_factory=dict)
    form: str = "linear"
    nfev: int = 0
    unidentified: dict[str, str] = field(default_factory=dict)
    held: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "form": self.form,
            "pressure_kpa": self.pressure_kpa,
            "params": self.params,
            "held": dict(self.held),
            "rmse_rad": self.rmse,
            "ci95": {k: list(v) for k, v in self.ci95.items()},
            "unidentified": dict(self.unidentified),
            "nfev": self.nfev,
        }


def fixture_twin(
    fixture: str,
    model: str,
    steer_friction: Any = "majd_steer",
    calibration: Any = None,
    pressure_kpa: float | None = None,
    time_step_s: float = 0.005,
    drive_friction: Any = "majd_drive",
) -> Twin:
    """A twin for replaying free-motion segments of ``fixture`` (the drive has no friction when locked)."""
    return Twin(
        TwinConfig(
            fixture=fixture,
            shell_model=model,
            steer_friction=steer_friction,
            drive_friction="none" if fixture in ("steer_plane", "stand") else drive_friction,
            calibration=calibration,
            pressure_kpa=pressure_kpa,
            time_step_s=time_step_s,
        )
    )


class TwinPool:
    """One twin per fixture for one shell model, built on first use and re-calibrated in place."""

    def __init__(
        self,
        model: str,
        steer_friction: Any = "majd_steer",
        time_step_s: float = 0.005,
        drive_friction: Any = "majd_drive",
    ):
        self.model, self.steer_friction, self.time_step_s, self.drive_friction = (
            model,
            steer_friction,
            time_step_s,
            drive_friction,
        )
        self.twins: dict[str, Twin] = {}
        self._cal: tuple[ShellCalibration, float] | None = None

    def install(self, cal: ShellCalibration, pressure_kpa: float) -> None:
        self._cal = (cal, pressure_kpa)
        for twin in self.twins.values():
            twin.set_calibration(cal, pressure_kpa)

    def get(self, fixture: str) -> Twin:
        twin = self.twins.get(fixture)
        if twin is None:
            twin = fixture_twin(
                fixture, self.model, self.steer_friction, None, None, self.time_step_s, self.drive_friction
            )
            self.twins[fixture] = twin
            if self._cal is not None:
                twin.set_calibration(*self._cal)
        return twin


def trial_rmse(twin: Twin | TwinPool, logs: Sequence[RobotLog]) -> dict[str, dict[str, float]]:
    """φ and θ RMSE [rad] per log for the twin (or pool of twins) as currently calibrated."""
    out = {}
    for log in logs:
        tw = twin.get(log.fixture) if isinstance(twin, TwinPool) else twin
        tr = simulate_log(tw, log)
        out[log.name] = {"phi": rmse(tr["phi"], log["phi"]), "theta": rmse(tr["theta"], log["theta"])}
    return out


def calibration_with(
    base: ShellCalibration,
    p0: float,
    values: Mapping[str, float],
    form: str | None = None,
    robot: RobotParameters | None = None,
) -> dict[str, Any]:
    """``base`` as a mapping with the named fitted values set at p₀ (see :func:`fit_shell` for names)."""
    raw = calibration_at(
        base,
        p0,
        omega_n=values.get("omega_n"),
        zeta=values.get("zeta"),
        modulus_pa=10 ** values["log10_modulus_pa"] if "log10_modulus_pa" in values else None,
        dissipation_s_per_m=values.get("dissipation_s_per_m"),
        robot=robot,
    )
    raw["nominal_pressure_kpa"] = float(p0)
    if form is not None or any(k in values for k in ("rest_angle_rad", *sum(STEER_LAW_FORMS.values(), ()))):
        law = dict(base.steer_law.as_dict())
        if form is not None and form != law["form"]:
            law = {"form": form, "rest_angle_rad": law["rest_angle_rad"]}
        for k in ("rest_angle_rad", *STEER_LAW_FORMS[law["form"]]):
            if k in values:
                law[k] = float(values[k])
            law.setdefault(k, start_value(k, base, p0, robot or RobotParameters.from_urdf()))
        raw["steer_law"] = law
    hyd = dict(raw["hydroelastic"])
    for k in HYDRO_PARAMS:
        if k in values:
            hyd[k] = float(values[k])
    raw["hydroelastic"] = hyd
    return raw


def unidentified(
    values: Mapping[str, float],
    ci95: Mapping[str, tuple[float, float]],
    bounds: Mapping[str, tuple[float, float]],
    at_bound_frac: float = 1e-3,
) -> dict[str, str]:
    """The fitted parameters the data do not pin down, name -> reason: a 95 % interval wider than
    |value| (the data cannot tell the value from one of twice its size or from none), an interval
    that could not be computed, or a value within ``at_bound_frac`` of its search range from a bound
    (the optimum is the bound, not a minimum of the error)."""
    out = {}
    for k, (lo, hi) in bounds.items():
        v = values[k]
        c_lo, c_hi = ci95.get(k, (math.nan, math.nan))
        tol = at_bound_frac * (hi - lo)
        if v <= lo + tol or v >= hi - tol:
            which = "lower" if v <= lo + tol else "upper"
            out[k] = f"at the {which} bound {lo if which == 'lower' else hi:.4g} of the search"
        elif not (math.isfinite(c_lo) and math.isfinite(c_hi)):
            out[k] = "95 % interval not computable"
        elif c_hi - c_lo > abs(v):
            out[k] = f"95 % interval [{c_lo:.4g}, {c_hi:.4g}] wider than |value| {abs(v):.4g}"
    return out


def jacobian_ci95(res, names: Sequence[str]) -> dict[str, tuple[float, float]]:
    """95 % intervals of a scipy ``least_squares`` result's parameters from the Jacobian at the optimum
    (residual variance × (JᵀJ)⁻¹); optimistic where the residuals are correlated, as a decay's are."""
    J = res.jac
    dof = max(J.shape[0] - J.shape[1], 1)
    try:
        cov = np.linalg.pinv(J.T @ J) * (2 * res.cost / dof)
        std = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        std = np.full(len(names), np.nan)
    return {k: (float(v - 1.96 * s), float(v + 1.96 * s)) for k, v, s in zip(names, res.x, std)}


def _moving(log: RobotLog, min_swing_rad: float = 0.02) -> bool:
    return float(np.ptp(log["phi"])) >= min_swing_rad or float(np.ptp(log["theta"])) >= min_swing_rad


def _check_segments(logs: Sequence[RobotLog]) -> None:
    """Refuses (:class:`FitError`) no segments, and a segment without φ and θ, of another fixture
    than ``steer_plane`` or ``free``, or with no free motion."""
    if not logs:
        raise FitError("fit_shell: no segments to fit on")
    for log in logs:
        for ch in ("phi", "theta"):
            if not log.has(ch):
                raise FitError(f"log {log.path!r}: trial {log.name!r} needs a {ch} channel for a shell fit")
        if log.fixture not in ("steer_plane", "free"):
            raise FitError(
                f"log {log.path!r}: trial {log.name!r} has fixture {log.fixture!r}; "
                "a shell fit needs 'steer_plane' or 'free' segments"
            )
        if not _moving(log):
            raise FitError(
                f"log {log.path!r}: trial {log.name!r}: no free motion to fit (phi and theta move "
                f"less than 0.02 rad over {log.t_s[-1]:.2f} s)"
            )


def _rmse_at_optimum(pool: TwinPool, logs: Sequence[RobotLog], where: str) -> dict[str, dict[str, float]]:
    """φ and θ RMSE [rad] per log with the pool at the optimum; refuses (:class:`FitError`) a twin
    that diverges there."""
    per = {}
    for log in logs:
        tr = simulate_log(pool.get(log.fixture), log)
        if tr.diverged:
            raise FitError(f"{where}: the twin diverged on {log.name!r} at the optimum. Nothing written.")
        per[log.name] = {"phi": rmse(tr["phi"], log["phi"]), "theta": rmse(tr["theta"], log["theta"])}
    return per


def _fitted_values(res, names: Sequence[str], lo: np.ndarray, hi: np.ndarray, raw: Mapping[str, Any]):
    """(values, 95 % intervals, unidentified) of a ``least_squares`` result over ``names`` searched
    in [lo, hi]; the modulus and k_d are added in the file's terms where they were fitted."""
    ci = jacobian_ci95(res, names)
    values = {k: float(v) for k, v in zip(names, res.x)}
    poor = unidentified(values, ci, {k: (float(a), float(b)) for k, a, b in zip(names, lo, hi)})
    if "log10_modulus_pa" in values:
        values["modulus_pa"] = 10 ** values["log10_modulus_pa"]
        ci["modulus_pa"] = tuple(10**c for c in ci["log10_modulus_pa"])
    if "dissipation_s_per_m" in values:
        values["k_d"] = float(raw["hydroelastic"]["k_d"])
    return values, ci, poor


# least_squares' settings of every shell fit (besides its bounds and evaluation budget)
_SOLVER = {"diff_step": 1e-3, "x_scale": "jac", "xtol": 1e-6, "ftol": 1e-8}


def _search_box(
    names: Sequence[str], base: ShellCalibration, p0: float, robot: RobotParameters, start: Mapping[str, float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lower bounds, upper bounds, start) of the search over ``names``: :data:`BOUNDS`, with ω_n
    kept where the robot can stand (:func:`omega_n_floor`); the start is ``start``'s value or
    :func:`start_value`, clipped into the box."""
    lo = np.array([BOUNDS[n][0] for n in names])
    hi = np.array([BOUNDS[n][1] for n in names])
    if "omega_n" in names:
        i = names.index("omega_n")
        lo[i] = max(lo[i], omega_n_floor(base, p0, robot))
    x0 = np.clip([float(start.get(n, start_value(n, base, p0, robot))) for n in names], lo, hi)
    return lo, hi, x0


def _optimum(res, cal_for, where: str, require_convergence: bool) -> tuple[ShellCalibration, dict]:
    """The calibration ``cal_for`` gives at a ``least_squares`` result, and its file's data. Refuses (:class:`FitError`)
    a result that did not converge (when ``require_convergence``), an optimum that is not finite,
    and one the robot cannot stand still with."""
    if require_convergence and res.status <= 0:
        raise FitError(
            f"{where}: did not converge after {res.nfev} evaluations ({res.message}); "
            "raise max_nfev, start closer or fit fewer parameters. Nothing written."
        )
    if not np.all(np.isfinite(res.x)) or not np.isfinite(res.cost):
        raise FitError(f"{where}: the optimum is not finite ({res.x}). Nothing written.")
    cal = cal_for(res.x)
    raw = dict(cal.raw)
    try:
        ShellCalibration.from_dict(raw, source=f"<{where}>")  # the stand-still check, naming the field
    except ValueError as err:
        raise FitError(f"{where}: refused: {err}. Nothing written.") from err
    return cal, raw


def _calibration_at(x, base, p0: float, names, fixed, law_form: str | None, robot) -> ShellCalibration:
    """The calibration with the searched ``names`` at ``x`` and the ``fixed`` values at p₀ (the law
    of ``law_form`` for an injected fit), not yet checked for standing still."""
    vals = dict(fixed, **dict(zip(names, map(float, x))))
    raw = calibration_with(base, p0, vals, law_form, robot)
    return ShellCalibration.from_dict(raw, source="<fit>", check_stand_still=False)


def _residuals(x, cal_for, pool: TwinPool, p0: float, logs: Sequence[RobotLog], theta_weight: float) -> np.ndarray:
    """φ and θ errors [rad] of every log with the calibration ``cal_for(x)`` (θ times
    ``theta_weight``), each sample weighted 1/√n: a log weighs by its length. A calibration whose
    curves leave their valid range somewhere in p (e.g. ζ ≥ 1) counts as a 1 rad error."""
    n_res = sum(2 * len(log.t_s) for log in logs)
    w = 1.0 / math.sqrt(n_res)
    try:
        cal = cal_for(x)
    except ValueError:
        return np.full(n_res, w)
    pool.install(cal, p0)
    parts = []
    for log in logs:
        tr = simulate_log(pool.get(log.fixture), log)
        parts += [w * (tr["phi"] - log["phi"]), theta_weight * w * (tr["theta"] - log["theta"])]
    return np.concatenate(parts)


def fit_shell(
    logs: Sequence[RobotLog],
    model: str,
    pressure_kpa: float,
    steer_friction: FrictionModel | str = "majd_steer",
    base: ShellCalibration | None = None,
    start: Mapping[str, float] | None = None,
    fixed_injected: Mapping[str, float] | None = None,
    time_step_s: float = 0.005,
    max_nfev: int = 60,
    twin: Twin | None = None,
    form: str | None = None,
    params: Sequence[str] | None = None,
    pool: TwinPool | None = None,
    drive_friction: FrictionModel | str = "majd_drive",
    require_convergence: bool = True,
    theta_weight: float = 1.0,
    hold: Mapping[str, float] | None = None,
) -> ShellFit:
    """Fit the shell ``model`` at p₀ = ``pressure_kpa`` to free-motion segments (``steer_plane`` or ``free``).

    Residuals are φ and θ errors [rad] of every log (θ times ``theta_weight``: the pendulum angle
    also depends on steer friction, which this fit does not touch), each log weighted by its length:
    every sample counts the same, so a window's say in the fit grows with how much of the motion it
    records, and the cost is the mean square error over all samples. Parameters: ``injected``:
    :func:`~sphere_env.calibration.shell_params.law_params` of ``form`` (default: the base
    calibration's form); ``hydroelastic``: :data:`~sphere_env.calibration.shell_params.HYDRO_PARAMS`
    (the steer couple's factors) unless ``params`` names others (``log10_modulus_pa``,
    ``dissipation_s_per_m``). ``fixed_injected``: ω_n, ζ at p₀ held while fitting hydroelastic
    parameters (default the base calibration's). ``hold``: parameters held at the given values
    instead of fitted (:func:`~sphere_env.calibration.shell_params.check_hold`; those of this model's
    default parameters are set in the base calibration and left out of the fit, the others are ignored):
    a parameter the data do not pin down, held so that the law is no richer than the data allow.

    Refuses (:class:`FitError`, nothing written) a segment with no free motion, a fit that does
    not converge within ``max_nfev`` evaluations (unless ``require_convergence`` is False), a
    diverged simulation at the optimum, and a result the robot cannot stand still with.
    """
    # The body is one search: its set-up (held parameters, the box, the twins), least_squares over
    # _residuals, and the optimum's checks and intervals.
    validate(ShellFitOptions, {"model": model, "form": form, "params": params}, "fit_shell")
    _check_segments(logs)
    base = base or ShellCalibration.load()
    robot = RobotParameters.from_urdf()
    p0 = base.check_pressure(pressure_kpa)
    form = form or base.steer_law.form
    law_form = form if model == "injected" else None
    held = {k: v for k, v in check_hold(hold or {}).items() if k in model_params(model, form)}
    if held:
        raw0 = calibration_with(base, p0, held, law_form, robot)
        base = ShellCalibration.from_dict(raw0, source=base.source, check_stand_still=False)
    if params is None:
        params = model_params(model, form, held)
    names = [n for n in params if n not in held]
    fixed = dict(fixed_injected or {}) if model == "hydroelastic" else {}
    lo, hi, x0 = _search_box(names, base, p0, robot, start or {})
    if pool is None:
        pool = TwinPool(model, steer_friction, time_step_s, drive_friction)
        if twin is not None:
            pool.twins[twin.config.fixture] = twin
    cal_for = functools.partial(
        _calibration_at, base=base, p0=p0, names=names, fixed=fixed, law_form=law_form, robot=robot
    )
    res = least_squares(
        _residuals, x0, bounds=(lo, hi), args=(cal_for, pool, p0, logs, theta_weight), max_nfev=max_nfev, **_SOLVER
    )
    where = f"shell fit of {model!r} (form {form!r}) on {[log.name for log in logs]}"
    cal, raw = _optimum(res, cal_for, where, require_convergence)
    pool.install(cal, p0)
    per = _rmse_at_optimum(pool, logs, where)
    values, ci, poor = _fitted_values(res, names, lo, hi, raw)
    K, C = cal.bind(robot).injected_gains(p0)
    values.update(K_inject=K, C_inject=C)
    return ShellFit(model, p0, values, per, raw, ci, law_form or cal.steer_law.form, res.nfev, poor, held)


def window(log: RobotLog, start_s: float, end_s: float, name: str | None = None) -> RobotLog:
    """The samples of ``log`` in [start_s, end_s] [s] as a log whose time restarts at 0."""
    keep = (log.t_s >= start_s - 1e-9) & (log.t_s <= end_s + 1e-9)
    if keep.sum() < 3:
        raise FitError(f"log {log.path!r}: window [{start_s}, {end_s}] s of {log.name!r} has fewer than 3 samples")
    t = log.t_s[keep]
    return dataclasses.replace(
        log,
        name=name or f"{log.name}[{start_s:g}:{end_s:g}]",
        t_s=t - t[0],
        channels={k: v[keep] for k, v in log.channels.items()},
        meta=dict(log.meta),
    )
