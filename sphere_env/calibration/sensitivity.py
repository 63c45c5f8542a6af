"""Hydroelastic sensitivity sweep (paper Fig. 11).

At each pressure the calibration's hydroelastic modulus m(p) = f_n / V(p) and dissipation
d(p) = k_d C_inject(p) are the control point; each is scaled by 0.5 and 1.5 (one at a time).
Every case is a ``locked_steer`` free decay released at φ₀ on flat ground; ω_n and ζ come from a
damped-sinusoid fit of φ(t). Reported: the simulated ζ, its change against the control point, and
its error against the calibration curve ζ(p). Cases run on :func:`sphere_env.parallel.run_parallel`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from sphere_env.analysis.decay import fit_free_decay
from sphere_env.calibration.shell_fit import calibration_at
from sphere_env.models.rigid_body import RobotParameters
from sphere_env.models.shell import ShellCalibration
from sphere_env.parallel import run_parallel
from sphere_env.plotting import save_figure
from sphere_env.reporting import markdown_table

CASES = (
    ("control", 1.0, 1.0),
    ("modulus -50%", 0.5, 1.0),
    ("modulus +50%", 1.5, 1.0),
    ("dissipation -50%", 1.0, 0.5),
    ("dissipation +50%", 1.0, 1.5),
)


def decay_case(job: Mapping[str, Any]) -> dict[str, Any]:
    """One locked-steer hydroelastic free decay. ``job`` keys: calibration (path or None),
    pressure_kpa, modulus_scale, dissipation_scale, phi0_rad, duration_s, time_step_s, case."""
    from sphere_env.physics import InitialState, Twin, TwinConfig

    step = job.get("time_step_s", TwinConfig.model_fields["time_step_s"].default)
    base = ShellCalibration.load(job.get("calibration")).for_time_step(step)  # k_d of that step, if refitted
    robot = RobotParameters.from_urdf()
    p = float(job["pressure_kpa"])
    m0, d0 = base.bind(robot).hydroelastic(p)
    m, d = m0 * job["modulus_scale"], d0 * job["dissipation_scale"]
    twin = Twin(
        TwinConfig(
            fixture="locked_steer",
            shell_model="hydroelastic",
            steer_friction="none",
            drive_friction="none",
            calibration=job.get("calibration"),
            pressure_kpa=p,
            time_step_s=step,
        )
    )
    twin.set_calibration(
        ShellCalibration.from_dict(
            calibration_at(base, p, modulus_pa=m, dissipation_s_per_m=d, robot=robot), source="<sweep>"
        ),
        p,
    )
    twin.reset(InitialState(roll=job.get("phi0_rad", 0.15)))
    dt, n = 0.01, int(job.get("duration_s", 6.0) / 0.01)
    t, phi = np.empty(n + 1), np.empty(n + 1)
    t[0], phi[0] = 0.0, twin.state().phi
    for i in range(1, n + 1):
        twin.advance(dt)
        t[i], phi[i] = i * dt, twin.state().phi
    try:
        fit = fit_free_decay(t, phi)
        omega_n, zeta = fit.omega_n, fit.zeta
    except ValueError:
        omega_n = zeta = float("nan")
    return {
        "case": job["case"],
        "pressure_kpa": p,
        "modulus_pa": m,
        "dissipation_s_per_m": d,
        "omega_n": omega_n,
        "zeta": zeta,
        "zeta_curve": float(base.zeta(p)),
        "omega_n_curve": float(base.omega_n(p)),
        "time_step_s": twin.config.time_step_s,
    }


def sweep(
    pressures_kpa: Sequence[float],
    calibration: str | Path | None = None,
    workers: int | None = None,
    phi0_rad: float = 0.15,
    duration_s: float = 6.0,
    time_step_s: float = 0.005,
    cases: Sequence[tuple[str, float, float]] = CASES,
) -> list[dict[str, Any]]:
    """Run every (pressure, case); returns rows with ζ, its change vs control [%] and error vs ζ(p) [%]."""
    jobs = [
        {
            "calibration": None if calibration is None else str(calibration),
            "pressure_kpa": float(p),
            "modulus_scale": ms,
            "dissipation_scale": ds,
            "phi0_rad": phi0_rad,
            "duration_s": duration_s,
            "time_step_s": time_step_s,
            "case": name,
        }
        for p in pressures_kpa
        for name, ms, ds in cases
    ]
    rows = run_parallel(decay_case, jobs, workers)
    control = {r["pressure_kpa"]: r["zeta"] for r in rows if r["case"] == "control"}
    for r in rows:
        c = control.get(r["pressure_kpa"], float("nan"))
        r["zeta_change_pct"] = 100.0 * (r["zeta"] - c) / c if c and math.isfinite(c) else float("nan")
        r["zeta_error_vs_curve_pct"] = 100.0 * (r["zeta"] - r["zeta_curve"]) / r["zeta_curve"]
    return rows


def sensitivity_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """A Markdown table of :func:`sweep`'s rows."""
    return markdown_table(
        rows,
        [
            ("pressure_kpa", "p [kPa]", "{:.2f}"),
            ("case", "case", ""),
            ("modulus_pa", "modulus [Pa]", "{:.3g}"),
            ("dissipation_s_per_m", "dissipation [s/m]", "{:.3f}"),
            ("omega_n", "ω_n [rad/s]", "{:.3f}"),
            ("zeta", "ζ sim", "{:.3f}"),
            ("zeta_curve", "ζ curve", "{:.3f}"),
            ("zeta_change_pct", "Δζ vs control [%]", "{:+.1f}"),
            ("zeta_error_vs_curve_pct", "ζ error vs curve [%]", "{:+.1f}"),
        ],
        align="rlrrrrrrr",
    )


