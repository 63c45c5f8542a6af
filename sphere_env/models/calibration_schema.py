"""The shell calibration file's typed schema, and the one place such a file is read.

A calibration file is YAML (``assets/calibration/default.yaml`` is the shipped one; the sections
are described in :mod:`sphere_env.models.shell`). :func:`read_calibration_file` reads it and
:func:`check_calibration` validates a mapping against :class:`CalibrationFile`: unknown keys,
wrong types (a number written as a string, a bool for a number), non-finite numbers and values
outside their ranges are refused with the field's dotted path, its value and what is allowed. The
checks that relate fields (the nominal pressure inside the range, a ``k_d_by_pressure`` table
spanning it, one ``k_d`` per time step, a ``drive_law`` that holds the applied values of the
``drive_fit`` record: :mod:`sphere_env.models.drive_schema`) run in the same validation. What the physics decides, that
the robot can stand still under the steer law, stays with
:meth:`sphere_env.models.shell.ShellCalibration.check_stand_still`.
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path
from typing import Annotated, Any, Callable, Literal, Union

import numpy as np
import yaml
from pydantic import Discriminator, Field, Tag, model_validator

from sphere_env import safe_yaml
from sphere_env.models.drive_schema import DriveFitRecord, DriveLawSection, check_drive_law_is_the_fit
from sphere_env.schemas import Finite, Schema, allowed, checker, number, ordered_pair, validate

#: Gauge pressures [kPa] a calibration may cover: RoboBall runs 3-14 kPa and a fabric/rubber shell
#: does not hold 1 bar (100 kPa) over ambient; a range written in Pa (thousands) or MPa (thousandths)
#: falls outside.
PLAUSIBLE_PRESSURE_KPA = (0.5, 100.0)
#: Contact (sphere–plane intersection) volumes must be below a hemisphere of the 0.305 m shell [m³].
MAX_CONTACT_VOLUME_M3 = 0.06
#: Hydroelastic mesh resolution hint [m]: from 2 mm (a mesh of ~10⁵ facets) to about the shell radius.
RESOLUTION_HINT_RANGE_M = (0.002, 0.3)
#: Plant time step at which k_d was matched [s].
FITTED_TIME_STEP_RANGE_S = (1e-5, 0.1)
#: Relative tolerance between a step's single ``k_d`` and its ``k_d_by_pressure`` at the nominal
#: pressure (files hold 5 significant digits).
K_D_NOMINAL_REL_TOL = 1e-3
#: Parameters of each steer-law form beyond the rest angle φ_0.
STEER_LAW_FORMS: dict[str, tuple[str, ...]] = {
    "linear": (),
    "saturating": ("amplitude_stiffness_nm_per_rad", "amplitude_scale_rad"),
    "quadratic": ("quadratic_stiffness_nm_per_rad2",),
}

_P_LO, _P_HI = PLAUSIBLE_PRESSURE_KPA
_H_LO, _H_HI = RESOLUTION_HINT_RANGE_M
_T_LO, _T_HI = FITTED_TIME_STEP_RANGE_S

NonNegative = number(ge=0.0)
Pressure = Annotated[
    float,
    Field(
        ge=_P_LO,
        le=_P_HI,
        json_schema_extra=allowed(f"a gauge pressure in kPa within [{_P_LO}, {_P_HI}] (Pa or MPa values fall outside)"),
    ),
]
ResolutionHint = Annotated[
    float,
    Field(
        ge=_H_LO,
        le=_H_HI,
        json_schema_extra=allowed(
            f"[{_H_LO}, {_H_HI}] m (a mesh edge length on a shell of radius ~0.3 m; cost: the facets grow as "
            f"1/resolution², about 10⁵ at {_H_LO} m, each meshed at build and at every new pressure)"
        ),
    ),
]
TimeStep = Annotated[
    float, Field(ge=_T_LO, le=_T_HI, json_schema_extra=allowed(f"[{_T_LO}, {_T_HI}] s (a plant time step)"))
]
#: Free-form records a file may carry for readers and tools (confidence intervals, provenance, notes).
Notes = Any


class OmegaN(Schema):
    """ω_n(p) = intercept + slope · p [rad/s]."""

    model: Literal["linear"]
    intercept_rad_s: Finite
    slope_rad_s_per_kpa: Finite
    ci95: Notes = None
    notes: Notes = None


class Zeta(Schema):
    """ζ(p) = scale · exp(rate · p)."""

    model: Literal["exponential"]
    scale: Finite
    rate_per_kpa: Finite
    ci95: Notes = None
    notes: Notes = None


class ContactVolume(Schema):
    """V(p): the membrane estimate, or a table interpolated in p."""

    model: Literal["membrane", "table"]
    pressure_kpa: list[Finite] | None = None
    volume_m3: (
        list[
            Annotated[
                float,
                Field(gt=0.0, lt=MAX_CONTACT_VOLUME_M3, json_schema_extra=allowed(f"(0, {MAX_CONTACT_VOLUME_M3}) m³")),
            ]
        ]
        | None
    ) = None
    notes: Notes = None

    @model_validator(mode="after")
    def _table(self) -> "ContactVolume":
        if self.model != "table":
            return self
        pk, vm = self.pressure_kpa, self.volume_m3
        if pk is None or vm is None or len(pk) != len(vm) or len(pk) < 2 or any(b <= a for a, b in zip(pk, pk[1:])):
            raise ValueError(
                f"field 'pressure_kpa' = {pk!r}, 'volume_m3' = {vm!r}: a table needs increasing "
                "'pressure_kpa' and 'volume_m3' lists of equal length >= 2"
            )
        return self


class KdPoint(Schema):
    """One point of a ``k_d_by_pressure`` table."""

    pressure_kpa: Pressure
    k_d: NonNegative


KdTable = Annotated[
    list[KdPoint],
    Field(
        min_length=2, json_schema_extra=allowed("a list of at least 2 {pressure_kpa, k_d} spanning pressure_range_kpa")
    ),
]


class KdStep(Schema):
    """k_d refitted at another plant step, optionally with its pressure table."""

    time_step_s: TimeStep
    k_d: NonNegative
    k_d_by_pressure: KdTable | None = None


class LowPressureMesh(Schema):
    """A coarser hydroelastic mesh below ``below_kpa``."""

    below_kpa: Finite
    resolution_hint_m: ResolutionHint


class Hydroelastic(Schema):
    """Drake hydroelastic settings and the couple factors."""

    k_d: NonNegative
    resolution_hint_m: ResolutionHint
    low_pressure_mesh: LowPressureMesh | None = None
    fitted_time_step_s: TimeStep | None = None
    k_d_by_time_step: list[KdStep] | None = None
    k_d_by_pressure: KdTable | None = None
    couple_stiffness_factor: NonNegative = 0.0
    couple_damping_factor: NonNegative = 0.0
    ci95: Notes = None
    notes: Notes = None


class SteerLawSection(Schema):
    """The steer-direction law: its form, rest angle φ_0 and the form's own parameters."""

    form: Literal[tuple(STEER_LAW_FORMS)] = Field(json_schema_extra=allowed(str(list(STEER_LAW_FORMS))))  # type: ignore[valid-type]
    rest_angle_rad: Annotated[float, Field(ge=-0.3, le=0.3, json_schema_extra=allowed("[-0.3, 0.3] rad"))] = 0.0
    amplitude_stiffness_nm_per_rad: Finite | None = None
    amplitude_scale_rad: number(gt=0.0) | None = None  # rad
    quadratic_stiffness_nm_per_rad2: Finite | None = None
    ci95: Notes = None
    notes: Notes = None

    @model_validator(mode="after")
    def _form_fields(self) -> "SteerLawSection":
        own = STEER_LAW_FORMS[self.form]
        for key in sorted(k for forms in STEER_LAW_FORMS.values() for k in forms):
            if key in own and getattr(self, key) is None:
                raise ValueError(f"field {key!r} is missing (form {self.form!r} needs {list(own)})")
            if key not in own and getattr(self, key) is not None:
                raise ValueError(
                    f"field {key!r} is not used by form {self.form!r}; allowed: "
                    f"{sorted(['form', 'rest_angle_rad', *own])}"
                )
        return self

    def parameters(self) -> dict[str, Any]:
        """The law's numbers: form, rest angle and the form's own parameters."""
        return {
            "form": self.form,
            "rest_angle_rad": self.rest_angle_rad,
            **{k: getattr(self, k) for k in STEER_LAW_FORMS[self.form]},
        }


