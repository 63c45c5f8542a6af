"""The evaluation sweep's outputs: the episodes CSV, PME rows, aggregates and the Markdown report.

Pure functions of the rows and traces :func:`sphere_env.evaluation.cells.rollout` returns (plots:
:mod:`sphere_env.evaluation.plots`).
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from sphere_env.evaluation.metrics import KEY_COLUMNS, METRIC_COLUMNS, PME_MIN_SPEED_RAD_S, pme_between

if TYPE_CHECKING:
    from sphere_env.evaluation.evaluate import SweepSpec


def _fmt(v: Any) -> str:
    if isinstance(v, bool):
        return str(int(v))
    if isinstance(v, float):
        return repr(v)
    return str(v)


def write_csv(rows: Sequence[Mapping[str, Any]], path: Path) -> Path:
    cols = list(KEY_COLUMNS) + list(METRIC_COLUMNS) + ["truncation_reason"]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in rows:
            w.writerow([_fmt(r.get(c, "")) for c in cols])
    return path


def pme_rows(
    rows: Sequence[Mapping[str, Any]], traces: Sequence[Mapping[str, np.ndarray]], controller: str = "zero"
) -> list[dict[str, Any]]:
    """PME [%] of every ordered pair of shell models (reference → simulation) per (pressure,
    friction, seed) for ``controller``'s episodes."""
    cells: dict[tuple, dict[str, Mapping[str, np.ndarray]]] = {}
    for r, tr in zip(rows, traces):
        if r["controller"] == controller:
            cells.setdefault((r["pressure_kpa"], r["friction"], r["seed"]), {})[r["shell_model"]] = tr
    out = []
    for (p, fr, s), by_model in sorted(cells.items()):
        for ref, te in by_model.items():
            for sim, ts in by_model.items():
                if ref == sim:
                    continue
                out.append(
                    dict(
                        pressure_kpa=p,
                        friction=fr,
                        seed=s,
                        reference=ref,
                        simulation=sim,
                        pme_percent=pme_between(te["t_s"], te["omega_d"], te["on_ramp"], ts["t_s"], ts["omega_d"]),
                    )
                )
    return out


def write_pme_csv(pmes: Sequence[Mapping[str, Any]], path: Path) -> Path:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(pmes[0]))
        w.writeheader()
        w.writerows(pmes)
    return path


def load_user_log(path: str | Path) -> dict[str, np.ndarray]:
    """A user ramp log: CSV with ``t_s``, ``omega_d`` [rad/s], optional ``on_ramp`` (0/1).

    :raises ValueError: ``pme_log: ...`` naming the line and column: a missing column, a time that
        does not increase, an ω_d that is not finite or beyond what the robot can do
        (:data:`sphere_env.tasks.termination.MAX_RATE_RAD_S`), an ``on_ramp`` other than 0/1, fewer
        than 2 samples on the ramp.
    """
    import pandas as pd

    from sphere_env.schemas import shown
    from sphere_env.tasks.termination import MAX_RATE_RAD_S

    try:
        df = pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError) as err:
        raise ValueError(f"pme_log: cannot read {str(path)!r}: {err}") from None
    for col in ("t_s", "omega_d"):
        if col not in df:
            raise ValueError(f"pme_log: {str(path)!r} has no column {col!r} (needs t_s, omega_d[, on_ramp])")
    if len(df) < 2:
        raise ValueError(f"pme_log: {str(path)!r} has {len(df)} samples; at least 2 are needed")
    try:
        t = df["t_s"].to_numpy(float)
        w = df["omega_d"].to_numpy(float)
    except ValueError as err:
        raise ValueError(f"pme_log: {str(path)!r}: t_s and omega_d must be numbers ({err})") from None
    if not (np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)):
        raise ValueError(f"pme_log: {str(path)!r} column t_s must be finite and strictly increasing")
    bad = ~(np.abs(w) <= MAX_RATE_RAD_S)  # NaN and inf too
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"pme_log: {str(path)!r} line {i + 2}, column 'omega_d': {float(w[i])} rad/s; allowed: a finite rate with "
            f"|omega_d| <= {MAX_RATE_RAD_S:g} rad/s (no joint of the robot turns faster; is it in deg/s?)"
        )
    on = np.ones(len(t), bool)
    if "on_ramp" in df:
        flags = pd.to_numeric(df["on_ramp"], errors="coerce").to_numpy(float)
        odd = np.flatnonzero(~np.isin(flags, (0.0, 1.0)))  # text and missing cells are NaN
        if len(odd):
            raise ValueError(
                f"pme_log: {str(path)!r} line {odd[0] + 2}, column 'on_ramp': {shown(df['on_ramp'].astype(object).iloc[odd[0]])}; "
                "allowed: 0 or 1"
            )
        on = flags == 1.0
    if on.sum() < 2:
        raise ValueError(
            f"pme_log: {str(path)!r} has {int(on.sum())} samples with on_ramp = 1; at least 2 are needed to "
            "compare a descent"
        )
    return {"t_s": t - t[0], "omega_d": w, "on_ramp": on}