def plot_sweep(path: str | Path, rows: Sequence[Mapping[str, Any]]) -> Path:
    """ζ vs pressure per case, with the calibration curve (paper Fig. 11 layout)."""
    from sphere_env.plotting import pyplot

    plt = pyplot()

    fig, ax = plt.subplots(figsize=(6, 4))
    ps = sorted({r["pressure_kpa"] for r in rows})
    ax.plot(ps, [next(r["zeta_curve"] for r in rows if r["pressure_kpa"] == p) for p in ps], "k--", label="ζ(p) curve")
    for name in dict.fromkeys(r["case"] for r in rows):
        sel = [r for r in rows if r["case"] == name]
        ax.plot([r["pressure_kpa"] for r in sel], [r["zeta"] for r in sel], "o-", label=name)
    ax.set_xlabel("gauge pressure p [kPa]")
    ax.set_ylabel("simulated damping ratio ζ [-]")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path, dpi=110)


def match_dissipation(
    calibration: str | Path | None,
    pressure_kpa: float,
    target_zeta: float | None = None,
    scale_bracket: tuple[float, float] = (0.05, 3.0),
    duration_s: float = 6.0,
    phi0_rad: float = 0.15,
    xtol: float = 0.01,
    time_step_s: float | None = None,
) -> dict[str, float]:
    """Find the Hunt–Crossley dissipation d [s/m] at which the hydroelastic ``locked_steer`` free decay
    has the damping ratio ``target_zeta`` (default: the calibration's ζ(p)); returns d, k_d = d / C_inject
    and ``time_step_s``, the plant step [s] the decays ran at (None: the twin's default step).

    This is the paper's §III.D tuning of k_d, done by root finding on the simulated ζ. A discrete
    plant adds numerical damping that depends on the step, so k_d holds at that step only.
    """
    from scipy.optimize import brentq

    from sphere_env.physics import TwinConfig

    step = float(TwinConfig.model_fields["time_step_s"].default if time_step_s is None else time_step_s)
    base = ShellCalibration.load(calibration).for_time_step(step)  # decay_case scales this step's k_d
    robot = RobotParameters.from_urdf()
    p = base.check_pressure(pressure_kpa)
    target = float(base.zeta(p)) if target_zeta is None else float(target_zeta)
    shell = base.bind(robot)
    _, d0 = shell.hydroelastic(p)
    _, c_inject = shell.injected_gains(p)

    def zeta_at(scale: float) -> float:
        job = {
            "calibration": None if calibration is None else str(calibration),
            "pressure_kpa": p,
            "modulus_scale": 1.0,
            "dissipation_scale": scale,
            "phi0_rad": phi0_rad,
            "duration_s": duration_s,
            "time_step_s": step,
            "case": "match",
        }
        return decay_case(job)["zeta"] - target

    scale = brentq(zeta_at, *scale_bracket, xtol=xtol)
    d = d0 * scale
    return {
        "pressure_kpa": p,
        "target_zeta": target,
        "dissipation_s_per_m": d,
        "k_d": d / c_inject,
        "zeta_sim": zeta_at(scale) + target,
        "time_step_s": step,
    }