class CalibrationFile(Schema):
    """A shell calibration file."""

    name: str | None = None
    pressure_range_kpa: ordered_pair(
        _P_LO,
        _P_HI,
        "kPa",
        strict=True,
        words=(f"[low, high] with {_P_LO} <= low < high <= {_P_HI} kPa (gauge; Pa or MPa fall outside)"),
    )
    nominal_pressure_kpa: Finite | None = None
    omega_n: OmegaN
    zeta: Zeta
    steer_law: SteerLawSection | None = None
    drive_law: DriveLawSection | None = None
    contact_volume: ContactVolume
    hydroelastic: Hydroelastic
    provenance: Notes = None
    fit_ci: Notes = None
    trial_fits: Notes = None
    steer_fit: Notes = None
    drive_fit: DriveFitRecord | None = None
    notes: Notes = None

    @property
    def nominal_kpa(self) -> float:
        """The nominal pressure [kPa]: as given, else the middle of the range."""
        lo, hi = self.pressure_range_kpa
        return 0.5 * (lo + hi) if self.nominal_pressure_kpa is None else self.nominal_pressure_kpa

    @model_validator(mode="after")
    def _related_fields(self) -> "CalibrationFile":
        lo, hi = self.pressure_range_kpa
        if not lo <= self.nominal_kpa <= hi:
            raise ValueError(f"field 'nominal_pressure_kpa' = {self.nominal_pressure_kpa!r} must lie in [{lo}, {hi}]")
        for q in (lo, hi):
            wn = self.omega_n.intercept_rad_s + self.omega_n.slope_rad_s_per_kpa * q
            z = self.zeta.scale * math.exp(self.zeta.rate_per_kpa * q)
            if wn <= 0 or not 0 <= z < 1:
                raise ValueError(
                    f"field 'omega_n', 'zeta': the curves give omega_n={wn:.3g} rad/s, zeta={z:.3g} at "
                    f"{q} kPa; need omega_n > 0 and 0 <= zeta < 1 over the range"
                )
        hyd = self.hydroelastic
        mesh = hyd.low_pressure_mesh
        if mesh is not None and not lo < mesh.below_kpa <= hi:
            raise ValueError(
                f"field 'hydroelastic.low_pressure_mesh.below_kpa' = {mesh.below_kpa!r} must lie in "
                f"({lo}, {hi}] kPa (inside pressure_range_kpa, else the low-pressure mesh is never used)"
            )
        _check_table(hyd.k_d_by_pressure, "hydroelastic.k_d_by_pressure", (lo, hi))
        if hyd.k_d_by_pressure:
            _check_k_d_at_nominal(hyd.k_d, hyd.k_d_by_pressure, self.nominal_kpa, "hydroelastic")
        taken = [] if hyd.fitted_time_step_s is None else [hyd.fitted_time_step_s]
        for i, entry in enumerate(hyd.k_d_by_time_step or ()):
            at = f"hydroelastic.k_d_by_time_step[{i}]"
            if any(math.isclose(entry.time_step_s, s, rel_tol=1e-9) for s in taken):
                raise ValueError(
                    f"field '{at}.time_step_s' = {entry.time_step_s!r} has a k_d already "
                    "(hydroelastic.fitted_time_step_s or an earlier entry); one k_d per step"
                )
            taken.append(entry.time_step_s)
            _check_table(entry.k_d_by_pressure, f"{at}.k_d_by_pressure", (lo, hi))
            if entry.k_d_by_pressure:
                _check_k_d_at_nominal(entry.k_d, entry.k_d_by_pressure, self.nominal_kpa, at)
        check_drive_law_is_the_fit(self.drive_law, self.drive_fit)
        return self


