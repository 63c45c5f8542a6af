"""Shell calibration from free-motion segments: robot on flat ground, pendulum free, no torque.

Segments are ``steer_plane`` trials (robot confined to the steer plane, drive locked) and ``free``
windows of a long log (whole robot free, e.g. a release or a push followed by free rocking). The
pressure of the segments is unknown; the fit is expressed at one pressure p₀ (by default the
calibration's nominal pressure): whatever the true pressure was, the file then says "at p₀ the
shell behaves like this", and the slopes of ω_n(p), ζ(p) carry it to other pressures.

* ``injected``: ω_n(p₀) [rad/s], ζ(p₀) [-] (K_inject, C_inject of eqs. 7–8) and the steer law's
  numbers for the chosen form (:data:`~sphere_env.models.shell.STEER_LAW_FORMS`): the rest angle
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
unidentified (:func:`unidentified`). The law's form is chosen by held-out error
(:func:`cross_validate`), never by training error; with two or more segments :func:`steer_fit`
also reports each segment's error when it is left out of the fit (leave-one-window-out).
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np
from scipy.optimize import brentq, least_squares

from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.simulate import rmse, simulate_log
from sphere_env.models.friction import FrictionModel
from sphere_env.models.rigid_body import RobotParameters
from sphere_env.models.shell import STEER_LAW_FORMS, ShellCalibration, membrane_contact_volume_m3
from sphere_env.physics.twin import Twin, TwinConfig


def pressure_for_modulus(modulus_pa: float, robot: RobotParameters | None = None,
                         bracket_kpa: tuple[float, float] = (0.2, 200.0)) -> float:
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
        raw["omega_n"] = {"model": "linear", "intercept_rad_s": float(omega_n - base.omega_n_slope * p0),
                          "slope_rad_s_per_kpa": base.omega_n_slope}
    if zeta is not None:
        raw["zeta"] = {"model": "exponential", "scale": float(zeta * math.exp(-base.zeta_rate * p0)),
                       "rate_per_kpa": base.zeta_rate}
    if modulus_pa is not None:
        lo, hi = base.pressure_range_kpa
        grid = np.unique(np.concatenate([np.linspace(lo, hi, table_points), [p0]]))
        v_base = np.array([base.volume_m3(p, r.weight_n, r.radius_m) for p in grid])
        factor = (r.weight_n / modulus_pa) / base.volume_m3(p0, r.weight_n, r.radius_m)
        raw["contact_volume"] = {"model": "table", "pressure_kpa": [float(x) for x in grid],
                                 "volume_m3": [float(v) for v in v_base * factor]}
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

    def as_dict(self) -> dict[str, Any]:
        return {"model": self.model, "form": self.form, "pressure_kpa": self.pressure_kpa, "params": self.params,
                "rmse_rad": self.rmse, "ci95": {k: list(v) for k, v in self.ci95.items()},
                "unidentified": dict(self.unidentified), "nfev": self.nfev}


def fixture_twin(fixture: str, model: str, steer_friction: Any = "majd_steer", calibration: Any = None,
                 pressure_kpa: float | None = None, time_step_s: float = 0.005,
                 drive_friction: Any = "majd_drive") -> Twin:
    """A twin for replaying free-motion segments of ``fixture`` (the drive has no friction when locked)."""
    return Twin(TwinConfig(fixture=fixture, shell_model=model, steer_friction=steer_friction,
                           drive_friction="none" if fixture in ("steer_plane", "stand") else drive_friction,
                           calibration=calibration, pressure_kpa=pressure_kpa, time_step_s=time_step_s))


class TwinPool:
    """One twin per fixture for one shell model, built on first use and re-calibrated in place."""

    def __init__(self, model: str, steer_friction: Any = "majd_steer", time_step_s: float = 0.005,
                 drive_friction: Any = "majd_drive"):
        self.model, self.steer_friction, self.time_step_s, self.drive_friction = (
            model, steer_friction, time_step_s, drive_friction)
        self.twins: dict[str, Twin] = {}
        self._cal: tuple[ShellCalibration, float] | None = None

    def install(self, cal: ShellCalibration, pressure_kpa: float) -> None:
        self._cal = (cal, pressure_kpa)
        for twin in self.twins.values():
            twin.set_calibration(cal, pressure_kpa)

    def get(self, fixture: str) -> Twin:
        twin = self.twins.get(fixture)
        if twin is None:
            twin = fixture_twin(fixture, self.model, self.steer_friction, None, None, self.time_step_s,
                                self.drive_friction)
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


# ---- parameters of each model and form --------------------------------------------------------------
# name -> (lower bound, upper bound); ω_n, ζ at p₀; the amplitude terms in the file's units.
_BOUNDS = {
    "omega_n": (0.5, 8.0), "zeta": (0.0, 0.95), "rest_angle_rad": (-0.2, 0.2),
    "amplitude_stiffness_nm_per_rad": (-60.0, 400.0), "amplitude_scale_rad": (0.03, 1.5),
    "quadratic_stiffness_nm_per_rad2": (-40.0, 120.0),
    "couple_stiffness_factor": (0.0, 3.0), "couple_damping_factor": (0.0, 3.0),
    "log10_modulus_pa": (4.0, 7.0), "dissipation_s_per_m": (0.0, 20.0),
}
HYDRO_PARAMS = ("couple_stiffness_factor", "couple_damping_factor")


def law_params(form: str) -> tuple[str, ...]:
    """The injected model's fitted parameters for a steer-law form."""
    if form not in STEER_LAW_FORMS:
        raise ValueError(f"form: unknown value {form!r}; allowed: {list(STEER_LAW_FORMS)}")
    return ("omega_n", "zeta", "rest_angle_rad", *STEER_LAW_FORMS[form])


