"""Shell contact laws and the pressure calibration they read (paper §III, DESIGN.md §3).

A :class:`ShellCalibration` holds the measured/assumed pressure curves ω_n(p), ζ(p), V(p) and the
valid pressure range, loaded from one YAML file (``assets/calibration/default.yaml`` by default,
or a user's own). Pressures are gauge pressures in **kPa** at this user-facing boundary.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from sphere_env.resources import asset_path

DEFAULT_CALIBRATION = asset_path("calibration", "default.yaml")

SHELL_MODELS = ("point", "injected", "hydroelastic")


def check_shell_model(name: str) -> str:
    if name not in SHELL_MODELS:
        raise ValueError(f"shell_model: unknown value {name!r}; allowed: {list(SHELL_MODELS)}")
    return name


def membrane_contact_volume_m3(pressure_kpa: float, weight_n: float, radius_m: float) -> float:
    """Sphere–plane intersection volume V(p) [m³] from a membrane estimate (DESIGN.md §3).

    Contact area A = f_n / p gives the flat's radius a = √(A/π); the undeformed sphere would
    penetrate δ = R − √(R² − a²) ≈ a²/(2R); the cap volume is V = π δ² (R − δ/3).
    """
    area = weight_n / (pressure_kpa * 1e3)
    a2 = min(area / math.pi, radius_m**2)
    delta = radius_m - math.sqrt(radius_m**2 - a2)
    return math.pi * delta**2 * (radius_m - delta / 3.0)


def injected_gains(omega_n: float, zeta: float, M_eq: float, K_eq: float) -> tuple[float, float]:
    """K_inject = ω_n² M_eq − K_eq (eq. 7) [N m/rad], C_inject = 2 M_eq ω_n ζ (eq. 8) [N m s/rad]."""
    return omega_n**2 * M_eq - K_eq, 2.0 * M_eq * omega_n * zeta


def injected_torques(phi, phi_dot, omega_d, K_inject: float, C_inject: float):
    """Injected shell torques (eq. 9 and §IV) [N m].

    Steer direction: τ_φ = −C_inject φ̇ − K_inject φ.  Drive direction: τ_d = −C_inject ω_d
    (the paper drops K_inject there and damps the rolling velocity).
    """
    return -C_inject * phi_dot - K_inject * phi, -C_inject * omega_d


def _number(data: Mapping[str, Any], key: str, where: str, path: str) -> float:
    if key not in data:
        raise ValueError(f"calibration file {path!r}: field '{where}.{key}' is missing")
    val = data[key]
    if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val):
        raise ValueError(f"calibration file {path!r}: field '{where}.{key}' = {val!r} must be a finite number")
    return float(val)


@dataclass(frozen=True)
class ShellCalibration:
    """Pressure curves of the shell (paper Fig. 10 form) and hydroelastic settings.

    ω_n(p) = omega_n_intercept + omega_n_slope · p       [rad/s], p in kPa (linear, Fig. 10)
    ζ(p)   = zeta_scale · exp(zeta_rate · p)             [-]                 (exponential, Fig. 10)
    V(p)   = membrane estimate, or a table interpolated in p                [m³]
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

    # ---- loading ---------------------------------------------------------------------------------
    @classmethod
    def load(cls, path: str | Path | None = None) -> "ShellCalibration":
        path = Path(path) if path is not None else DEFAULT_CALIBRATION
        p = str(path)
        try:
            data = yaml.safe_load(Path(path).read_text())
        except (OSError, yaml.YAMLError) as err:
            raise ValueError(f"calibration file {p!r}: cannot read: {err}") from err
        return cls.from_dict(data, source=p)

    @classmethod
    def from_dict(cls, data: Any, source: str = "<dict>") -> "ShellCalibration":
        p = source
        if not isinstance(data, Mapping):
            raise ValueError(f"calibration file {p!r}: top level must be a mapping")
        for section in ("pressure_range_kpa", "omega_n", "zeta", "contact_volume", "hydroelastic"):
            if section not in data:
                raise ValueError(f"calibration file {p!r}: field '{section}' is missing")
        rng = data["pressure_range_kpa"]
        if (
            not isinstance(rng, (list, tuple))
            or len(rng) != 2
            or not all(isinstance(x, (int, float)) and math.isfinite(x) for x in rng)
            or not 0 < rng[0] < rng[1]
        ):
            raise ValueError(
                f"calibration file {p!r}: field 'pressure_range_kpa' = {rng!r} must be [low, high] "
                "with 0 < low < high (kPa gauge)"
            )
        lo, hi = float(rng[0]), float(rng[1])
        nominal = data.get("nominal_pressure_kpa", 0.5 * (lo + hi))
        if not isinstance(nominal, (int, float)) or not lo <= nominal <= hi:
            raise ValueError(
                f"calibration file {p!r}: field 'nominal_pressure_kpa' = {nominal!r} must lie in [{lo}, {hi}]"
            )
        om, ze, vol, hyd = data["omega_n"], data["zeta"], data["contact_volume"], data["hydroelastic"]
        for name, sec in (("omega_n", om), ("zeta", ze), ("contact_volume", vol), ("hydroelastic", hyd)):
            if not isinstance(sec, Mapping):
                raise ValueError(f"calibration file {p!r}: field '{name}' must be a mapping")
        if om.get("model") != "linear":
            raise ValueError(f"calibration file {p!r}: field 'omega_n.model' = {om.get('model')!r}; allowed: ['linear']")
        if ze.get("model") != "exponential":
            raise ValueError(f"calibration file {p!r}: field 'zeta.model' = {ze.get('model')!r}; allowed: ['exponential']")
        vmodel = vol.get("model")
        table = None
        if vmodel == "table":
            pk, vm = vol.get("pressure_kpa"), vol.get("volume_m3")
            if (
                not isinstance(pk, list) or not isinstance(vm, list) or len(pk) != len(vm) or len(pk) < 2
                or any(not isinstance(x, (int, float)) for x in pk + vm)
                or any(b <= a for a, b in zip(pk, pk[1:])) or any(v <= 0 for v in vm)
            ):
                raise ValueError(
                    f"calibration file {p!r}: field 'contact_volume' table needs increasing 'pressure_kpa' "
                    "and positive 'volume_m3' lists of equal length >= 2"
                )
            table = (tuple(map(float, pk)), tuple(map(float, vm)))
        elif vmodel != "membrane":
            raise ValueError(
                f"calibration file {p!r}: field 'contact_volume.model' = {vmodel!r}; allowed: ['membrane', 'table']"
            )
        cal = cls(
            pressure_range_kpa=(lo, hi),
            nominal_pressure_kpa=float(nominal),
            omega_n_intercept=_number(om, "intercept_rad_s", "omega_n", p),
            omega_n_slope=_number(om, "slope_rad_s_per_kpa", "omega_n", p),
            zeta_scale=_number(ze, "scale", "zeta", p),
            zeta_rate=_number(ze, "rate_per_kpa", "zeta", p),
            volume_model=vmodel,
            volume_table=table,
            k_d=_number(hyd, "k_d", "hydroelastic", p),
            resolution_hint_m=_number(hyd, "resolution_hint_m", "hydroelastic", p),
            fitted_time_step_s=(
                _number(hyd, "fitted_time_step_s", "hydroelastic", p) if "fitted_time_step_s" in hyd else None
            ),
            source=p,
            raw=dict(data),
        )
        for q in (lo, hi):
            if cal.omega_n(q) <= 0 or not 0 <= cal.zeta(q) < 1:
                raise ValueError(
                    f"calibration file {p!r}: curves give omega_n={cal.omega_n(q):.3g} rad/s, "
                    f"zeta={cal.zeta(q):.3g} at {q} kPa; need omega_n > 0 and 0 <= zeta < 1 over the range"
                )
        if cal.k_d < 0 or cal.resolution_hint_m <= 0:
            raise ValueError(
                f"calibration file {p!r}: 'hydroelastic.k_d' must be >= 0 and 'resolution_hint_m' > 0"
            )
        return cal

    # ---- curves ----------------------------------------------------------------------------------
    def check_pressure(self, pressure_kpa: float, field: str = "pressure_kpa") -> float:
        """Return ``pressure_kpa`` as float if finite and inside the calibrated range, else raise."""
        lo, hi = self.pressure_range_kpa
        try:
            val = float(pressure_kpa)
        except (TypeError, ValueError):
            raise ValueError(f"{field}: value {pressure_kpa!r} is not a number; allowed: [{lo}, {hi}] kPa") from None
        if not math.isfinite(val) or not lo <= val <= hi:
            raise ValueError(
                f"{field}: value {pressure_kpa!r} is outside the calibrated range [{lo}, {hi}] kPa "
                f"(calibration {self.source})"
            )
        return val

    def omega_n(self, pressure_kpa):
        """Locked-steer natural frequency ω_n(p) [rad/s]."""
        return self.omega_n_intercept + self.omega_n_slope * np.asarray(pressure_kpa, dtype=float)

    def zeta(self, pressure_kpa):
        """Locked-steer damping ratio ζ(p) [-]."""
        return self.zeta_scale * np.exp(self.zeta_rate * np.asarray(pressure_kpa, dtype=float))

    def volume_m3(self, pressure_kpa: float, weight_n: float, radius_m: float) -> float:
        """Sphere–plane intersection volume V(p) [m³]."""
        if self.volume_model == "table":
            pk, vm = self.volume_table
            return float(np.interp(pressure_kpa, pk, vm))
        return membrane_contact_volume_m3(pressure_kpa, weight_n, radius_m)

    def injected_gains(self, pressure_kpa: float, M_eq: float, K_eq: float) -> tuple[float, float]:
        """(K_inject, C_inject) at pressure p (eqs. 7–8)."""
        return injected_gains(float(self.omega_n(pressure_kpa)), float(self.zeta(pressure_kpa)), M_eq, K_eq)

    def hydroelastic(self, pressure_kpa: float, weight_n: float, radius_m: float, M_eq: float, K_eq: float):
        """(modulus [Pa], Hunt–Crossley dissipation [s/m]) at pressure p.

        m_hydro = f_n / V(p) (eq. 10);  d = k_d · C_inject(p) (eq. 11 with the §III.D factor k_d).
        C_inject is used by number as the dissipation in s/m, as the paper does.
        """
        modulus = weight_n / self.volume_m3(pressure_kpa, weight_n, radius_m)
        _, c_inject = self.injected_gains(pressure_kpa, M_eq, K_eq)
        return modulus, self.k_d * c_inject
