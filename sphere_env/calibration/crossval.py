"""Cross-validation of the shell fit: fit on one trial or event, test on the others of its group.

For every group of segments recorded at one (possibly unknown) pressure — the ``steer_free``
trials, the free-motion events of one robot log — and every shell model, the shell is fitted on
each segment in turn and the fitted calibration is validated on every segment of the group. The
fit segment's own figure is a fit, not a test; the others are held out. ``point`` (rigid) has
nothing to fit and is validated once, with the given calibration, as the baseline.

The fit is one call, :func:`fit_calibration`, so a different fitting routine plugs in without
touching the tables.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from sphere_env.calibration.decay import write_yaml
from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.validate import validate
from sphere_env.models.shell import ShellCalibration
from sphere_env.reporting import markdown_table, number

FITTED_MODELS = ("injected", "hydroelastic")

#: fit(train_logs, model, pressure_kpa, base_calibration, steer_friction) -> (params, calibration mapping)
FitFn = Callable[[Sequence[RobotLog], str, float, ShellCalibration, Any], "tuple[dict[str, float], dict[str, Any]]"]


def fit_calibration(
    train: Sequence[RobotLog],
    model: str,
    pressure_kpa: float,
    base: ShellCalibration,
    steer_friction: Any,
    max_nfev: int = 60,
    forms: Sequence[str] | None = None,
) -> tuple[dict[str, float], dict[str, Any]]:
    """Fit ``model`` on ``train`` exactly as ``steer-fit --fit-on`` does (:func:`steer_fit`: the
    steer-law form chosen by held-out error within ``train``; ``hydroelastic`` fitted on top of an
    ``injected`` fit of the same segments, so nothing of a held-out segment leaks in through the
    base calibration; no leave-one-window-out within ``train``: the caller holds segments out);
    returns (params, calibration)."""
    from sphere_env.calibration.steer_fit import steer_fit
    from sphere_env.models.calibration_schema import STEER_LAW_FORMS

    models = ("injected",) if model == "injected" else ("injected", model)
    raw, record = steer_fit(
        list(train),
        models,
        pressure_kpa,
        base,
        forms=tuple(forms or STEER_LAW_FORMS),
        steer_friction=steer_friction,
        max_nfev=max_nfev,
        hold_out_windows=False,
    )
    params: dict[str, float] = {}
    for m in models:
        params.update({f"{m}.{k}" if m != model else k: v for k, v in record["models"][m]["params"].items()})
    return params, raw


def cross_validate(
    groups: Mapping[str, Sequence[RobotLog]],
    models: Sequence[str] = ("point", "injected", "hydroelastic"),
    calibration: str | Path | None = None,
    pressure_kpa: float | None = None,
    steer_friction: Any = "majd_steer",
    drive_friction: Any = "majd_drive",
    fit: FitFn | None = None,
    workers: int | None = 1,
) -> list[dict[str, Any]]:
    """Every (group, model, fit segment): the fitted parameters and the validation record of every
    segment of the group (``role`` "fit" or "held out"). ``pressure_kpa`` None: the calibration's
    nominal pressure (the groups' pressures are not recorded)."""
    base = ShellCalibration.load(calibration)
    p0 = base.nominal_pressure_kpa if pressure_kpa is None else base.check_pressure(pressure_kpa)
    fit = fit or (lambda tr, m, p, b, sf: fit_calibration(tr, m, p, b, sf))
    out: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for group, logs in groups.items():
            for model in models:
                trains: list[RobotLog | None] = list(logs) if model in FITTED_MODELS else [None]
                for train in trains:
                    if train is None:
                        params, cal_path = {}, calibration
                    else:
                        try:
                            params, raw = fit([train], model, p0, base, steer_friction)
                        except (ValueError, RuntimeError) as err:  # reported in the table, not fatal
                            out.append(
                                {
                                    "group": group,
                                    "model": model,
                                    "fit_on": train.name,
                                    "pressure_kpa": p0,
                                    "params": {},
                                    "records": [],
                                    "rmse_rad": {},
                                    "error": str(err),
                                }
                            )
                            continue
                        cal_path = write_yaml(Path(tmp) / f"{group}_{model}_{train.name}.yaml", raw)
                    rows = validate(
                        logs,
                        [model],
                        steer_friction=steer_friction,
                        drive_friction=drive_friction,
                        calibration=cal_path,
                        default_pressure_kpa=p0,
                        workers=workers,
                    )
                    recs = []
                    for r in rows:
                        rec = r.record()
                        rec["role"] = "fit" if train is not None and r.trial == train.name else "held out"
                        recs.append(rec)
                    out.append(
                        {
                            "group": group,
                            "model": model,
                            "fit_on": None if train is None else train.name,
                            "pressure_kpa": p0,
                            "params": params,
                            "records": recs,
                            "rmse_rad": {r.trial: dict(r.rmse) for r in rows},
                        }
                    )
    return out


def crossval_table(results: Sequence[Mapping[str, Any]]) -> str:
    """Markdown: one row per (group, model, fit segment, tested segment)."""
    rows = []
    for x in results:
        pr = ", ".join(f"{k}={v:.4g}" for k, v in x["params"].items() if isinstance(v, (int, float))) or "—"
        if x.get("error"):
            rows.append(
                {
                    "group": x["group"],
                    "model": x["model"],
                    "fit_on": x["fit_on"],
                    "trial": "—",
                    "role": f"fit failed: {x['error']}",
                }
            )
        for rec in x["records"]:
            rows.append(
                {
                    "group": x["group"],
                    "model": x["model"],
                    "fit_on": x["fit_on"] or "— (nothing to fit)",
                    "trial": rec["trial"],
                    "role": rec["role"] if x["fit_on"] else "baseline",
                    "phi": number(rec.get("rmse_phi_rad")),
                    "theta": number(rec.get("rmse_theta_rad")),
                    "alpha": number(rec.get("rmse_pendulum_pitch_rad")),
                    "params": pr,
                }
            )
    return markdown_table(
        rows,
        [
            ("group", "group", ""),
            ("model", "model", ""),
            ("fit_on", "fitted on", ""),
            ("trial", "tested on", ""),
            ("role", "role", ""),
            ("phi", "RMSE φ [rad]", ""),
            ("theta", "RMSE θ [rad]", ""),
            ("alpha", "RMSE α [rad]", ""),
            ("params", "parameters", ""),
        ],
        align="lllllrrrl",
    )


def held_out_summary(results: Sequence[Mapping[str, Any]]) -> dict[tuple[str, str], dict[str, float]]:
    """(group, model) -> worst held-out and worst fit φ RMSE [rad] (NaN when there is none)."""
    out: dict[tuple[str, str], dict[str, float]] = {}
    for x in results:
        d = out.setdefault(
            (x["group"], x["model"]), {"worst_held_out_phi_rad": math.nan, "worst_fit_phi_rad": math.nan}
        )
        for rec in x["records"]:
            v = rec.get("rmse_phi_rad")
            if v is None:
                continue
            key = "worst_fit_phi_rad" if rec["role"] == "fit" and x["fit_on"] else "worst_held_out_phi_rad"
            d[key] = v if math.isnan(d[key]) else max(d[key], v)
    return out