def interpolate_k_d(table: tuple[tuple[float, float], ...], pressure_kpa: float) -> float:
    """k_d of a ``k_d_by_pressure`` table at a pressure, linear between its points."""
    return float(np.interp(float(pressure_kpa), [q for q, _ in table], [k for _, k in table]))


def table_pairs(table: list[KdPoint] | None) -> tuple[tuple[float, float], ...]:
    """A ``k_d_by_pressure`` table as ((pressure_kpa, k_d), ...), () when absent."""
    return tuple((p.pressure_kpa, p.k_d) for p in table or ())


def _check_table(table: list[KdPoint] | None, where: str, pressure_range_kpa: tuple[float, float]) -> None:
    """Pressures increasing and spanning the calibrated range (k_d is never extrapolated)."""
    if not table:
        return
    for i in range(1, len(table)):
        q, prev = table[i].pressure_kpa, table[i - 1].pressure_kpa
        if not q > prev:
            raise ValueError(
                f"field '{where}[{i}].pressure_kpa' = {q!r} must be greater than the previous point's "
                f"{prev!r} kPa (pressures increasing)"
            )
    lo, hi = pressure_range_kpa
    first, last = table[0].pressure_kpa, table[-1].pressure_kpa
    if first > lo or last < hi:
        raise ValueError(
            f"field '{where}' covers [{first!r}, {last!r}] kPa; it must span pressure_range_kpa "
            f"[{lo}, {hi}] kPa (k_d is not extrapolated)"
        )