def match_dissipation_at_step(
    calibration: str | Path | None, time_step_s: float, pressure_kpa: float | None = None, **kwargs: Any
) -> dict[str, float]:
    """k_d for another plant step: the Hunt–Crossley dissipation at which the locked-steer decay at
    ``time_step_s`` has the damping ratio the calibration's own k_d gives at its
    ``fitted_time_step_s`` (at ``pressure_kpa``, default the nominal). Drake's discrete contact adds
    numerical damping that grows with the step; this keeps the damping the calibration was fitted
    with (its steer couple included). Returns :func:`match_dissipation`'s record plus
    ``reference_time_step_s`` and ``reference_zeta``. ``kwargs`` go to :func:`match_dissipation`.
    """
    base = ShellCalibration.load(calibration)
    if base.fitted_time_step_s is None:
        raise ValueError(
            f"calibration file {base.source!r}: field 'hydroelastic.fitted_time_step_s' is missing: "
            "the step its k_d holds at is needed as the reference"
        )
    from sphere_env.params import check as check_param

    step = check_param("time_step_s", time_step_s)
    p = base.nominal_pressure_kpa if pressure_kpa is None else base.check_pressure(pressure_kpa)
    ref = decay_case(
        {
            "calibration": None if calibration is None else str(calibration),
            "pressure_kpa": p,
            "modulus_scale": 1.0,
            "dissipation_scale": 1.0,
            "phi0_rad": kwargs.get("phi0_rad", 0.15),
            "duration_s": kwargs.get("duration_s", 6.0),
            "time_step_s": base.fitted_time_step_s,
            "case": "reference",
        }
    )
    out = match_dissipation(calibration, p, target_zeta=ref["zeta"], time_step_s=step, **kwargs)
    return dict(out, reference_time_step_s=base.fitted_time_step_s, reference_zeta=ref["zeta"])


def default_k_d_pressures(cal: ShellCalibration) -> list[float]:
    """Pressures [kPa] a k_d table is fitted at by default: the range's ends, the nominal pressure,
    five points evenly over the range, and both sides of a ``low_pressure_mesh`` switch (the mesh, and
    with it Drake's contact damping, changes there, so k_d may step)."""
    lo, hi = cal.pressure_range_kpa
    points = [lo, hi, cal.nominal_pressure_kpa, *np.linspace(lo, hi, 5).tolist()]
    if cal.low_pressure_mesh is not None:
        below = cal.low_pressure_mesh[0]
        points += [below, max(lo, below - 0.01)]
    return sorted({round(float(q), 4) for q in points})


def match_dissipation_by_pressure(
    calibration: str | Path | None, time_step_s: float, pressures_kpa: Sequence[float] | None = None, **kwargs: Any
) -> list[dict[str, float]]:
    """k_d against pressure at one plant step: at each pressure, the k_d at which the locked-steer
    hydroelastic decay at ``time_step_s`` has the calibration's ζ(p) (:func:`match_dissipation`, one
    root find per pressure; default pressures :func:`default_k_d_pressures`). With one k_d the
    decay's ζ falls with pressure faster than ζ(p); a k_d per pressure follows the curve. Returns
    :func:`match_dissipation`'s records, in increasing pressure. ``kwargs`` go to
    :func:`match_dissipation`."""
    from sphere_env.params import check as check_param

    step = check_param("time_step_s", time_step_s)
    cal = ShellCalibration.load(calibration)
    ps = default_k_d_pressures(cal) if pressures_kpa is None else sorted({float(q) for q in pressures_kpa})
    for q in ps:
        cal.check_pressure(q, "field 'pressures_kpa'")
    # At a coarse step and high pressure ζ(p) may need several times the single-k_d dissipation
    # (about 3.4x at 10 ms and 14 kPa): a wider bracket than the one-pressure match's
    kwargs.setdefault("scale_bracket", (0.05, 8.0))
    return [match_dissipation(calibration, q, time_step_s=step, **kwargs) for q in ps]
