"""The committed validation report: every real-log result in one Markdown file plus plots.

``python -m sphere_env.calibration report`` regenerates ``evaluation/results/validation/`` from
the logs of the manifest (``assets/logs/roboball.yaml``), the shipped friction presets and the
shipped shell calibration. It refits nothing that is shipped; the cross-validation fits it runs
(leave-one-out friction; per group of segments — the steer_free trials, the free-robot events —
fit on one, validate on the others, every shell model) are reported, not written. The free-robot
section lists the free-motion events found in each free-robot log and validates the manifest's
free windows with the shipped calibration.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from sphere_env.analysis.decay import fit_free_decay
from sphere_env.calibration.crossval import cross_validate, held_out_summary
from sphere_env.calibration.events import find_events
from sphere_env.calibration.friction_fit import evaluate_friction, fit_friction, leave_one_out, plot_stand_overlay
from sphere_env.calibration.log_csv import load_log
from sphere_env.calibration.manifest import Manifest
from sphere_env.calibration.report_page import validation_page
from sphere_env.calibration.sensitivity import plot_sweep, sweep
from sphere_env.calibration.validate import plot_overlays, validate
from sphere_env.files import staged_folder, swap_folder
from sphere_env.models.friction import FrictionModel, load_friction_presets
from sphere_env.models.shell import ShellCalibration

TABLE_I_STEER = FrictionModel("majd", {"f_w": 0.20, "f_c": 0.45, "sigma": 10.0, "omega_c": 0.1, "n": 1.0})


def build_report(
    manifest: Manifest,
    out_dir: str | Path,
    command: str,
    workers: int | None = None,
    starts: int = 2,
    calibration: str | None = None,
    sensitivity: bool = True,
) -> Path:
    """Run every real-log check and write ``README.md``, ``results.json`` and PNGs into ``out_dir``:
    all of them into a staging folder beside it first, moved into place only when every check has
    finished, so an interrupted or failed report leaves ``out_dir`` as it was."""
    with staged_folder(out_dir, _publish) as work:
        _build(manifest, work, command, workers, starts, calibration, sensitivity)
    return Path(out_dir) / "README.md"


def _publish(work: Path, out: Path) -> None:
    """Replace the earlier report in ``out`` by the new one as one set (a folder swap); other files
    there stay."""
    swap_folder(work, out, lambda name: name in ("README.md", "results.json") or name.endswith(".png"))


MODELS = ("point", "injected", "hydroelastic")


def _build(
    manifest: Manifest,
    out: Path,
    command: str,
    workers: int | None,
    starts: int,
    calibration: str | None,
    sensitivity: bool,
) -> None:
    """Every check in order, into ``out``: friction on the stand, the shell on steer_free, the free
    robot, the cross-validation and (``sensitivity``) the hydroelastic sensitivity; then
    ``results.json`` and ``README.md``."""
    t_start = time.time()
    cal = ShellCalibration.load(calibration)
    steer = load_friction_presets()["majd_steer"]
    results: dict[str, Any] = {"command": command, "calibration": str(cal.source), "majd_steer": dict(steer.params)}
    stand = [t.load(required=("theta",)) for t in manifest.group("stand_swing")]
    results["stand_swing"] = _stand_swing(out, stand, steer, starts)
    sf = [t.load(required=("phi", "theta")) for t in manifest.group("steer_free")]
    p0 = cal.nominal_pressure_kpa
    rows = validate(
        sf, MODELS, steer_friction=steer, drive_friction="none", calibration=calibration, default_pressure_kpa=p0
    )
    plot_overlays(out / "steer_free_overlay.png", sf, rows)
    results["steer_free_shipped"] = [r.as_dict() for r in rows]
    results["steer_free_decay"] = _free_decays(sf)
    free_specs = [t for t in manifest.trials if t.group == "free_robot"]
    free = [t.load(required=("phi", "theta")) for t in free_specs]
    results["free_robot_events"] = _free_robot_events(free_specs)
    free_rows = (
        validate(
            free, MODELS, steer_friction=steer, drive_friction="majd_drive", calibration=calibration, workers=workers
        )
        if free
        else []
    )
    results["free_robot_shipped"] = [r.record() for r in free_rows]
    if free:
        plot_overlays(out / "free_robot_overlay.png", free, free_rows)
    # cross-validation: per group, fit on one segment, validate on the others, every model
    groups = {"steer_free": sf, **({"free_robot": free} if free else {})}
    results["cross_validation"] = cross_validate(groups, MODELS, calibration, p0, steer, "majd_drive", workers=workers)
    results["cross_validation_summary"] = {
        f"{g}/{m}": v for (g, m), v in held_out_summary(results["cross_validation"]).items()
    }
    if sensitivity:
        results["sensitivity"] = _sensitivity(out, cal, calibration, workers)
    results["runtime_s"] = time.time() - t_start
    (out / "results.json").write_text(json.dumps(results, indent=1, default=float))
    (out / "README.md").write_text(validation_page(results, rows, cal))


def _stand_swing(out: Path, stand: list, steer: FrictionModel, starts: int) -> dict[str, Any]:
    """Friction on the stand_swing logs: the shipped preset's and Table I's RMSE (overlay plot),
    the leave-one-out fits and a fit with an angle offset."""
    shipped = evaluate_friction(stand, steer)
    table1 = evaluate_friction(stand, TABLE_I_STEER)
    plot_stand_overlay(
        out / "stand_swing_overlay.png",
        stand,
        {"majd_steer (shipped)": (steer, 0.0), "Table I params, continuous law": (TABLE_I_STEER, 0.0)},
    )
    return {
        "shipped_rmse_rad": shipped,
        "table_i_rmse_rad": table1,
        "leave_one_out": leave_one_out(stand, law="majd", fixed=("sigma", "n"), starts=starts),
        "fit_with_offset": fit_friction(stand, "majd", fixed=("sigma", "n"), fit_offset=True, starts=1).as_dict(),
    }


def _free_decays(logs: list) -> dict[str, Any]:
    """What the steer_free logs themselves say, model-free: each one's free-decay fit (or why it
    failed)."""
    decays = {}
    for log in logs:
        try:
            decays[log.name] = fit_free_decay(log.t_s, log["phi"]).as_dict()
        except ValueError as err:
            decays[log.name] = {"error": str(err)}
    return decays


def _free_robot_events(free_specs: list) -> dict[str, list]:
    """The free-motion events found in each free-robot log file (whole files, not the trials'
    windows)."""
    events = {}
    for f in sorted({str(t.file) for t in free_specs}):
        spec = next(t for t in free_specs if str(t.file) == f)
        events[Path(f).name] = [e.as_dict() for e in find_events(load_log(spec.file, spec.mapping))]
    return events


def _sensitivity(out: Path, cal: ShellCalibration, calibration: str | None, workers: int | None) -> list:
    """The hydroelastic sensitivity (paper Fig. 11) at the calibration's low, nominal, middle and
    high pressures, with its plot."""
    lo, hi = cal.pressure_range_kpa
    p0 = cal.nominal_pressure_kpa
    ps = sorted({round(lo, 2), round(p0, 2), round(0.5 * (lo + hi), 2), round(hi, 2)})
    sweep_rows = sweep(ps, calibration, workers=workers)
    plot_sweep(out / "hydroelastic_sensitivity.png", sweep_rows)
    return sweep_rows