def _start(name: str, base: ShellCalibration, p0: float, robot: RobotParameters) -> float:
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
    defaults = {"amplitude_stiffness_nm_per_rad": 0.0, "amplitude_scale_rad": 0.2, "quadratic_stiffness_nm_per_rad2": 0.0}
    return float(getattr(law, name)) if law.form != "linear" or name == "rest_angle_rad" else defaults[name]


def calibration_with(base: ShellCalibration, p0: float, values: Mapping[str, float], form: str | None = None,
                     robot: RobotParameters | None = None) -> dict[str, Any]:
    """``base`` as a mapping with the named fitted values set at p₀ (see :func:`fit_shell` for names)."""
    raw = calibration_at(base, p0, omega_n=values.get("omega_n"), zeta=values.get("zeta"),
                         modulus_pa=10 ** values["log10_modulus_pa"] if "log10_modulus_pa" in values else None,
                         dissipation_s_per_m=values.get("dissipation_s_per_m"), robot=robot)
    raw["nominal_pressure_kpa"] = float(p0)
    if form is not None or any(k in values for k in ("rest_angle_rad", *sum(STEER_LAW_FORMS.values(), ()))):
        law = dict(base.steer_law.as_dict())
        if form is not None and form != law["form"]:
            law = {"form": form, "rest_angle_rad": law["rest_angle_rad"]}
        for k in ("rest_angle_rad", *STEER_LAW_FORMS[law["form"]]):
            if k in values:
                law[k] = float(values[k])
            law.setdefault(k, _start(k, base, p0, robot or RobotParameters.from_urdf()))
        raw["steer_law"] = law
    hyd = dict(raw["hydroelastic"])
    for k in HYDRO_PARAMS:
        if k in values:
            hyd[k] = float(values[k])
    raw["hydroelastic"] = hyd
    return raw


def omega_n_floor(base: ShellCalibration, p0: float, robot: RobotParameters, margin: float = 0.9) -> float:
    """The least ω_n(p₀) [rad/s] whose linear stiffness stays stable at the reach of φ at every pressure.

    Every form's extra stiffness vanishes (saturating) or may be negative (softening quadratic) at
    large |φ|, so the linear part alone must keep K_inject(p) + K_g cos φ_max > 0 over the range, with
    K_g the free-pendulum gravity stiffness; ``margin`` < 1 keeps a little positive stiffness there.
    The slope of ω_n(p) carries p₀ to the weakest end of the range.
    """
    from sphere_env.models.shell import PHI_REACH_RAD, gravity_stiffness_free_pendulum

    k_min = -margin * gravity_stiffness_free_pendulum(robot) * math.cos(PHI_REACH_RAD)
    w_min = math.sqrt(max(robot.K_eq + k_min, 0.0) / robot.M_eq)
    lo, hi = base.pressure_range_kpa
    return w_min + max(base.omega_n_slope * (p0 - lo), base.omega_n_slope * (p0 - hi), 0.0)


