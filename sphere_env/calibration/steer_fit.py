"""What ``calibrate steer-fit`` does: the shell models fitted in order on free-motion segments, the
steer-law form chosen by held-out error, and every segment's error when it is left out of the fit.

:func:`steer_fit` fits each model with :func:`~sphere_env.calibration.shell_fit.fit_shell`, on top of
the previous model's calibration; :func:`cross_validate` scores forms and models on held-out
segments (or held-out blocks of one segment), its folds in worker processes; :func:`choose_form`
picks the form with the least mean held-out φ RMSE. Parameters the data do not pin down may be held
(``hold``: name -> value, :func:`~sphere_env.calibration.shell_params.check_hold`); several candidate
holds are chosen between by held-out error the same way as forms (:func:`choose_variant`).
"""

from __future__ import annotations

import math
from functools import partial
from typing import Any, Mapping, Sequence

import numpy as np

from sphere_env.calibration.logs import RobotLog
from sphere_env.calibration.shell_fit import FitError, TwinPool, fit_shell, trial_rmse, window
from sphere_env.models.calibration_schema import STEER_LAW_FORMS
from sphere_env.models.friction import FrictionModel
from sphere_env.models.shell import ShellCalibration


def cross_validate(
    logs: Sequence[RobotLog],
    forms: Sequence[str],
    pressure_kpa: float,
    base: ShellCalibration | None = None,
    steer_friction: FrictionModel | str = "majd_steer",
    max_nfev: int = 40,
    blocks: int = 3,
    models: Sequence[str] = ("injected",),
    drive_friction: FrictionModel | str = "majd_drive",
    workers: int | None = 1,
    holds: Sequence[Mapping[str, float]] = ({},),
) -> list[dict[str, Any]]:
    """Held-out φ/θ RMSE [rad] of each steer-law form (and each candidate of ``holds``: parameters
    held instead of fitted) for each shell model in ``models``.

    Two or more segments: leave one segment out, fit on the others, test on it. One segment: cut it
    into ``blocks`` consecutive blocks, each replayed from the logged state at its start; leave one
    block out, fit on the others, test on it (blocked cross-validation: every amplitude of the decay
    is once held out, and no form is judged only on extrapolation from large swings to small ones).
    Within a fold the models are fitted in order, each on top of the previous one's fit as
    :func:`steer_fit` does (``hydroelastic`` after ``injected`` keeps the fold's injected law), so
    nothing of the held-out segment reaches any fit. The (form, fold) fits run on ``workers``
    processes (:func:`~sphere_env.parallel.run_parallel`; 1: in this process).
    Returns one row per (model, form, hold, fold) with the held-out RMSE and the fit; a fold whose fit is
    refused (e.g. a law the robot cannot stand still with) gets RMSE ``inf`` and the reason under
    ``refused``, so that form is never chosen.
    """
    from sphere_env.parallel import run_parallel

    base = base or ShellCalibration.load()
    if len(logs) >= 2:
        folds = [([lg for j, lg in enumerate(logs) if j != i], [logs[i]]) for i in range(len(logs))]
    else:
        (lg,) = logs
        edges = np.linspace(0.0, float(lg.t_s[-1]), blocks + 1)
        parts = [window(lg, a, b, f"{lg.name}[{a:.2f}-{b:.2f} s]") for a, b in zip(edges[:-1], edges[1:])]
        folds = [([p for j, p in enumerate(parts) if j != i], [parts[i]]) for i in range(blocks)]
    jobs = [
        {
            "train": train,
            "test": test,
            "form": form,
            "models": tuple(models),
            "base": dict(base.raw),
            "source": base.source,
            "pressure_kpa": pressure_kpa,
            "steer_friction": steer_friction,
            "drive_friction": drive_friction,
            "max_nfev": max_nfev,
            "hold": dict(hold),
        }
        for form in forms
        for hold in holds
        for train, test in folds
    ]
    return [row for rows in run_parallel(_fold_job, jobs, workers=workers) for row in rows]