def _check_k_d_at_nominal(k_d: float, table: list[KdPoint], nominal_kpa: float, where: str) -> None:
    """A step's single k_d beside its pressure table must be the table's value at the nominal pressure."""
    expected = interpolate_k_d(table_pairs(table), nominal_kpa)
    if not math.isclose(k_d, expected, rel_tol=K_D_NOMINAL_REL_TOL):
        raise ValueError(
            f"field '{where}.k_d' = {k_d!r} must equal its k_d_by_pressure at nominal_pressure_kpa "
            f"{nominal_kpa:g} kPa ({expected:.5g}, within {100 * K_D_NOMINAL_REL_TOL:g}%)"
        )


def shipped_calibrations() -> list[str]:
    """Names of the calibrations shipped in ``assets/calibration`` (``"default"``, ``"hydroelastic_fast"``, ...)."""
    from importlib import resources

    folder = resources.files("sphere_env.assets").joinpath("calibration")
    return sorted(p.name[: -len(".yaml")] for p in folder.iterdir() if p.name.endswith(".yaml"))


def calibration_form(value: Any) -> str:
    """``"name"`` for a calibration given by name (a bare word: no folder, no suffix, and no such
    file in the working folder), else ``"path"`` (a path, or None: the shipped default)."""
    if isinstance(value, str) and Path(value).name == value and not Path(value).suffix and not Path(value).exists():
        return "name"
    return "path"


@lru_cache(maxsize=1)
def calibration_ref() -> Callable[[Any, str], Any]:
    """The check of a calibration reference (:func:`~sphere_env.schemas.checker`): the path of a
    calibration YAML, the name of a shipped one (:func:`shipped_calibrations`) or None."""
    names = tuple(shipped_calibrations())
    return checker(
        Annotated[
            Union[
                Annotated[Literal[names], Tag("name")],  # type: ignore[valid-type]
                Annotated[str | Path | None, Tag("path")],
            ],
            Discriminator(calibration_form),
            Field(
                json_schema_extra=allowed(
                    f"the path of a calibration YAML file, the name of a shipped one {list(names)}, "
                    "or None (the shipped default)"
                )
            ),
        ]
    )


def check_calibration(data: Any, source: str = "<dict>") -> CalibrationFile:
    """``data`` (a calibration mapping) as :class:`CalibrationFile`; ``ValueError``
    ``calibration file '<source>': <field>: ...`` otherwise."""
    return validate(CalibrationFile, data, f"calibration file {source!r}")


def read_calibration_file(path: str | Path) -> tuple[dict[str, Any], CalibrationFile]:
    """The file's mapping as written and its validated schema; ``ValueError`` naming the file when it
    cannot be read or parsed."""
    try:
        data = safe_yaml.load_file(Path(path))
    except (OSError, yaml.YAMLError) as err:
        raise ValueError(f"calibration file {str(path)!r}: cannot read: {err}") from err
    return data, check_calibration(data, str(path))