def unidentified(values: Mapping[str, float], ci95: Mapping[str, tuple[float, float]],
                 bounds: Mapping[str, tuple[float, float]], at_bound_frac: float = 1e-3) -> dict[str, str]:
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


def _moving(log: RobotLog, min_swing_rad: float = 0.02) -> bool:
    return float(np.ptp(log["phi"])) >= min_swing_rad or float(np.ptp(log["theta"])) >= min_swing_rad


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
) -> ShellFit:
    """Fit the shell ``model`` at p₀ = ``pressure_kpa`` to free-motion segments (``steer_plane`` or ``free``).

    Residuals are φ and θ errors [rad] of every log (θ times ``theta_weight``: the pendulum angle
    also depends on steer friction, which this fit does not touch), each log weighted by its length:
    every sample counts the same, so a window's say in the fit grows with how much of the motion it
    records, and the cost is the mean square error over all samples. Parameters:
    ``injected``: :func:`law_params` of ``form`` (default: the base calibration's form);
    ``hydroelastic``: :data:`HYDRO_PARAMS` (the steer couple's factors) unless ``params`` names
    others (``log10_modulus_pa``, ``dissipation_s_per_m``). ``fixed_injected``: ω_n, ζ at p₀ held
    while fitting hydroelastic parameters (default the base calibration's).

    Refuses (:class:`FitError`, nothing written) a segment with no free motion, a fit that does
    not converge within ``max_nfev`` evaluations (unless ``require_convergence`` is False), a
    diverged simulation at the optimum, and a result the robot cannot stand still with.
    """
    if model not in ("injected", "hydroelastic"):
        raise ValueError(f"model: value {model!r}; allowed: ['injected', 'hydroelastic']")
    if not logs:
        raise FitError("fit_shell: no segments to fit on")
    for log in logs:
        for ch in ("phi", "theta"):
            if not log.has(ch):
                raise FitError(f"log {log.path!r}: trial {log.name!r} needs a {ch} channel for a shell fit")
        if log.fixture not in ("steer_plane", "free"):
            raise FitError(f"log {log.path!r}: trial {log.name!r} has fixture {log.fixture!r}; "
                           "a shell fit needs 'steer_plane' or 'free' segments")
        if not _moving(log):
            raise FitError(f"log {log.path!r}: trial {log.name!r}: no free motion to fit (phi and theta move "
                           f"less than 0.02 rad over {log.t_s[-1]:.2f} s)")
    base = base or ShellCalibration.load()
    robot = RobotParameters.from_urdf()
    p0 = base.check_pressure(pressure_kpa)
    form = form or base.steer_law.form
    if params is None:
        params = law_params(form) if model == "injected" else HYDRO_PARAMS
    names = list(params)
    for n in names:
        if n not in _BOUNDS:
            raise ValueError(f"params: unknown value {n!r}; allowed: {sorted(_BOUNDS)}")
    fixed = dict(fixed_injected or {}) if model == "hydroelastic" else {}
    lo = np.array([_BOUNDS[n][0] for n in names])
    hi = np.array([_BOUNDS[n][1] for n in names])
    if "omega_n" in names:  # keep the search where the robot can stand (see omega_n_floor)
        i = names.index("omega_n")
        lo[i] = max(lo[i], omega_n_floor(base, p0, robot))
    x0 = np.clip([float((start or {}).get(n, _start(n, base, p0, robot))) for n in names], lo, hi)
    if pool is None:
        pool = TwinPool(model, steer_friction, time_step_s, drive_friction)
        if twin is not None:
            pool.twins[twin.config.fixture] = twin

    def cal_for(x) -> ShellCalibration:
        vals = dict(fixed, **dict(zip(names, map(float, x))))
        raw = calibration_with(base, p0, vals, form if model == "injected" else None, robot)
        return ShellCalibration.from_dict(raw, source="<fit>", check_stand_still=False)

    n_res = sum(2 * len(log.t_s) for log in logs)
    w = 1.0 / math.sqrt(n_res)  # one weight for every sample: each log weighs by its length

    def residuals(x) -> np.ndarray:
        try:
            cal = cal_for(x)
        except ValueError:  # curves leave their valid range somewhere in p (e.g. ζ ≥ 1): a 1 rad error
            return np.full(n_res, 1.0 / math.sqrt(n_res))
        pool.install(cal, p0)
        parts = []
        for log in logs:
            tr = simulate_log(pool.get(log.fixture), log)
            parts += [w * (tr["phi"] - log["phi"]), theta_weight * w * (tr["theta"] - log["theta"])]
        return np.concatenate(parts)

    res = least_squares(residuals, x0, bounds=(lo, hi), diff_step=1e-3, x_scale="jac", max_nfev=max_nfev,
                        xtol=1e-6, ftol=1e-8)
    where = f"shell fit of {model!r} (form {form!r}) on {[log.name for log in logs]}"
    if require_convergence and res.status <= 0:
        raise FitError(f"{where}: did not converge after {res.nfev} evaluations ({res.message}); "
                       "raise max_nfev, start closer or fit fewer parameters. Nothing written.")
    if not np.all(np.isfinite(res.x)) or not np.isfinite(res.cost):
        raise FitError(f"{where}: the optimum is not finite ({res.x}). Nothing written.")
    cal = cal_for(res.x)
    raw = dict(cal.raw)
    try:
        ShellCalibration.from_dict(raw, source=f"<{where}>")  # the stand-still check, naming the field
    except ValueError as err:
        raise FitError(f"{where}: refused: {err}. Nothing written.") from err
    pool.install(cal, p0)
    per = {}
    for log in logs:
        tr = simulate_log(pool.get(log.fixture), log)
        if tr.diverged:
            raise FitError(f"{where}: the twin diverged on {log.name!r} at the optimum. Nothing written.")
        per[log.name] = {"phi": rmse(tr["phi"], log["phi"]), "theta": rmse(tr["theta"], log["theta"])}
    J = res.jac
    dof = max(J.shape[0] - J.shape[1], 1)
    try:
        cov = np.linalg.pinv(J.T @ J) * (2 * res.cost / dof)
        std = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        std = np.full(len(names), np.nan)
    ci = {k: (float(v - 1.96 * s), float(v + 1.96 * s)) for k, v, s in zip(names, res.x, std)}
    values = {k: float(v) for k, v in zip(names, res.x)}
    poor = unidentified(values, ci, {k: (float(a), float(b)) for k, a, b in zip(names, lo, hi)})
    if "log10_modulus_pa" in values:
        values["modulus_pa"] = 10 ** values["log10_modulus_pa"]
        ci["modulus_pa"] = tuple(10 ** c for c in ci["log10_modulus_pa"])
    if "dissipation_s_per_m" in values:
        values["k_d"] = float(raw["hydroelastic"]["k_d"])
    K, C = cal.bind(robot).injected_gains(p0)
    values.update(K_inject=K, C_inject=C)
    return ShellFit(model, p0, values, per, raw, ci, form if model == "injected" else cal.steer_law.form, res.nfev,
                    poor)