def pme_log_rows(
    log: Mapping[str, np.ndarray], rows, traces, pressure_kpa: float | None, controller: str = "zero"
) -> list[dict[str, Any]]:
    """PME [%] of each shell model's zero-torque trace against a user log (nearest pressure)."""
    cand = [(r, tr) for r, tr in zip(rows, traces) if r["controller"] == controller]
    if not cand:
        return []
    ps = sorted({r["pressure_kpa"] for r, _ in cand})
    p = ps[0] if pressure_kpa is None else min(ps, key=lambda x: abs(x - pressure_kpa))
    out = []
    for r, tr in cand:
        if r["pressure_kpa"] == p:
            out.append(
                dict(
                    pressure_kpa=p,
                    friction=r["friction"],
                    seed=r["seed"],
                    reference="log",
                    simulation=r["shell_model"],
                    pme_percent=pme_between(log["t_s"], log["omega_d"], log["on_ramp"], tr["t_s"], tr["omega_d"]),
                )
            )
    return out


def aggregate(rows: Sequence[Mapping[str, Any]], by: Sequence[str]) -> list[dict[str, Any]]:
    """Mean (and std) of the metrics per group ``by``; success rate."""
    groups: dict[tuple, list] = {}
    for r in rows:
        groups.setdefault(tuple(r[k] for k in by), []).append(r)
    out = []
    for key, rs in groups.items():
        d = dict(zip(by, key))
        d["episodes"] = len(rs)
        d["success_rate"] = float(np.mean([r["is_success"] for r in rs]))
        d["reached_runout_rate"] = float(np.mean([r["reached_runout"] for r in rs]))
        for m in (
            "return",
            "tracking_rmse_rad_s",
            "mean_omega_d_rad_s",
            "lateral_drift_m",
            "energy_j",
            "peak_torque_nm",
            "time_on_ramp_s",
        ):
            v = np.array([r[m] for r in rs], float)
            d[m] = float(np.nanmean(v))
            d[m + "_std"] = float(np.nanstd(v))
        out.append(d)
    return out


# (key, header, format) of the report's tables
_CONTROLLER_COLUMNS = [
    ("controller", "controller", ""),
    ("episodes", "episodes", "{:d}"),
    ("success_rate", "success", "{:.0%}"),
    ("reached_runout_rate", "reached run-out", "{:.0%}"),
    ("return", "return", "{:.2f}"),
    ("tracking_rmse_rad_s", "tracking RMSE rad/s", "{:.2f}"),
    ("lateral_drift_m", "lateral drift m", "{:.3f}"),
    ("energy_j", "energy J", "{:.1f}"),
    ("peak_torque_nm", "peak torque N m", "{:.1f}"),
    ("time_on_ramp_s", "time on ramp s", "{:.2f}"),
]
_CELL_COLUMNS = [
    ("controller", "controller", ""),
    ("shell_model", "shell model", ""),
    ("friction", "friction", ""),
    ("pressure_kpa", "pressure kPa", "{:g}"),
    ("success_rate", "success", "{:.0%}"),
    ("reached_runout_rate", "reached run-out", "{:.0%}"),
    ("return", "return", "{:.2f}"),
    ("tracking_rmse_rad_s", "tracking RMSE rad/s", "{:.2f}"),
    ("mean_omega_d_rad_s", "mean ω_d rad/s", "{:.2f}"),
    ("lateral_drift_m", "lateral drift m", "{:.3f}"),
    ("energy_j", "energy J", "{:.1f}"),
    ("peak_torque_nm", "peak torque N m", "{:.1f}"),
]
_PME_COLUMNS = [
    ("reference", "reference", ""),
    ("simulation", "simulation", ""),
    ("friction", "friction", ""),
    ("pressure_kpa", "pressure kPa", "{:g}"),
    ("pme", "PME %", ""),
]


