"""Blocks of ``docs/physics.md``: ``hydro_tradeoff.json`` and the time-step study."""

from __future__ import annotations

from typing import Any

from sphere_env.evaluation.experiments.docs.base import Results, kpa, renders, signed, slash
from sphere_env.evaluation.experiments.docs.speed import (
    HYDRO_LOW_MESH,
    HYDRO_LOW_MESH_10MS,
    HYDRO_SHIPPED,
    HYDRO_UNIFORM_COARSE,
    hydro,
    per_pressure,
)


@renders("mesh_figures")
def mesh_figures(res: Results) -> str:
    h = hydro(res)
    ps, lo = slash(h["pressures_kpa"], kpa), str(float(min(h["pressures_kpa"])))
    low, ship = h["accuracy"]["rows"][HYDRO_LOW_MESH], h["accuracy"]["rows"][HYDRO_SHIPPED]

    def omega(candidate: str) -> str:
        return slash(per_pressure(h, candidate, "omega_err_pct"), signed) + "%"

    spd_low, spd_ship = h["speed"][HYDRO_LOW_MESH], h["speed"][HYDRO_SHIPPED]
    return "\n".join(
        [
            f"* locked-steer ω with that mesh against a 0.02 m mesh: {omega(HYDRO_LOW_MESH)} at {ps} kPa (a uniform "
            f"0.1 m mesh: {omega(HYDRO_UNIFORM_COARSE)}; uniform 0.05 m: {omega(HYDRO_SHIPPED)});",
            f"* at {kpa(min(h['pressures_kpa']))} kPa: contact polygons at rest "
            f"{ship['per_pressure'][lo]['polygons']} → {low['per_pressure'][lo]['polygons']}, the twin "
            f"{spd_ship['rtf'][lo]:.1f}× → {spd_low['rtf'][lo]:.1f}× real time, ζ "
            f"{signed(low['per_pressure'][lo]['zeta_vs_baseline_pct'])}%; ramp ω_d RMSE against the shipped setting at "
            f"0.5 ms {ship['ramp_rmse_vs_shipped_unrefit_pct']:.2f}% → {low['ramp_rmse_vs_shipped_unrefit_pct']:.2f}% of "
            f"peak (at {h['accuracy']['nominal_pressure_kpa']:g} kPa, then on the 0.1 m mesh);",
        ]
    )


@renders("mesh_speedup")
def mesh_speedup(res: Results) -> str:
    s = hydro(res)["speed"][HYDRO_LOW_MESH]
    return f"{s['speedup_twin']:.2f}× (twin) / {s['speedup_env']:.2f}× (env)"


def _timestep(res: Results) -> list[dict[str, Any]]:
    """The time-step study's rows: its JSON when the study wrote one, else its Markdown table."""
    if (res.folder / "timestep_study.json").exists():
        rows = res.json("timestep_study.json")["rows"]
    else:
        cols = {
            "model": "case",
            "step ms": "dt_ms",
            "ramp ω_d RMSE % of peak": "ramp_omega_d_rmse_pct",
            "rock ω_n err %": "rock_omega_n_err_pct",
            "rock ζ err %": "rock_zeta_err_pct",
            "stand θ RMSE rad": "stand_theta_rmse_rad",
        }
        rows = [{key: row[head] for head, key in cols.items()} for row in res.md_table("timestep_study.md")]
    return [{k: (v if k == "case" or v in ("", None) else float(v)) for k, v in r.items()} for r in rows]


def _at(rows: list[dict], case: str, dt_ms: float) -> dict:
    for r in rows:
        if r["case"] == case and abs(r["dt_ms"] - dt_ms) < 1e-9:
            return r
    raise KeyError(f"timestep_study: {case} at {dt_ms:g} ms")


@renders("timestep_default")
def timestep_default(res: Results) -> str:
    rows = _timestep(res)
    shells = ("point", "injected", "hydroelastic")
    ramp = ", ".join(f"{_at(rows, s, 5)['ramp_omega_d_rmse_pct']:.2f}% ({s})" for s in shells)
    rock = max(abs(_at(rows, s, 5)["rock_omega_n_err_pct"]) for s in shells)
    stand = next(r for r in rows if r["case"].startswith("stand") and abs(r["dt_ms"] - 5) < 1e-9)
    return (
        f"ramp ω_d RMSE {ramp} of peak; rocking frequency within {rock:.2f}% for all models; stand swing θ RMSE "
        f"{stand['stand_theta_rmse_rad']:.4f} rad"
    )


@renders("timestep_hydro_damping")
def timestep_hydro_damping(res: Results) -> str:
    rows = _timestep(res)

    def z(dt: float) -> str:
        v = _at(rows, "hydroelastic", dt)["rock_zeta_err_pct"]
        return f"{abs(v):.{0 if abs(v) >= 10 else 1}f}% {'above' if v >= 0 else 'below'}"

    return (
        f"**the hydroelastic damping ratio at 5 ms is {z(5)} the 0.5 ms value** ({z(1)} at 1 ms, {z(2)} at 2 ms; "
        f"at 10 ms with the refitted k_d {z(10)}, and the ramp error "
        f"{_at(rows, 'hydroelastic', 10)['ramp_omega_d_rmse_pct']:.2f}%)"
    )


@renders("shipped_zeta_nominal")
def shipped_zeta_nominal(res: Results) -> str:
    h = hydro(res)
    first = h["accuracy"]["ramp_against_k_d"][0]
    zeta_p0 = first["zeta"] / (1 + first["zeta_err_pct"] / 100)
    return f"ζ = {h['accuracy']['rows'][HYDRO_SHIPPED]['zeta_at_nominal']:.3f} (the curve's ζ(p₀) = {zeta_p0:.3f})"


@renders("shipped_zeta_vs_curve")
def shipped_zeta_vs_curve(res: Results) -> str:
    h = hydro(res)
    return (
        f"{slash(per_pressure(h, HYDRO_SHIPPED, 'zeta_err_pct'), lambda v: signed(v, 0))}% against ζ(p) at "
        f"{slash(h['pressures_kpa'], kpa)} kPa"
    )


@renders("step_10ms")
def step_10ms(res: Results) -> str:
    h = hydro(res)
    s, a = h["speed"][HYDRO_LOW_MESH_10MS], h["accuracy"]["rows"][HYDRO_LOW_MESH_10MS]
    ps = slash(h["pressures_kpa"], kpa)

    def zeta(key: str) -> str:
        return slash(per_pressure(h, HYDRO_LOW_MESH_10MS, key), lambda v: signed(v, 0))

    return (
        f"runs {s['speedup_twin']:.2f}× (twin) / {s['speedup_env']:.2f}× (env) faster over the pressure range; "
        f"ω stays within {a['max_omega_err_pct']:.1f}% of the 0.02 m mesh and the ramp ω_d RMSE against the "
        f"shipped setting at 0.5 ms is {a['ramp_rmse_vs_shipped_unrefit_pct']:.2f}% of peak, but ζ moves by "
        f"{zeta('zeta_vs_baseline_pct')}% at {ps} kPa against the 5 ms setting (against ζ(p): "
        f"{zeta('zeta_err_pct')}%)"
    )