def window(log: RobotLog, start_s: float, end_s: float, name: str | None = None) -> RobotLog:
    """The samples of ``log`` in [start_s, end_s] [s] as a log whose time restarts at 0."""
    keep = (log.t_s >= start_s - 1e-9) & (log.t_s <= end_s + 1e-9)
    if keep.sum() < 3:
        raise FitError(f"log {log.path!r}: window [{start_s}, {end_s}] s of {log.name!r} has fewer than 3 samples")
    t = log.t_s[keep]
    return dataclasses.replace(log, name=name or f"{log.name}[{start_s:g}:{end_s:g}]", t_s=t - t[0],
                               channels={k: v[keep] for k, v in log.channels.items()}, meta=dict(log.meta))


def cross_validate(
    logs: Sequence[RobotLog],
    forms: Sequence[str],
    pressure_kpa: float,
    base: ShellCalibration | None = None,
    steer_friction: FrictionModel | str = "majd_steer",
    max_nfev: int = 40,
    blocks: int = 3,
    models: Sequence[str] = ("injected",),
    drive_friction: FrictionModel | str = "majd_drive",
    workers: int | None = 1,
) -> list[dict[str, Any]]:
    """Held-out φ/θ RMSE [rad] of each steer-law form for each shell model in ``models``.

    Two or more segments: leave one segment out, fit on the others, test on it. One segment: cut it
    into ``blocks`` consecutive blocks, each replayed from the logged state at its start; leave one
    block out, fit on the others, test on it (blocked cross-validation: every amplitude of the decay
    is once held out, and no form is judged only on extrapolation from large swings to small ones).
    Within a fold the models are fitted in order, each on top of the previous one's fit as
    :func:`steer_fit` does (``hydroelastic`` after ``injected`` keeps the fold's injected law), so
    nothing of the held-out segment reaches any fit. The (form, fold) fits run on ``workers``
    processes (:func:`~sphere_env.parallel.run_parallel`; 1: in this process).
    Returns one row per (model, form, fold) with the held-out RMSE and the fit; a fold whose fit is
    refused (e.g. a law the robot cannot stand still with) gets RMSE ``inf`` and the reason under
    ``refused``, so that form is never chosen.
    """
    from sphere_env.parallel import run_parallel

    base = base or ShellCalibration.load()
    if len(logs) >= 2:
        folds = [([lg for j, lg in enumerate(logs) if j != i], [logs[i]]) for i in range(len(logs))]
    else:
        (lg,) = logs
        edges = np.linspace(0.0, float(lg.t_s[-1]), blocks + 1)
        parts = [window(lg, a, b, f"{lg.name}[{a:.2f}-{b:.2f} s]") for a, b in zip(edges[:-1], edges[1:])]
        folds = [([p for j, p in enumerate(parts) if j != i], [parts[i]]) for i in range(blocks)]
    jobs = [{"train": train, "test": test, "form": form, "models": tuple(models), "base": dict(base.raw),
             "source": base.source, "pressure_kpa": pressure_kpa, "steer_friction": steer_friction,
             "drive_friction": drive_friction, "max_nfev": max_nfev} for form in forms for train, test in folds]
    return [row for rows in run_parallel(_fold_job, jobs, workers=workers) for row in rows]