def _header(spec: SweepSpec, n_rows: int, wall_s: float, executor: str, total_episodes: int | None) -> list[str]:
    """The report's title, its grid, time, machine and controllers."""
    from sphere_env.provenance import machine_info

    info = machine_info()
    return [
        "# Controller evaluation",
        "",
        f"`{spec.env_id}`, randomization off; pressures {', '.join(f'{p:g}' for p in spec.pressures_kpa)} kPa × "
        f"shell models {', '.join(spec.shell_models)} × friction {', '.join(spec.frictions)} × seeds "
        f"{', '.join(map(str, spec.seeds))} → {n_rows} episodes"
        + (f" ({total_episodes} with the conditions below)" if total_episodes not in (None, n_rows) else "")
        + f" in {wall_s:.0f} s ({executor}).",
        f"Machine: {info['cpu']}, {info['cores']} cores; drake {info['drake']}, torch {info['torch']}, "
        f"sb3 {info['stable_baselines3']}, commit {info['commit']}.",
        "",
        "Controllers: " + ", ".join(f"`{c.label}` = `{c.spec}`" for c in spec.controllers),
        "",
    ]


def _pme_section(pmes: Sequence[Mapping[str, Any]]) -> list[str]:
    """The report's section on the Point Mean Error of the zero-torque descents."""
    from sphere_env.reporting import markdown_table

    return [
        "## Point Mean Error (eq. 12), zero-torque descent",
        "",
        "PME = mean over the reference's on-ramp samples of (ω_e − ω_s)/ω_e × 100 %, ω_e the "
        f"reference's and ω_s the simulation's drive velocity (samples with |ω_e| < {PME_MIN_SPEED_RAD_S} "
        "rad/s, the release, left out); positive when "
        "the simulation underestimates the reference. Mean ± std over seeds.",
        "",
        markdown_table(aggregate_pme(pmes), _PME_COLUMNS),
        "",
    ]


def write_report(
    out: Path,
    spec: SweepSpec,
    rows,
    agg_model,
    agg_ctrl,
    pmes,
    files: Mapping[str, Path],
    wall_s: float,
    executor: str,
    extra: str = "",
    conditions: str = "",
    total_episodes: int | None = None,
) -> Path:
    """``report.md``: the nominal grid's ``rows`` and aggregates, the PME, then ``conditions`` (the
    section on the sweep's faults and calibrations, Markdown; ``total_episodes``: the sweep's
    episodes with them) and the files."""
    from sphere_env.reporting import markdown_table

    lines = _header(spec, len(rows), wall_s, executor, total_episodes)
    if extra:
        lines += [extra, ""]
    lines += ["## Summary per controller (all cells)", "", markdown_table(agg_ctrl, _CONTROLLER_COLUMNS), ""]
    cells = sorted(agg_model, key=lambda a: (a["controller"], a["shell_model"], a["friction"], a["pressure_kpa"]))
    lines += [
        "## Per controller, shell model and pressure (mean over seeds)",
        "",
        markdown_table(cells, _CELL_COLUMNS),
        "",
    ]
    if conditions:
        lines += [conditions]
    if pmes:
        lines += _pme_section(pmes)
    lines += ["## Files", ""] + [
        f"- {k}: `{v.relative_to(out) if v.is_relative_to(out) else v}`" for k, v in files.items()
    ]
    path = out / "report.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def aggregate_pme(pmes: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    groups: dict[tuple, list[float]] = {}
    for r in pmes:
        groups.setdefault((r["reference"], r["simulation"], r["friction"], r["pressure_kpa"]), []).append(
            r["pme_percent"]
        )
    return [
        dict(
            reference=k[0],
            simulation=k[1],
            friction=k[2],
            pressure_kpa=k[3],
            pme=f"{np.mean(v):+.1f} ± {np.std(v):.1f}",
        )
        for k, v in sorted(groups.items())
    ]
