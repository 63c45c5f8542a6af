"""Calibration files: where one is (a path, or the name of a shipped one), how a parameter set names
it, and the intervals its fit reports for the shell's randomizable scales."""

from __future__ import annotations

from pathlib import Path

from sphere_env.models.calibration_schema import calibration_form, calibration_ref
from sphere_env.models.steer_law import injected_gains
from sphere_env.params import SHIPPED_CALIBRATIONS
from sphere_env.resources import asset_path

DEFAULT_CALIBRATION = asset_path("calibration", "default.yaml")


def calibration_file(calibration: str | Path | None) -> Path:
    """The file of a calibration given as a path, as the name of a shipped one (a bare name such as
    ``"hydroelastic_fast"``: no folder, no suffix, and no such file in the working folder), or
    ``None`` (the shipped default); anything else is a ValueError naming ``calibration``
    (:func:`~sphere_env.models.calibration_schema.calibration_ref`)."""
    calibration = calibration_ref()(calibration, "calibration")
    if calibration is None:
        return DEFAULT_CALIBRATION
    if calibration_form(calibration) == "name":
        return asset_path("calibration", f"{calibration}.yaml")
    return Path(calibration)


def calibration_name(calibration: str | Path | None) -> str:
    """How a parameter set names a calibration: a shipped one by its name (``None``: ``default``),
    any other by its path."""
    path = Path(calibration_file(calibration)).resolve()
    return next(
        (name for name in SHIPPED_CALIBRATIONS if Path(calibration_file(name)).resolve() == path), str(calibration)
    )


def law_scale_intervals(calibration, robot) -> dict[str, tuple[float, float]]:
    """The 95 % intervals of ``shell_stiffness_scale`` and ``shell_damping_scale`` (the
    randomizable scales of the shell's springs and dampers, :mod:`sphere_env.params`) that a
    :class:`~sphere_env.models.shell.ShellCalibration`'s file reports of its own fit: its intervals of
    ω_n, ζ and the spring's amplitude or quadratic stiffness, over windows where the fit has them
    (``steer_fit.models.injected.ci95_over_windows``), else the fit's Jacobian ones
    (``provenance.injected_fit.ci95``), mapped through eqs. 7-8 (K_inject = ω_n² M_eq − K_eq,
    C_inject = 2 M_eq ω_n ζ) at the fit's own values for ``robot``. Empty when the file reports no
    interval."""
    raw = calibration.raw or {}
    fit = ((raw.get("steer_fit") or {}).get("models") or {}).get("injected") or {}
    values, ci = fit.get("params"), fit.get("ci95_over_windows")
    if not ci:
        prov = (raw.get("provenance") or {}).get("injected_fit") or {}
        values, ci = prov.get("values"), prov.get("ci95")
    if not ci or not values:
        return {}

    def pick(d, *keys):
        return next((d[k] for k in keys if k in d), None)

    w, z = pick(values, "omega_n", "omega_n_rad_s"), pick(values, "zeta")
    w_ci = pick(ci, "omega_n", "omega_n_rad_s") or (w, w)
    z_ci = pick(ci, "zeta") or (z, z)
    M, K_eq = robot.M_eq, robot.K_eq
    K0, C0 = injected_gains(w, z, M, K_eq)
    stiffness = [injected_gains(x, z, M, K_eq)[0] / K0 for x in w_ci]
    for key in ("amplitude_stiffness_nm_per_rad", "quadratic_stiffness_nm_per_rad2"):
        if key in ci and values.get(key):
            stiffness += [x / values[key] for x in ci[key]]
    damping = [injected_gains(x, y, M, K_eq)[1] / C0 for x, y in zip(w_ci, z_ci)]
    return {
        "shell_stiffness_scale": (float(min(stiffness)), float(max(stiffness))),
        "shell_damping_scale": (float(min(damping)), float(max(damping))),
    }