def _fold_job(job: Mapping[str, Any]) -> list[dict[str, Any]]:
    """One (form, fold) of :func:`cross_validate`: fit its models in order on the training segments
    (twins built here: Drake diagrams never cross processes) and score the held-out ones."""
    train, test, form, models, p0 = job["train"], job["test"], job["form"], job["models"], job["pressure_kpa"]
    hold = dict(job.get("hold") or {})
    cur = ShellCalibration.from_dict(job["base"], source=job["source"])
    rows: list[dict[str, Any]] = []
    for i, model in enumerate(models):
        where = {"model": model, "form": form, "held": hold, "fit_on": [t.name for t in train]}
        pool = TwinPool(model, job["steer_friction"], drive_friction=job["drive_friction"])
        try:
            fit = fit_shell(
                train,
                model,
                p0,
                steer_friction=job["steer_friction"],
                base=cur,
                form=form if model == "injected" else None,
                max_nfev=job["max_nfev"],
                pool=pool,
                require_convergence=False,
                drive_friction=job["drive_friction"],
                hold=hold,
            )
        except FitError as err:  # this model and every one fitted on top of it are refused
            return rows + [
                dict(where, model=m, test=lg.name, rmse_phi_rad=math.inf, rmse_theta_rad=math.inf, refused=str(err))
                for m in models[i:]
                for lg in test
            ]
        cur = ShellCalibration.from_dict(fit.calibration, source="<cv>")
        pool.install(cur, p0)
        for name, r in trial_rmse(pool, test).items():
            rows.append(
                dict(
                    where,
                    test=name,
                    rmse_phi_rad=r["phi"],
                    rmse_theta_rad=r["theta"],
                    train_rmse_rad=fit.rmse,
                    params=fit.params,
                )
            )
    return rows


def variant_label(form: str, held: Mapping[str, float] | None = None) -> str:
    """How a (form, held parameters) candidate is named in reports: ``saturating`` or
    ``saturating [amplitude_scale_rad=0.07]``."""
    if not held:
        return form
    return f"{form} [{', '.join(f'{k}={v:g}' for k, v in held.items())}]"


def choose_variant(rows: Sequence[Mapping[str, Any]]) -> tuple[str, dict[str, float], dict[str, float]]:
    """The (form, held parameters) candidate with the least mean held-out φ RMSE; ties within 0.1 mrad
    go to the form with fewer parameters (earlier in :data:`STEER_LAW_FORMS`), then to the candidate
    listed first. Returns (form, held, mean held-out φ RMSE per :func:`variant_label`)."""
    cands: dict[str, tuple[str, dict[str, float]]] = {}
    for r in rows:
        cands.setdefault(variant_label(r["form"], r.get("held")), (r["form"], dict(r.get("held") or {})))
    mean = {
        label: float(np.mean([r["rmse_phi_rad"] for r in rows if variant_label(r["form"], r.get("held")) == label]))
        for label in cands
    }
    order = list(cands)
    best = min(mean, key=lambda k: (round(mean[k], 4), list(STEER_LAW_FORMS).index(cands[k][0]), order.index(k)))
    if not math.isfinite(mean[best]):
        raise FitError(f"no steer-law form could be fitted: {[r.get('refused') for r in rows]}")
    return cands[best][0], cands[best][1], mean


def choose_form(rows: Sequence[Mapping[str, Any]]) -> tuple[str, dict[str, float]]:
    """The form with the least mean held-out φ RMSE (ties: fewer parameters, i.e. earlier in the list);
    :func:`choose_variant` without held parameters."""
    form, _, mean = choose_variant(rows)
    return form, mean


