"""Shell contact laws and the pressure calibration they read (paper §III; docs/design.md).

A :class:`ShellCalibration` holds the measured/assumed pressure curves ω_n(p), ζ(p), V(p), the
valid pressure range, the steer-direction law (form, rest angle φ_0, amplitude term) and the
hydroelastic settings, loaded from one YAML file (``assets/calibration/default.yaml`` by default,
or a user's own). Pressures are gauge pressures in **kPa** at this user-facing boundary.

The steer-direction law and its forms are :mod:`sphere_env.models.steer_law`; where a calibration's
file is and how a parameter set names it, :mod:`sphere_env.models.calibration_files`.
:meth:`ShellCalibration.bind` evaluates a calibration for one robot (:class:`BoundShell`): injected gains, hydroelastic modulus
and dissipation, and the gain vector of the shell couple.

Calibration file, steer-law section (optional; absent = linear about φ = 0, the paper's eq. 9)::

    steer_law: {form: linear | saturating | quadratic, rest_angle_rad: φ_0,
                amplitude_stiffness_nm_per_rad: K_a, amplitude_scale_rad: φ_a,   # saturating only
                quadratic_stiffness_nm_per_rad2: K_2}                           # quadratic only
    hydroelastic: {..., couple_stiffness_factor: f_K, couple_damping_factor: f_C}  # default 0, 0

Drive-direction section (optional; absent = the paper's: C_drive = C_inject, no spin damping, Table I's
drive friction × 1), with the ``drive_fit`` record of what it applies (:mod:`sphere_env.models.drive_schema`)::

    drive_law: {shell_models: [injected], drive_friction_scale: f, injected_rolling_damping_factor: c,
                spin_damping_nms_per_rad: C_spin}

Hydroelastic mesh (optional ``low_pressure_mesh``; absent = ``resolution_hint_m`` everywhere)::

    hydroelastic: {resolution_hint_m: h, low_pressure_mesh: {below_kpa: p_c, resolution_hint_m: h_low}}

Hunt–Crossley dissipation refitted at other plant steps (optional ``k_d_by_time_step``)::

    hydroelastic: {k_d: k, fitted_time_step_s: dt, k_d_by_time_step: [{time_step_s: dt_2, k_d: k_2}, ...]}

Drake's discrete hydroelastic contact adds numerical damping that grows with the step, so k_d
holds at the step it was fitted at; each entry is k_d refitted at another step
(:meth:`ShellCalibration.for_time_step` picks it, the twin does so for its own step).

Hunt–Crossley dissipation factor against pressure (optional ``k_d_by_pressure``, at the fitted step
or in a ``k_d_by_time_step`` entry for that step)::

    hydroelastic: {k_d: k(p0), k_d_by_pressure: [{pressure_kpa: p_1, k_d: k_1}, ...],
                   k_d_by_time_step: [{time_step_s: dt_2, k_d: k_2(p0), k_d_by_pressure: [...]}, ...]}

With one k_d the hydroelastic decay's damping ratio falls with pressure faster than ζ(p) does
(``evaluation/results/hydro_tradeoff.md``); a table lets k_d follow the pressure. k_d(p) is
interpolated linearly between the points, which must span ``pressure_range_kpa``; the single
``k_d`` beside a table must be the table's value at ``nominal_pressure_kpa`` (so one number still
describes the step, for tools and readers). Without a table k_d is the same at every pressure.

The compliant shell is meshed with ``h_low`` below ``p_c`` and with ``h`` from ``p_c`` up. A soft
shell's contact patch is large (radius ≈ √(f_n / (π p))), so a coarser mesh resolves it as well as
the fine one does at high pressure, at a fraction of the contact polygons (``docs/physics.md``, *Mesh
resolution (hydroelastic)*).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from sphere_env.models.calibration_files import calibration_file
from sphere_env.models.calibration_schema import (
    STEER_LAW_FORMS,
    CalibrationFile,
    check_calibration,
    interpolate_k_d,
    read_calibration_file,
    table_pairs,
)
from sphere_env.models.drive_schema import SOFT_SHELLS, DriveLawSection
from sphere_env.models.steer_law import PHI_REACH_RAD, SteerLaw, gravity_stiffness_free_pendulum, injected_gains
from sphere_env.params import ParameterSpace


def membrane_contact_volume_m3(pressure_kpa: float, weight_n: float, radius_m: float) -> float:
    """Sphere–plane intersection volume V(p) [m³] from a membrane estimate (docs/design.md §5).

    Contact area A = f_n / p gives the flat's radius a = √(A/π); the undeformed sphere would
    penetrate δ = R − √(R² − a²) ≈ a²/(2R); the cap volume is V = π δ² (R − δ/3).
    """
    area = weight_n / (pressure_kpa * 1e3)
    a2 = min(area / math.pi, radius_m**2)
    delta = radius_m - math.sqrt(radius_m**2 - a2)
    return math.pi * delta**2 * (radius_m - delta / 3.0)


@dataclass(frozen=True)
class DriveDirection:
    """A shell model's drive direction: C_drive / C_inject (the injected shell's rolling damper), the
    spin damping C_spin [N m s/rad] about the ground normal, and × the drive joint's friction law."""

    rolling_damping_factor: float = 1.0
    spin_damping_nms_per_rad: float = 0.0
    friction_scale: float = 1.0


