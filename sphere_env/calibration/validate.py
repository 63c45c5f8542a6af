"""Validation: any log against any shell model, with RMSE, PME (eq. 12) and overlay plots.

Each trial is simulated on the fixture its manifest names, from the logged initial state, with
every requested shell model. Reported per trial and model: RMSE of φ and θ [rad]; of ω_d [rad/s]
where the log has ω_d (measured or derived, see :mod:`sphere_env.calibration.logs`); of the
pendulum pitch α [rad] on ``free`` windows where both the log and the simulation carry it; and
the Point Mean Error of ω_d (paper eq. 12) only on ramp trials, i.e. those whose manifest names the
on-ramp samples (``ramp_window_s``): on flat ground the robot does not roll down anything and a
PME means nothing.

Trials run on a process pool with ``workers`` > 1 (:func:`sphere_env.parallel.run_parallel`); each
worker builds its own twins, one per (fixture, model, pressure), and results keep trial order.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Iterable, Mapping, Sequence

from pydantic import BeforeValidator

from sphere_env.analysis.metrics import pme_percent, rmse
from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.simulate import SimTrace, simulate_log
from sphere_env.files import write_text_atomic
from sphere_env.parallel import run_parallel
from sphere_env.physics import Twin, TwinConfig
from sphere_env.plotting import save_figure
from sphere_env.reporting import markdown_table, number
from sphere_env.schemas import Schema
from sphere_env.schemas import number as bounded
from sphere_env.schemas import validate as validate_schema

METRICS = ("phi", "theta", "omega_d")
#: RMSE over fewer samples compares nothing (the first sample is the simulation's initial state).
MIN_COMPARED_SAMPLES = 3


@dataclass
class ValidationRow:
    """One trial × model: RMSE per channel [rad or rad/s] (NaN if not compared), PME [%] (NaN if
    not a ramp trial). ``rmse`` may also hold ``pendulum_pitch`` on free windows."""

    trial: str
    model: str
    fixture: str
    rmse: dict[str, float]
    pme_percent: float
    trace: SimTrace | None = None
    derived: dict[str, str] = field(default_factory=dict)
    window_s: tuple[float, float] | None = None
    #: A driven window's motor torques (:meth:`~sphere_env.calibration.driven.DrivenTrace.torque_summary`).
    torques: dict[str, dict[str, float]] | None = None

    def as_dict(self) -> dict[str, Any]:
        return {
            "trial": self.trial,
            "model": self.model,
            "fixture": self.fixture,
            "rmse": self.rmse,
            "pme_percent": self.pme_percent,
        }

    def record(self) -> dict[str, Any]:
        """The machine-readable record of ``validate --json``: a metric appears only where it was
        compared (``rmse_omega_d_rad_s`` where ω_d is logged, ``pme_percent`` on ramp trials,
        ``rmse_pendulum_pitch_rad`` on free windows); ``rmse_phi_rad``/``rmse_theta_rad`` are
        always present (null when the log lacks the channel)."""

        def val(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        out: dict[str, Any] = {
            "trial": self.trial,
            "model": self.model,
            "fixture": self.fixture,
            "rmse_phi_rad": val(self.rmse.get("phi", math.nan)),
            "rmse_theta_rad": val(self.rmse.get("theta", math.nan)),
        }
        if math.isfinite(self.rmse.get("omega_d", math.nan)):
            out["rmse_omega_d_rad_s"] = self.rmse["omega_d"]
            if "omega_d" in self.derived:
                out["omega_d_derived_from"] = self.derived["omega_d"]
        if math.isfinite(self.rmse.get("pendulum_pitch", math.nan)):
            out["rmse_pendulum_pitch_rad"] = self.rmse["pendulum_pitch"]
        if math.isfinite(self.rmse.get("heading_rate", math.nan)):
            out["rmse_heading_rate_rad_s"] = self.rmse["heading_rate"]
        if self.torques is not None:
            out["kind"], out["torques"] = "driven", self.torques
        if math.isfinite(self.pme_percent):
            out["pme_percent"] = self.pme_percent
        if self.window_s is not None:
            out["window_s"] = list(self.window_s)
        return out


def validate_log(twin: Twin, log: RobotLog, theta_offset_rad: float = 0.0) -> ValidationRow:
    """Simulate ``log`` on ``twin`` (built for the log's fixture) and score it.

    A log shorter than :data:`MIN_COMPARED_SAMPLES` is not simulated: every metric is NaN.
    """
    enough = len(log.t_s) >= MIN_COMPARED_SAMPLES
    if not enough:
        nan = float("nan")
        return ValidationRow(
            log.name,
            twin.config.shell_model,
            twin.config.fixture,
            {ch: nan for ch in METRICS},
            nan,
            None,
            dict(log.derived),
            log.window_s,
        )
    if (log.meta or {}).get("kind") == "driven":
        return _validate_driven(twin, log)
    # A free window starts from the logged state (the log's θ, θ̇, φ, φ̇, α, α̇, q̇_d at the
    # window start): simulate_log builds it with simulate.initial_state_from_log.
    tr = simulate_log(twin, log, theta_offset_rad, pressure_kpa=log.pressure_kpa)
    out = {}
    for ch in METRICS:
        out[ch] = rmse(tr[ch], log[ch]) if enough and log.has(ch) else float("nan")
    if enough and log.fixture == "free" and log.has("pendulum_pitch") and "pendulum_pitch" in tr.channels:
        out["pendulum_pitch"] = rmse(tr["pendulum_pitch"], log["pendulum_pitch"])
    pme = float("nan")
    win = log.meta.get("ramp_window_s") if log.meta else None
    if enough and log.has("omega_d") and win is not None:  # PME only on ramp trials
        mask = (log.t_s >= win[0]) & (log.t_s <= win[1])
        pme = pme_percent(log["omega_d"], tr["omega_d"], mask)
    return ValidationRow(
        log.name, twin.config.shell_model, twin.config.fixture, out, pme, tr, dict(log.derived), log.window_s
    )


def _validate_driven(twin: Twin, log: RobotLog) -> ValidationRow:
    """A driven window: the pendulum tracks the logged θ and α, the shell responds
    (:mod:`~sphere_env.calibration.driven`); RMSE of ω_d, ψ̇ (``heading_rate``), φ and the tracked θ, α."""
    from sphere_env.calibration.driven import driven_replay, driven_rmse

    tr = driven_replay(twin, log, pressure_kpa=log.pressure_kpa)
    err = driven_rmse(tr, log)
    row = ValidationRow(log.name, twin.config.shell_model, twin.config.fixture, err, math.nan, None, dict(log.derived))
    row.window_s, row.torques = log.window_s, tr.torque_summary()
    return row


_TWINS: dict[tuple, Twin] = {}  # per process: one twin per configuration, reused across jobs


def _validate_job(job: Mapping[str, Any]) -> ValidationRow:
    """One (log, model) validation; module level so process pools can pickle it."""
    key = tuple(sorted((k, repr(v)) for k, v in job["config"].items()))
    if key not in _TWINS:
        _TWINS[key] = Twin(TwinConfig(**job["config"]))
    row = validate_log(_TWINS[key], job["log"])
    if not job.get("keep_trace", True):
        row.trace = None
    return row


def validate(
    logs: Sequence[RobotLog],
    models: Iterable[str] = ("point", "injected", "hydroelastic"),
    steer_friction: Any = "majd",
    drive_friction: Any = "majd",
    calibration: str | Path | None = None,
    time_step_s: float | None = None,
    default_pressure_kpa: float | None = None,
    workers: int | None = 1,
) -> list[ValidationRow]:
    """Validate every log against every shell model; one twin per (fixture, model, pressure) and process.

    A log without a recorded pressure runs at ``default_pressure_kpa`` (None: the calibration's
    nominal pressure, which for the shipped calibration is the steer_free anchor). ``time_step_s``
    None is the twin's default step. ``workers`` > 1 spreads the (log, model) jobs over processes.
    """
    jobs = []
    for model in models:
        for log in logs:
            p = log.pressure_kpa if log.pressure_kpa is not None else default_pressure_kpa
            config = dict(
                fixture=log.fixture or "free",
                shell_model=model,
                steer_friction=steer_friction,
                drive_friction=drive_friction,
                calibration=calibration,
                pressure_kpa=p,
            )
            if time_step_s is not None:
                config["time_step_s"] = time_step_s
            jobs.append({"config": config, "log": log})
    return run_parallel(_validate_job, jobs, workers=workers)


#: What :func:`fit_record` copies from a calibration's ``steer_fit.models.<model>`` record.
FIT_FIELDS = ("form", "params", "held", "ci95", "ci95_over_windows", "unidentified", "held_out_rmse_rad")


def fit_record(calibration: Mapping[str, Any], model: str) -> dict[str, Any] | None:
    """How the calibration's ``model`` (``injected``, ``hydroelastic``) was fitted, for ``validate
    --json``: the windows it was fitted on (``fit_on``), its parameters with their 95 % intervals
    (``ci95``; over windows, ``ci95_over_windows``, where left-one-out folds ran), the parameters
    marked ``unidentified`` or ``held``, and each window's held-out error (``held_out_rmse_rad``).
    Read from the file's ``steer_fit`` record (written by ``steer-fit``) or, for a file fitted
    before that record existed, its ``provenance.<model>_fit`` entry (with the form choice's
    held-out errors, ``provenance.form_choice``, as ``cross_validation``). None: no record of a fit
    (``point`` has nothing fitted; a hand-written calibration)."""
    sf = calibration.get("steer_fit") or {}
    if model in (sf.get("models") or {}):
        rec = sf["models"][model]
        return {"fit_on": list(sf.get("fit_on") or []), **{k: rec[k] for k in FIT_FIELDS if k in rec}}
    prov = (calibration.get("provenance") or {}).get(f"{model}_fit")
    if isinstance(prov, Mapping) and "fit_on" in prov:
        out = {"fit_on": list(prov["fit_on"])}
        out.update({k: prov[k] for k in ("form", "ci95") if k in prov})
        if "values" in prov:
            out["params"] = prov["values"]
        choice = calibration["provenance"].get("form_choice")
        if model == "injected" and isinstance(choice, Mapping):
            out["cross_validation"] = dict(choice)
        return out
    return None


def write_records(
    path: str | Path, rows: Sequence[ValidationRow], calibration: Mapping[str, Any] | None = None
) -> Path:
    """Write ``[row.record() ...]`` as JSON, atomically (temp file in the same folder, then rename).
    With the ``calibration`` mapping the rows ran with, each row of a fitted model also carries
    ``fit`` (:func:`fit_record`) and ``held_out``: whether its trial was left out of that fit (so
    its RMSE is a test, not a fit); null where the calibration records no fit."""
    out = []
    for r in rows:
        rec = r.record()
        if calibration is not None and r.model != "point":
            fit = fit_record(calibration, r.model)
            rec["held_out"] = None if fit is None else r.trial not in fit["fit_on"]
            rec["fit"] = fit
        out.append(rec)
    return write_text_atomic(Path(path), json.dumps(out, indent=1) + "\n")


def _limit_text(value: Any) -> Any:
    """A limit as written on the command line (``0.1``) as the number it reads as; other text
    unchanged, for the number check to refuse by name."""
    try:
        return float(value) if isinstance(value, str) else value
    except ValueError:
        return value


Limit = Annotated[bounded(gt=0.0, words="NAME=LIMIT with LIMIT a finite number > 0"), BeforeValidator(_limit_text)]


class Tolerances(Schema):
    """``--tol`` limits: RMSE of φ ``phi``, θ ``theta`` [rad], ω_d ``omega_d``, ψ̇ ``heading_rate`` [rad/s], α
    ``pendulum_pitch`` [rad] and |PME| ``pme`` [%]."""

    phi: Limit = None  # None: not checked
    theta: Limit = None
    omega_d: Limit = None
    pendulum_pitch: Limit = None
    heading_rate: Limit = None
    pme: Limit = None


#: The names a tolerance may take.
TOLERANCE_KEYS = tuple(Tolerances.model_fields)


def parse_tolerances(items: Sequence[str] | None) -> dict[str, float]:
    """``["phi=0.1", "theta=0.12", "pme=10"]`` -> {channel: limit}; RMSE in rad (rad/s), |PME| in %.
    Loaded through :class:`Tolerances`: an unknown name or a limit that is not a number > 0 is a
    ValueError naming it."""
    given = {key.strip(): val for key, _, val in (item.partition("=") for item in items or ())}
    spec = validate_schema(Tolerances, given, "--tol")
    return {key: getattr(spec, key) for key in given}


def tolerance_failures(
    rows: Sequence[ValidationRow], tol: Mapping[str, float], models: Iterable[str] | None = None
) -> list[str]:
    """Messages for every (trial, model, metric) above its tolerance, and for every one the
    tolerance could not be checked on (channel not logged, too few samples, PME off a ramp);
    only ``models`` if given. An empty list means every requested limit was checked and met."""
    keep = set(models) if models is not None else None
    bad = []
    checked = 0
    for r in rows:
        if keep is not None and r.model not in keep:
            continue
        for key, lim in tol.items():
            val = abs(r.pme_percent) if key == "pme" else r.rmse.get(key, float("nan"))
            if not math.isfinite(val):
                why = (
                    "PME is computed on ramp trials only (manifest 'ramp_window_s')"
                    if key == "pme"
                    else f"the log has no {key!r} channel or fewer than {MIN_COMPARED_SAMPLES} samples"
                )
                bad.append(f"{r.trial} / {r.model}: {key} not compared ({why})")
            elif val > lim:
                bad.append(f"{r.trial} / {r.model}: {key} = {val:.4g} exceeds tolerance {lim:.4g}")
            else:
                checked += 1
    if tol and not bad and checked == 0:
        bad.append("nothing compared: no trial and model matched the tolerances (check --tol-models)")
    return bad


def validation_table(rows: Sequence[ValidationRow]) -> str:
    """A Markdown table of the rows (RMSE in rad or rad/s, PME in %)."""
    table = [
        {
            "trial": r.trial,
            "fixture": r.fixture,
            "model": r.model,
            "phi": r.rmse["phi"],
            "theta": r.rmse["theta"],
            "omega_d": r.rmse["omega_d"],
            "alpha": r.rmse.get("pendulum_pitch", math.nan),
            "pme": r.pme_percent,
        }
        for r in rows
    ]
    return markdown_table(
        table,
        [
            ("trial", "trial", ""),
            ("fixture", "fixture", ""),
            ("model", "model", ""),
            ("phi", "RMSE φ [rad]", number),
            ("theta", "RMSE θ [rad]", number),
            ("omega_d", "RMSE ω_d [rad/s]", number),
            ("alpha", "RMSE α [rad]", number),
            ("pme", "PME [%]", lambda x: number(x, 1)),
        ],
        align="lllrrrrr",
    )


def plot_overlays(path: str | Path, logs: Sequence[RobotLog], rows: Sequence[ValidationRow]) -> Path:
    """One panel per trial and logged channel: measured vs every model."""
    from sphere_env.plotting import pyplot

    plt = pyplot()

    panels = [(log, ch) for log in logs for ch in METRICS if log.has(ch)]
    fig, axes = plt.subplots(len(panels), 1, figsize=(8, 2.2 * len(panels)), squeeze=False)
    for ax, (log, ch) in zip(axes[:, 0], panels):
        ax.plot(log.t_s, log[ch], "k.", ms=3, label="measured")
        for r in rows:
            if r.trial == log.name and r.trace is not None:
                ax.plot(r.trace.t_s, r.trace[ch], "-", lw=1.2, label=f"{r.model} ({r.rmse[ch]:.3f})")
        unit = "rad/s" if ch == "omega_d" else "rad"
        ax.set_ylabel(f"{ch} [{unit}]")
        ax.set_title(log.name, fontsize=9)
        ax.legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("time [s]")
    fig.tight_layout()
    return save_figure(fig, path, dpi=100)