def steer_fit(
    logs: Sequence[RobotLog],
    models: Sequence[str],
    pressure_kpa: float,
    base: ShellCalibration,
    forms: Sequence[str] = tuple(STEER_LAW_FORMS),
    steer_friction: FrictionModel | str = "majd_steer",
    drive_friction: FrictionModel | str = "majd_drive",
    max_nfev: int = 60,
    log_to=None,
    hold_out_windows: bool = True,
    workers: int | None = 1,
    holds: Sequence[Mapping[str, float]] = ({},),
) -> tuple[dict[str, Any], dict[str, Any]]:
    """What ``steer-fit`` does: fit each shell model in ``models`` on ``logs``, in order, each on top of
    the previous one's calibration (``hydroelastic`` after ``injected`` keeps the injected ω_n, ζ and
    steer law just fitted). With several ``forms`` and ``injected`` among the models, the steer-law
    form is the one with the least held-out φ RMSE (:func:`cross_validate`, :func:`choose_form`) —
    never the training error. With two or more ``logs`` and ``hold_out_windows``, every model is
    then cross-validated leave-one-window-out with the chosen form (:func:`cross_validate`; the
    injected rows of the form choice are reused when injected is the only model, and are then
    slightly optimistic: the form was picked on them). Returns (calibration mapping, record of the
    fit: per model its parameters, 95 % intervals and ``unidentified`` ones; under
    ``leave_one_window_out`` each window's held-out RMSE); ``log_to`` (e.g. ``print``) receives a
    readable account. ``workers``: processes for the cross-validation folds. ``holds``: candidate
    sets of parameters held instead of fitted (name -> value); with several forms or several
    candidates, the (form, hold) pair is chosen by held-out error as a form alone is, and the chosen
    hold is recorded under ``held`` (each model's held values under ``models.<model>.held``).
    """
    say = log_to or (lambda *_: None)
    record: dict[str, Any] = {"fit_on": [log.name for log in logs], "pressure_kpa": pressure_kpa, "models": {}}
    # the cross-validation of every fold, with the fit's own settings
    cv = partial(
        cross_validate,
        logs,
        pressure_kpa=pressure_kpa,
        base=base,
        steer_friction=steer_friction,
        max_nfev=max_nfev,
        drive_friction=drive_friction,
        workers=workers,
    )
    form, hold = forms[0], dict(holds[0])
    form_rows: list[dict[str, Any]] = []
    if "injected" in models and len(forms) * len(holds) > 1:
        form_rows = cv(forms, holds=holds)
        form, hold = _chosen_variant(form_rows, say)
        record["form_cross_validation"] = [_cv_row(r) for r in form_rows]
    if hold:
        record["held"] = dict(hold)
    raw = dict(base.raw)
    for model in models:
        fit, pool = _fit_model(
            logs, model, pressure_kpa, raw, base, form, hold, steer_friction, drive_friction, max_nfev
        )
        raw = fit.calibration
        _say_fit(say, fit, model, pressure_kpa, record["fit_on"])
        record["models"][model] = dict(fit.as_dict(), pool=pool)
    if hold_out_windows and len(logs) >= 2:
        chosen = variant_label(form, hold)
        if tuple(models) == ("injected",) and form_rows:
            rows = [r for r in form_rows if variant_label(r["form"], r.get("held")) == chosen]
        else:
            rows = cv([form], models=models, holds=(hold,))
        say(f"leave-one-window-out ({chosen!r}; fit on the others -> held-out window: RMSE phi / theta rad):")
        for r in rows:
            say(
                f"  {r['model']:12s} {'+'.join(r['fit_on'])} -> {r['test']}: "
                f"{r['rmse_phi_rad']:.4f} / {r['rmse_theta_rad']:.4f}" + (" (refused)" if r.get("refused") else "")
            )
        record["leave_one_window_out"] = [_cv_row(r) for r in rows]
        for model in models:
            _windows_out(record["models"][model], [r for r in rows if r["model"] == model], model, say)
    return raw, record


def _chosen_variant(form_rows: Sequence[Mapping[str, Any]], say) -> tuple[str, dict[str, float]]:
    """The (form, hold) of least held-out φ RMSE among ``form_rows`` (:func:`choose_variant`), each
    row's errors and the means told to ``say``."""
    form, hold, mean = choose_variant(form_rows)
    say("steer-law form by held-out error (fit on -> test: RMSE phi / theta rad):")
    for r in form_rows:
        say(
            f"  {variant_label(r['form'], r.get('held')):10s} {'+'.join(r['fit_on'])} -> {r['test']}: "
            f"{r['rmse_phi_rad']:.4f} / {r['rmse_theta_rad']:.4f}"
        )
    say(f"  mean held-out phi: { {k: round(v, 4) for k, v in mean.items()} } -> {variant_label(form, hold)!r}")
    return form, hold