def _fold_job(job: Mapping[str, Any]) -> list[dict[str, Any]]:
    """One (form, fold) of :func:`cross_validate`: fit its models in order on the training segments
    (twins built here: Drake diagrams never cross processes) and score the held-out ones."""
    train, test, form, models, p0 = job["train"], job["test"], job["form"], job["models"], job["pressure_kpa"]
    cur = ShellCalibration.from_dict(job["base"], source=job["source"])
    rows: list[dict[str, Any]] = []
    for i, model in enumerate(models):
        where = {"model": model, "form": form, "fit_on": [t.name for t in train]}
        pool = TwinPool(model, job["steer_friction"], drive_friction=job["drive_friction"])
        try:
            fit = fit_shell(train, model, p0, steer_friction=job["steer_friction"], base=cur,
                            form=form if model == "injected" else None, max_nfev=job["max_nfev"], pool=pool,
                            require_convergence=False, drive_friction=job["drive_friction"])
        except FitError as err:  # this model and every one fitted on top of it are refused
            return rows + [dict(where, model=m, test=lg.name, rmse_phi_rad=math.inf, rmse_theta_rad=math.inf,
                                refused=str(err)) for m in models[i:] for lg in test]
        cur = ShellCalibration.from_dict(fit.calibration, source="<cv>")
        pool.install(cur, p0)
        for name, r in trial_rmse(pool, test).items():
            rows.append(dict(where, test=name, rmse_phi_rad=r["phi"], rmse_theta_rad=r["theta"],
                             train_rmse_rad=fit.rmse, params=fit.params))
    return rows


def choose_form(rows: Sequence[Mapping[str, Any]]) -> tuple[str, dict[str, float]]:
    """The form with the least mean held-out φ RMSE (ties: fewer parameters, i.e. earlier in the list)."""
    mean: dict[str, float] = {}
    for form in dict.fromkeys(r["form"] for r in rows):
        mean[form] = float(np.mean([r["rmse_phi_rad"] for r in rows if r["form"] == form]))
    best = min(mean, key=lambda f: (round(mean[f], 4), list(STEER_LAW_FORMS).index(f)))
    if not math.isfinite(mean[best]):
        raise FitError(f"no steer-law form could be fitted: {[r.get('refused') for r in rows]}")
    return best, mean