@dataclass(frozen=True)
class ShellCalibration:
    """Pressure curves of the shell (paper Fig. 10 form), the steer law and hydroelastic settings.

    ω_n(p) = omega_n_intercept + omega_n_slope · p       [rad/s], p in kPa (linear, Fig. 10)
    ζ(p)   = zeta_scale · exp(zeta_rate · p)             [-]                 (exponential, Fig. 10)
    V(p)   = membrane estimate, or a table interpolated in p                [m³]
    steer law (section ``steer_law``, optional, default linear about φ_0 = 0): the spring's form,
    rest angle and amplitude term (:class:`SteerLaw`); K_inject(p), C_inject(p) from ω_n, ζ.
    hydroelastic couple: ``hydroelastic.couple_stiffness_factor`` / ``couple_damping_factor``
    (default 0: no couple) scale the injected steer-direction couple that the hydroelastic model
    carries on top of Drake's hydroelastic contact (the sphere itself has no restoring moment).

    Use :meth:`bind` to evaluate the laws for one robot.
    """

    pressure_range_kpa: tuple[float, float]
    nominal_pressure_kpa: float
    omega_n_intercept: float
    omega_n_slope: float
    zeta_scale: float
    zeta_rate: float
    volume_model: str
    volume_table: tuple[tuple[float, ...], tuple[float, ...]] | None
    k_d: float
    resolution_hint_m: float
    fitted_time_step_s: float | None
    source: str
    raw: Mapping[str, Any]
    steer_law: SteerLaw = SteerLaw()
    couple_stiffness_factor: float = 0.0
    couple_damping_factor: float = 0.0
    #: Drive direction (section ``drive_law``): C_drive = factor × C_inject for the injected shell,
    #: the couple −C_spin (ω_shell·n̂) n̂ [N m s/rad] against spinning about the ground normal, and
    #: × the drive joint's friction law, for the shell models ``drive_law_models``
    #: (:meth:`drive_law_of`; the others keep the paper's drive direction).
    injected_rolling_damping_factor: float = 1.0
    spin_damping_nms_per_rad: float = 0.0
    drive_friction_scale: float = 1.0
    drive_law_models: tuple[str, ...] = SOFT_SHELLS
    stand_still_checked: bool = True
    #: (below_kpa, resolution_hint_m) of the optional low-pressure mesh, or None.
    low_pressure_mesh: tuple[float, float] | None = None
    #: ((time step [s], k_d), ...) refitted at steps other than ``fitted_time_step_s``.
    k_d_by_time_step: tuple[tuple[float, float], ...] = ()
    #: ((pressure [kPa], k_d), ...) in force at ``fitted_time_step_s``, or () for one k_d at every pressure.
    k_d_by_pressure: tuple[tuple[float, float], ...] = ()
    #: ((time step [s], k_d_by_pressure table), ...) of the ``k_d_by_time_step`` entries that have one.
    k_d_by_pressure_at_steps: tuple[tuple[float, tuple[tuple[float, float], ...]], ...] = ()
    #: The range the laws were calibrated on [kPa] when :meth:`extrapolated` widened
    #: ``pressure_range_kpa``; None = not widened.
    calibrated_range_kpa: tuple[float, float] | None = None

    # ---- loading ---------------------------------------------------------------------------------
    @classmethod
    def load(cls, path: str | Path | None = None) -> "ShellCalibration":
        path = calibration_file(path)
        data, spec = read_calibration_file(path)
        return cls.from_schema(spec, data, str(path))

    @classmethod
    def from_dict(cls, data: Any, source: str = "<dict>", check_stand_still: bool = True) -> "ShellCalibration":
        """A calibration mapping, validated by :func:`~sphere_env.models.calibration_schema.check_calibration`
        (``ValueError`` naming file and field). Unless ``check_stand_still`` is False, a steer law
        that leaves the robot unable to stand still on flat ground is refused too
        (:meth:`check_stand_still`)."""
        return cls.from_schema(check_calibration(data, source), data, source, check_stand_still)

    @classmethod
    def from_schema(
        cls, spec: CalibrationFile, data: Mapping[str, Any], source: str, check_stand_still: bool = True
    ) -> "ShellCalibration":
        """The calibration of a validated file (``data``: the mapping as written, kept as ``raw``)."""
        hyd, vol, drive = spec.hydroelastic, spec.contact_volume, spec.drive_law or DriveLawSection()
        mesh = hyd.low_pressure_mesh
        steps = hyd.k_d_by_time_step or ()
        cal = cls(
            pressure_range_kpa=tuple(spec.pressure_range_kpa),
            nominal_pressure_kpa=spec.nominal_kpa,
            omega_n_intercept=spec.omega_n.intercept_rad_s,
            omega_n_slope=spec.omega_n.slope_rad_s_per_kpa,
            zeta_scale=spec.zeta.scale,
            zeta_rate=spec.zeta.rate_per_kpa,
            volume_model=vol.model,
            volume_table=(tuple(vol.pressure_kpa), tuple(vol.volume_m3)) if vol.model == "table" else None,
            k_d=hyd.k_d,
            resolution_hint_m=hyd.resolution_hint_m,
            fitted_time_step_s=hyd.fitted_time_step_s,
            source=source,
            raw=dict(data),
            steer_law=SteerLaw() if spec.steer_law is None else SteerLaw(**spec.steer_law.parameters()),
            couple_stiffness_factor=hyd.couple_stiffness_factor,
            couple_damping_factor=hyd.couple_damping_factor,
            injected_rolling_damping_factor=drive.injected_rolling_damping_factor,
            spin_damping_nms_per_rad=drive.spin_damping_nms_per_rad,
            drive_friction_scale=drive.drive_friction_scale,
            drive_law_models=tuple(drive.shell_models),
            stand_still_checked=check_stand_still,
            low_pressure_mesh=None if mesh is None else (mesh.below_kpa, mesh.resolution_hint_m),
            k_d_by_time_step=tuple((e.time_step_s, e.k_d) for e in steps),
            k_d_by_pressure=table_pairs(hyd.k_d_by_pressure),
            k_d_by_pressure_at_steps=tuple(
                (e.time_step_s, table_pairs(e.k_d_by_pressure)) for e in steps if e.k_d_by_pressure
            ),
        )
        if check_stand_still:
            cal.check_stand_still(_default_robot())
        return cal

    def extrapolated(self, margin_kpa: float) -> "ShellCalibration":
        """This calibration accepting pressures up to ``margin_kpa`` outside the range it was
        calibrated on (gauge pressure at least :data:`MIN_EXTRAPOLATED_KPA`); itself for a margin of
        0. The laws are analytic in p (ω_n linear, ζ exponential, the membrane contact volume);
        tables (``contact_volume`` and ``k_d_by_pressure``) hold their end values. The stand-still
        check runs again at the widened ends, so a margin that would let the robot tip over is
        refused when the calibration is bound."""
        if margin_kpa <= 0.0:
            return self
        lo, hi = self.calibrated_range_kpa or self.pressure_range_kpa
        return replace(
            self,
            pressure_range_kpa=(max(lo - margin_kpa, MIN_EXTRAPOLATED_KPA), hi + margin_kpa),
            calibrated_range_kpa=(lo, hi),
        )

    def drive_law_of(self, shell_model: str) -> DriveDirection:
        """The drive direction ``shell_model`` has under this calibration: the ``drive_law``
        section's values if it applies to the model, else the paper's (factor 1, no spin damping,
        the friction law × 1)."""
        if shell_model not in self.drive_law_models:
            return DriveDirection()
        return DriveDirection(
            self.injected_rolling_damping_factor if shell_model == "injected" else 1.0,
            0.0 if shell_model == "point" else self.spin_damping_nms_per_rad,
            self.drive_friction_scale,
        )

    def without_drive_law(self) -> "ShellCalibration":
        """This calibration with the paper's drive direction for every shell model: its ``drive_law``
        section dropped, also from ``raw`` with the ``drive_fit`` record of what it applied. What the
        envs registered before the drive fit use."""
        if not {"drive_law", "drive_fit"} & set(self.raw) and self.drive_law_of("injected") == DriveDirection():
            return self
        raw = {k: v for k, v in self.raw.items() if k not in ("drive_law", "drive_fit")}
        return replace(
            self,
            raw=raw,
            injected_rolling_damping_factor=1.0,
            spin_damping_nms_per_rad=0.0,
            drive_friction_scale=1.0,
            drive_law_models=SOFT_SHELLS,
        )

    # ---- parameters ------------------------------------------------------------------------------
    def parameter_space(self) -> ParameterSpace:
        """The parameter registry resolved against this calibration: the pressure's nominal value
        and bounds are ``nominal_pressure_kpa`` and ``pressure_range_kpa`` (its errors quote
        ``source``); every other parameter as registered (:class:`~sphere_env.params.ParameterSpace`)."""
        lo, hi = self.pressure_range_kpa
        return ParameterSpace.for_calibration(lo, hi, self.nominal_pressure_kpa, self.source)

    def check_pressure(self, pressure_kpa: float, field: str = "field 'pressure_kpa'") -> float:
        """``pressure_kpa`` as a float if it is a finite number inside the calibrated range, else a
        ValueError naming ``field`` (where the value was given), the value and the range: the
        pressure's check in :meth:`parameter_space`, for callers that check one pressure."""
        return self.parameter_space().check("pressure_kpa", pressure_kpa, field)

    # ---- curves ----------------------------------------------------------------------------------

    def omega_n(self, pressure_kpa):
        """Locked-steer natural frequency ω_n(p) [rad/s]."""
        return self.omega_n_intercept + self.omega_n_slope * np.asarray(pressure_kpa, dtype=float)

    def zeta(self, pressure_kpa):
        """Locked-steer damping ratio ζ(p) [-]."""
        return self.zeta_scale * np.exp(self.zeta_rate * np.asarray(pressure_kpa, dtype=float))

    def k_d_at(self, pressure_kpa: float) -> float:
        """Hunt–Crossley dissipation factor k_d [-] at pressure p: ``k_d_by_pressure`` interpolated
        linearly in pressure if the calibration has one for its step, else ``k_d``."""
        if not self.k_d_by_pressure:
            return self.k_d
        return interpolate_k_d(self.k_d_by_pressure, pressure_kpa)

    def for_time_step(self, time_step_s: float) -> ShellCalibration:
        """This calibration with the k_d refitted at ``time_step_s`` (``k_d_by_time_step``, with its
        ``k_d_by_pressure`` if it has one) in force and ``fitted_time_step_s`` set to that step;
        itself when the step is ``fitted_time_step_s`` or has no refit."""
        fitted = self.fitted_time_step_s
        if fitted is not None and math.isclose(fitted, time_step_s, rel_tol=1e-9):
            return self
        for step, k_d in self.k_d_by_time_step:
            if math.isclose(step, time_step_s, rel_tol=1e-9):
                # the fitted step's k_d (and its pressure table) moves into the list, so the result is a
                # calibration as valid (and as reversible) as this one, raw mapping included
                tables = dict(self.k_d_by_pressure_at_steps)
                table = tables.pop(step, ())
                others = [(s, k) for s, k in self.k_d_by_time_step if s != step]
                if fitted is not None:
                    others.append((fitted, self.k_d))
                    if self.k_d_by_pressure:
                        tables[fitted] = self.k_d_by_pressure
                entries = [
                    dict(
                        {"time_step_s": s, "k_d": k},
                        **({"k_d_by_pressure": _table_raw(tables[s])} if s in tables else {}),
                    )
                    for s, k in others
                ]
                hyd = {key: v for key, v in self.raw["hydroelastic"].items() if key != "k_d_by_pressure"}
                hyd.update(k_d=k_d, fitted_time_step_s=step, k_d_by_time_step=entries)
                if table:
                    hyd["k_d_by_pressure"] = _table_raw(table)
                return replace(
                    self,
                    k_d=k_d,
                    fitted_time_step_s=step,
                    k_d_by_time_step=tuple(others),
                    k_d_by_pressure=table,
                    k_d_by_pressure_at_steps=tuple(tables.items()),
                    raw=dict(self.raw, hydroelastic=hyd),
                )
        return self

    def resolution_hint_at(self, pressure_kpa: float) -> float:
        """Hydroelastic mesh resolution hint [m] at pressure p: ``low_pressure_mesh``'s below its
        ``below_kpa``, else ``resolution_hint_m``."""
        low = self.low_pressure_mesh
        if low is not None and float(pressure_kpa) < low[0]:
            return low[1]
        return self.resolution_hint_m

    def volume_m3(self, pressure_kpa: float, weight_n: float, radius_m: float) -> float:
        """Sphere–plane intersection volume V(p) [m³]."""
        if self.volume_model == "table":
            pk, vm = self.volume_table
            return float(np.interp(pressure_kpa, pk, vm))
        return membrane_contact_volume_m3(pressure_kpa, weight_n, radius_m)

    # ---- stability -------------------------------------------------------------------------------
    def check_stand_still(self, robot) -> None:
        """Refuse a steer law under which the robot cannot stand still on flat ground.

        The total rocking stiffness K_g cos φ + ∂(−τ_φ)/∂φ, with K_g the free-pendulum gravity
        stiffness (:func:`gravity_stiffness_free_pendulum`, the least the robot has), must stay
        positive for |φ| ≤ :data:`PHI_REACH_RAD` at both ends of the pressure range, for the
        injected law and for the hydroelastic couple. Then the restoring moment grows
        monotonically with φ: one rest pose, and no angle the robot can reach tips it over.
        """
        phi = np.linspace(-PHI_REACH_RAD, PHI_REACH_RAD, 481)
        k_g = gravity_stiffness_free_pendulum(robot) * np.cos(phi)
        law = self.steer_law
        for p in (*self.pressure_range_kpa, self.nominal_pressure_kpa):
            K, _ = injected_gains(float(self.omega_n(p)), float(self.zeta(p)), robot.M_eq, robot.K_eq)
            cases = [("injected", 1.0)]
            if self.couple_stiffness_factor > 0:
                cases.append(("hydroelastic", self.couple_stiffness_factor))
            for model, factor in cases:
                total = k_g + factor * law.stiffness(phi, K)
                if total.min() > 0:
                    continue
                j = int(np.argmin(total))
                linear_ok = (k_g + factor * K).min() > 0
                if not linear_ok:
                    field = "omega_n" if model == "injected" else "hydroelastic.couple_stiffness_factor"
                else:
                    field = "steer_law." + (STEER_LAW_FORMS[law.form] or ("form",))[0]
                raise ValueError(
                    f"calibration file {self.source!r}: field '{field}': the robot cannot stand still on flat "
                    f"ground ({model} model at {p:g} kPa): total rocking stiffness {total[j]:.3g} N m/rad <= 0 at "
                    f"phi = {phi[j]:+.2f} rad (K_inject = {K:.3g} N m/rad, form {law.form!r}); it must stay > 0 "
                    f"for |phi| <= {PHI_REACH_RAD} rad"
                    + (
                        f"; omega_n({p:g} kPa) = {float(self.omega_n(p)):.3g} rad/s is below the point-contact "
                        f"{math.sqrt(robot.K_eq / robot.M_eq):.3g} rad/s (omega_n is in rad/s: a value in Hz is "
                        "2π too small)"
                        if K < 0 and field == "omega_n"
                        else ""
                    )
                )

    def bind(self, robot) -> "BoundShell":
        """This calibration evaluated for one robot (:class:`BoundShell`); checks it can stand still
        (unless it was built with ``check_stand_still=False``: a fitter's trial candidate)."""
        if self.stand_still_checked:
            self.check_stand_still(robot)
        return BoundShell(self, robot)