def _fit_model(
    logs: Sequence[RobotLog],
    model: str,
    pressure_kpa: float,
    raw: Mapping[str, Any],
    base: ShellCalibration,
    form: str,
    hold: Mapping[str, float],
    steer_friction: FrictionModel | str,
    drive_friction: FrictionModel | str,
    max_nfev: int,
) -> tuple[Any, TwinPool]:
    """``model`` fitted on ``logs`` on top of the calibration mapping ``raw`` (the steer-law ``form``
    for the injected shell); (the fit, the pool of twins it ran on)."""
    pool = TwinPool(model, steer_friction, drive_friction=drive_friction)
    fit = fit_shell(
        logs,
        model,
        pressure_kpa,
        steer_friction=steer_friction,
        base=ShellCalibration.from_dict(raw, source=base.source),
        pool=pool,
        form=form if model == "injected" else None,
        max_nfev=max_nfev,
        drive_friction=drive_friction,
        hold=hold,
    )
    return fit, pool


def _say_fit(say, fit: Any, model: str, pressure_kpa: float, fit_on: Sequence[str]) -> None:
    """A fit's parameters told to ``say``: value, 95 % interval, unidentified or held."""
    say(f"{model} (form {fit.form!r}) at {pressure_kpa} kPa fitted on {list(fit_on)} in {fit.nfev} evaluations:")
    for k, v in fit.params.items():
        ci = fit.ci95.get(k)
        say(
            f"  {k} = {v:.5g}"
            + (f"  95% CI [{ci[0]:.5g}, {ci[1]:.5g}]" if ci else "")
            + (f"  UNIDENTIFIED: {fit.unidentified[k]}" if k in fit.unidentified else "")
        )
    for k, v in fit.held.items():
        say(f"  {k} = {v:.5g}  held (not fitted)")


def _windows_out(rec: dict[str, Any], mine: Sequence[Mapping[str, Any]], model: str, say) -> None:
    """Into ``model``'s fit record ``rec``: its held-out RMSE per window (``mine``: its
    leave-one-window-out rows) and, when every fold refitted, the 95 % intervals over windows
    (:func:`jackknife_ci95`), a parameter whose interval is wider than its value marked unidentified."""
    rec["held_out_rmse_rad"] = {r["test"]: {"phi": r["rmse_phi_rad"], "theta": r["rmse_theta_rad"]} for r in mine}
    folds = [r["params"] for r in mine if "params" in r]
    if not len(folds) == len(mine) >= 2:
        return
    fitted = {k: v for k, v in rec["params"].items() if k in rec["ci95"]}
    ci = jackknife_ci95(fitted, folds)
    rec["ci95_over_windows"] = {k: list(v) for k, v in ci.items()}
    for k, (lo, hi) in ci.items():
        if k not in rec["unidentified"] and hi - lo > abs(fitted[k]):
            rec["unidentified"][k] = (
                f"95 % interval over windows [{lo:.4g}, {hi:.4g}] wider than |value| {abs(fitted[k]):.4g}"
            )
    say(
        f"{model}: 95 % intervals over windows (jackknife over the {len(folds)} leave-one-window-out fits): "
        + ", ".join(f"{k} [{lo:.4g}, {hi:.4g}]" for k, (lo, hi) in ci.items())
    )


def jackknife_ci95(full: Mapping[str, float], folds: Sequence[Mapping[str, float]]) -> dict[str, tuple[float, float]]:
    """95 % intervals of fitted parameters from delete-one-window refits (the jackknife over windows).

    With n fits θ₍ᵢ₎, each leaving one window out, and θ̄ their mean, the jackknife variance is
    (n − 1)/n · Σ (θ₍ᵢ₎ − θ̄)² and the interval θ ± t₀.₉₇₅,ₙ₋₁ · its square root, around the fit on
    every window. Unlike the Jacobian interval of one fit it sees how much the parameter moves when
    the data change, so a parameter the windows disagree on gets a wide interval."""
    from scipy.stats import t as student_t

    n = len(folds)
    q = float(student_t.ppf(0.975, n - 1))
    out = {}
    for k, v in full.items():
        x = np.array([f[k] for f in folds], dtype=float)
        half = q * math.sqrt((n - 1) / n * float(np.sum((x - x.mean()) ** 2)))
        out[k] = (float(v) - half, float(v) + half)
    return out


def _cv_row(row: Mapping[str, Any]) -> dict[str, Any]:
    """A cross-validation row as recorded in a calibration file (no fitted mappings, the refusal kept)."""
    return {
        k: row[k]
        for k in ("model", "form", "held", "fit_on", "test", "rmse_phi_rad", "rmse_theta_rad", "refused")
        if k in row and (k != "held" or row[k])
    }
