"""Validation: any log against any shell model, with RMSE, PME (eq. 12) and overlay plots.

Each trial is simulated on the fixture its manifest names, from the logged initial state, with
every requested shell model. Reported per trial and model: RMSE of φ and θ [rad] (and of ω_d
[rad/s] where logged), and the Point Mean Error of ω_d (paper eq. 12) over the on-ramp samples
(``ramp_window_s`` in the manifest; the whole log if absent).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence


from sphere_env.calibration.logs import RobotLog
from sphere_env.analysis.metrics import pme_percent, rmse
from sphere_env.calibration.simulate import SimTrace, simulate_log
from sphere_env.physics.twin import Twin, TwinConfig
from sphere_env.plotting import save_figure

METRICS = ("phi", "theta", "omega_d")


@dataclass
class ValidationRow:
    """One trial × model: RMSE per channel [rad or rad/s] (NaN if not logged), PME [%]."""

    trial: str
    model: str
    fixture: str
    rmse: dict[str, float]
    pme_percent: float
    trace: SimTrace | None = None

    def as_dict(self) -> dict[str, Any]:
        return {"trial": self.trial, "model": self.model, "fixture": self.fixture,
                "rmse": self.rmse, "pme_percent": self.pme_percent}


def validate_log(twin: Twin, log: RobotLog, theta_offset_rad: float = 0.0) -> ValidationRow:
    """Simulate ``log`` on ``twin`` (built for the log's fixture) and score it."""
    tr = simulate_log(twin, log, theta_offset_rad, pressure_kpa=log.pressure_kpa)
    out = {}
    for ch in METRICS:
        out[ch] = rmse(tr[ch], log[ch]) if log.has(ch) else float("nan")
    pme = float("nan")
    if log.has("omega_d"):
        win = log.meta.get("ramp_window_s") if log.meta else None
        mask = None if win is None else (log.t >= win[0]) & (log.t <= win[1])
        pme = pme_percent(log["omega_d"], tr["omega_d"], mask)
    return ValidationRow(log.name, twin.config.shell_model, twin.config.fixture, out, pme, tr)


def validate(
    logs: Sequence[RobotLog],
    models: Iterable[str] = ("point", "injected", "hydroelastic"),
    steer_friction: Any = "majd",
    drive_friction: Any = "majd",
    calibration: str | Path | None = None,
    time_step_s: float = 0.005,
    default_pressure_kpa: float | None = None,
) -> list[ValidationRow]:
    """Validate every log against every shell model; one twin is built per (fixture, model, pressure).

    A log without a recorded pressure runs at ``default_pressure_kpa`` (None: the calibration's
    nominal pressure, which for the shipped calibration is the steer_free anchor).
    """
    rows = []
    twins: dict[tuple, Twin] = {}
    for model in models:
        for log in logs:
            fixture = log.fixture or "free"
            p = log.pressure_kpa if log.pressure_kpa is not None else default_pressure_kpa
            key = (fixture, model, p)
            if key not in twins:
                twins[key] = Twin(TwinConfig(fixture=fixture, shell_model=model, steer_friction=steer_friction,
                                             drive_friction=drive_friction, calibration=calibration,
                                             pressure_kpa=p, time_step_s=time_step_s))
            rows.append(validate_log(twins[key], log))
    return rows


def parse_tolerances(items: Sequence[str] | None) -> dict[str, float]:
    """``["phi=0.1", "theta=0.12", "pme=10"]`` -> {channel: limit}; RMSE in rad (rad/s), |PME| in %."""
    out: dict[str, float] = {}
    for item in items or ():
        key, sep, val = item.partition("=")
        key = key.strip()
        if not sep or key not in METRICS + ("pme",):
            raise ValueError(f"--tol: value {item!r}; allowed: NAME=LIMIT with NAME in {list(METRICS) + ['pme']}")
        try:
            lim = float(val)
        except ValueError:
            raise ValueError(f"--tol: value {item!r}: limit {val!r} is not a number") from None
        if not math.isfinite(lim) or lim <= 0:
            raise ValueError(f"--tol: value {item!r}: limit must be a positive number")
        out[key] = lim
    return out


def tolerance_failures(rows: Sequence[ValidationRow], tol: Mapping[str, float],
                       models: Iterable[str] | None = None) -> list[str]:
    """Messages for every (trial, model, metric) above its tolerance; only ``models`` if given."""
    keep = set(models) if models is not None else None
    bad = []
    for r in rows:
        if keep is not None and r.model not in keep:
            continue
        for key, lim in tol.items():
            val = abs(r.pme_percent) if key == "pme" else r.rmse.get(key, float("nan"))
            if math.isfinite(val) and val > lim:
                bad.append(f"{r.trial} / {r.model}: {key} = {val:.4g} exceeds tolerance {lim:.4g}")
    return bad


def markdown_table(rows: Sequence[ValidationRow]) -> str:
    """A Markdown table of the rows (RMSE in rad or rad/s, PME in %)."""
    lines = ["| trial | fixture | model | RMSE φ [rad] | RMSE θ [rad] | RMSE ω_d [rad/s] | PME [%] |",
             "| --- | --- | --- | ---: | ---: | ---: | ---: |"]
    f = lambda x, d=3: "—" if not math.isfinite(x) else f"{x:.{d}f}"  # noqa: E731
    for r in rows:
        lines.append(f"| {r.trial} | {r.fixture} | {r.model} | {f(r.rmse['phi'])} | {f(r.rmse['theta'])} | "
                     f"{f(r.rmse['omega_d'])} | {f(r.pme_percent, 1)} |")
    return "\n".join(lines)


def plot_overlays(path: str | Path, logs: Sequence[RobotLog], rows: Sequence[ValidationRow]) -> Path:
    """One panel per trial and logged channel: measured vs every model."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [(log, ch) for log in logs for ch in METRICS if log.has(ch)]
    fig, axes = plt.subplots(len(panels), 1, figsize=(8, 2.2 * len(panels)), squeeze=False)
    for ax, (log, ch) in zip(axes[:, 0], panels):
        ax.plot(log.t, log[ch], "k.", ms=3, label="measured")
        for r in rows:
            if r.trial == log.name and r.trace is not None:
                ax.plot(r.trace.t, r.trace[ch], "-", lw=1.2, label=f"{r.model} ({r.rmse[ch]:.3f})")
        unit = "rad/s" if ch == "omega_d" else "rad"
        ax.set_ylabel(f"{ch} [{unit}]")
        ax.set_title(log.name, fontsize=9)
        ax.legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("time [s]")
    fig.tight_layout()
    return save_figure(fig, path, dpi=100)