def steer_fit(
    logs: Sequence[RobotLog],
    models: Sequence[str],
    pressure_kpa: float,
    base: ShellCalibration,
    forms: Sequence[str] = tuple(STEER_LAW_FORMS),
    steer_friction: FrictionModel | str = "majd_steer",
    drive_friction: FrictionModel | str = "majd_drive",
    max_nfev: int = 60,
    log_to=None,
    hold_out_windows: bool = True,
    workers: int | None = 1,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """What ``steer-fit`` does: fit each shell model in ``models`` on ``logs``, in order, each on top of
    the previous one's calibration (``hydroelastic`` after ``injected`` keeps the injected ω_n, ζ and
    steer law just fitted). With several ``forms`` and ``injected`` among the models, the steer-law
    form is the one with the least held-out φ RMSE (:func:`cross_validate`, :func:`choose_form`) —
    never the training error. With two or more ``logs`` and ``hold_out_windows``, every model is
    then cross-validated leave-one-window-out with the chosen form (:func:`cross_validate`; the
    injected rows of the form choice are reused when injected is the only model, and are then
    slightly optimistic: the form was picked on them). Returns (calibration mapping, record of the
    fit: per model its parameters, 95 % intervals and ``unidentified`` ones; under
    ``leave_one_window_out`` each window's held-out RMSE); ``log_to`` (e.g. ``print``) receives a
    readable account. ``workers``: processes for the cross-validation folds.
    """
    say = log_to or (lambda *_: None)
    record: dict[str, Any] = {"fit_on": [log.name for log in logs], "pressure_kpa": pressure_kpa, "models": {}}
    form = forms[0]
    form_rows: list[dict[str, Any]] = []
    if "injected" in models and len(forms) > 1:
        form_rows = cross_validate(logs, forms, pressure_kpa, base=base, steer_friction=steer_friction,
                                   max_nfev=max_nfev, drive_friction=drive_friction, workers=workers)
        form, mean = choose_form(form_rows)
        say("steer-law form by held-out error (fit on -> test: RMSE phi / theta rad):")
        for r in form_rows:
            say(f"  {r['form']:10s} {'+'.join(r['fit_on'])} -> {r['test']}: "
                f"{r['rmse_phi_rad']:.4f} / {r['rmse_theta_rad']:.4f}")
        say(f"  mean held-out phi: { {k: round(v, 4) for k, v in mean.items()} } -> form {form!r}")
        record["form_cross_validation"] = [_cv_row(r) for r in form_rows]
    raw = dict(base.raw)
    for model in models:
        cur = ShellCalibration.from_dict(raw, source=base.source)
        pool = TwinPool(model, steer_friction, drive_friction=drive_friction)
        fit = fit_shell(logs, model, pressure_kpa, steer_friction=steer_friction, base=cur, pool=pool,
                        form=form if model == "injected" else None, max_nfev=max_nfev,
                        drive_friction=drive_friction)
        raw = fit.calibration
        say(f"{model} (form {fit.form!r}) at {pressure_kpa} kPa fitted on {record['fit_on']} in {fit.nfev} evaluations:")
        for k, v in fit.params.items():
            ci = fit.ci95.get(k)
            say(f"  {k} = {v:.5g}" + (f"  95% CI [{ci[0]:.5g}, {ci[1]:.5g}]" if ci else "")
                + (f"  UNIDENTIFIED: {fit.unidentified[k]}" if k in fit.unidentified else ""))
        record["models"][model] = dict(fit.as_dict(), pool=pool)
    if hold_out_windows and len(logs) >= 2:
        if tuple(models) == ("injected",) and form_rows:
            rows = [r for r in form_rows if r["form"] == form]
        else:
            rows = cross_validate(logs, [form], pressure_kpa, base=base, steer_friction=steer_friction,
                                  max_nfev=max_nfev, models=models, drive_friction=drive_friction, workers=workers)
        say(f"leave-one-window-out (form {form!r}; fit on the others -> held-out window: RMSE phi / theta rad):")
        for r in rows:
            say(f"  {r['model']:12s} {'+'.join(r['fit_on'])} -> {r['test']}: "
                f"{r['rmse_phi_rad']:.4f} / {r['rmse_theta_rad']:.4f}" + (" (refused)" if r.get("refused") else ""))
        record["leave_one_window_out"] = [_cv_row(r) for r in rows]
        for model in models:
            record["models"][model]["held_out_rmse_rad"] = {
                r["test"]: {"phi": r["rmse_phi_rad"], "theta": r["rmse_theta_rad"]} for r in rows if r["model"] == model}
    return raw, record


def _cv_row(row: Mapping[str, Any]) -> dict[str, Any]:
    """A cross-validation row as recorded in a calibration file (no fitted mappings, the refusal kept)."""
    return {k: row[k] for k in ("model", "form", "fit_on", "test", "rmse_phi_rad", "rmse_theta_rad", "refused")
            if k in row}