class BoundShell:
    """A :class:`ShellCalibration` bound to one robot's eq. 4 equivalents and weight.

    Every shell law of the twin is read from here: injected gains (eqs. 7–8), the hydroelastic
    modulus and dissipation (eqs. 10–11, memoized per pressure) and the steer-law gain vector the
    force system reads (:meth:`law_gains`).
    """

    def __init__(self, calibration: ShellCalibration, robot):
        self.calibration, self.robot = calibration, robot
        self._hydro: dict[float, tuple[float, float]] = {}

    def injected_gains(self, pressure_kpa: float) -> tuple[float, float]:
        """(K_inject [N m/rad], C_inject [N m s/rad]) at pressure p (eqs. 7–8)."""
        cal, r = self.calibration, self.robot
        return injected_gains(float(cal.omega_n(pressure_kpa)), float(cal.zeta(pressure_kpa)), r.M_eq, r.K_eq)

    def hydroelastic(self, pressure_kpa: float) -> tuple[float, float]:
        """(modulus [Pa], Hunt–Crossley dissipation [s/m]) at pressure p.

        m_hydro = f_n / V(p) (eq. 10);  d = k_d(p) · C_inject(p) (eq. 11 with the §III.D factor k_d,
        which is one number unless the calibration has ``k_d_by_pressure``).
        C_inject is used by number as the dissipation in s/m, as the paper does.
        """
        key = float(pressure_kpa)
        out = self._hydro.get(key)
        if out is None:
            r, cal = self.robot, self.calibration
            modulus = r.weight_n / cal.volume_m3(key, r.weight_n, r.radius_m)
            out = (modulus, cal.k_d_at(key) * self.injected_gains(key)[1])
            self._hydro[key] = out
        return out

    def law_gains(self, shell_model: str, pressure_kpa: float) -> np.ndarray:
        """The shell couple's numbers in :data:`LAW_GAIN_NAMES` order for ``shell_model``.

        ``injected``: the full law (steer spring + damper, drive damper). ``hydroelastic``: the steer
        spring and damper scaled by the couple factors, no drive damper (the contact's dissipation
        damps rolling). ``point``: zeros (the rigid baseline).
        """
        K, C = self.injected_gains(pressure_kpa)
        rest, A, B, Q = self.calibration.steer_law.gains_tail()
        if shell_model == "injected":
            factor = self.calibration.drive_law_of("injected").rolling_damping_factor
            return np.array([K, C, factor * C, rest, A, B, Q])
        if shell_model == "hydroelastic":
            fk, fc = self.calibration.couple_stiffness_factor, self.calibration.couple_damping_factor
            return np.array([fk * K, fc * C, 0.0, rest, fk * A, B, fk * Q])
        return np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0])

    def parameters(self, shell_model: str, pressure_kpa: float) -> dict[str, Any]:
        """The shell model's parameters at a pressure, units in the keys."""
        cal = self.calibration
        K, C = self.injected_gains(pressure_kpa)
        out: dict[str, Any] = {
            "pressure_kpa": float(pressure_kpa),
            "omega_n_rad_s": float(cal.omega_n(pressure_kpa)),
            "zeta": float(cal.zeta(pressure_kpa)),
            "K_inject_Nm_per_rad": K,
            "C_inject_Nms_per_rad": C,
            "steer_law": cal.steer_law.as_dict(),
        }
        if shell_model == "hydroelastic":
            m, d = self.hydroelastic(pressure_kpa)
            out.update(
                hydroelastic_modulus_pa=m,
                hunt_crossley_dissipation_s_per_m=d,
                k_d=cal.k_d_at(pressure_kpa),
                resolution_hint_m=cal.resolution_hint_at(pressure_kpa),
                couple_stiffness_factor=cal.couple_stiffness_factor,
                couple_damping_factor=cal.couple_damping_factor,
            )
        return out


@functools.lru_cache(maxsize=1)
def _default_robot():
    from sphere_env.models.rigid_body import RobotParameters

    return RobotParameters.from_urdf()


#: The least gauge pressure an extrapolated calibration accepts [kPa]: a shell below it is barely
#: inflated, and no shell law here was fitted near zero pressure.
MIN_EXTRAPOLATED_KPA = 0.5


def _table_raw(table: tuple[tuple[float, float], ...]) -> list[dict[str, float]]:
    return [{"pressure_kpa": q, "k_d": k} for q, k in table]
