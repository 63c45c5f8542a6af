"""CLI: ``python -m sphere_env.calibration <command>``.

Commands
  shell        free-decay logs at several pressures -> ω_n(p), ζ(p) -> calibration YAML + plot
  steer-fit    steer-plane logs at one pressure -> injected / hydroelastic parameters -> calibration YAML
  friction     stand-swing logs -> friction law parameters -> preset YAML + overlay plot (+ leave-one-out)
  sensitivity  hydroelastic ±50 % sweep (paper Fig. 11) on a process pool
  kd-step      hydroelastic k_d refitted at another plant step -> calibration YAML (k_d_by_time_step)
  kd-pressure  hydroelastic k_d against pressure at a plant step, fitted to ζ(p) -> calibration YAML (k_d_by_pressure)
  events       free-motion events (release or push, then free decay) in a long log [-> manifest entries]
  validate     any manifest's logs against any shell models; exit 1 if a tolerance is exceeded
  report       regenerate evaluation/results/validation/ from the real logs
Every command reads a trial manifest (``--manifest``, default ``assets/logs/roboball.yaml``).
Bad input exits with status 2 and a message naming the file, line/column or field.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
from pathlib import Path

from sphere_env.calibration.logs import LogError
from sphere_env.calibration.manifest import load_manifest
from sphere_env.cli import renamed
from sphere_env.resources import asset_path
from sphere_env.schemas import Finite, OutputFile, OutputFolder, checker, cli_type, count, number
from sphere_env.schemas.twin import parameter

DEFAULT_MANIFEST = asset_path("logs", "roboball.yaml")
# argparse types of the numeric flags: bounded, refused with argparse's one-line error (exit 2)
WORKERS = cli_type(count(1, 1024), int, "workers")
STARTS = cli_type(count(1, 100), int, "starts")
SEED = cli_type(count(0, 2**32 - 1), int, "seed")
MAX_NFEV = cli_type(count(1, 100_000), int, "max_nfev")
TIME_STEP_S = cli_type(parameter("time_step_s"), float, "time_step_s")
PRESSURE_KPA = cli_type(Finite, float, "pressure_kpa")  # against the calibration's range once it is loaded
DURATION_S = cli_type(number(gt=0.0, le=600.0, words="a simulated time in (0, 600] s"), float, "duration_s")
OUTPUT_FILE = checker(OutputFile)
OUTPUT_FOLDER = checker(OutputFolder)


def _trials(args, required=()):
    man = load_manifest(args.manifest, args.data_root)
    specs = man.group(args.group) if args.group else list(man.trials)
    if getattr(args, "trial", None):
        specs = [man.by_name(n) for n in args.trial]
    return man, [s.load(required=required) for s in specs]


def cmd_shell(args) -> int:
    from sphere_env.calibration.decay import (
        calibration_dict,
        fit_free_decay,
        fit_pressure_curves,
        plot_pressure_curves,
        write_yaml,
    )
    from sphere_env.models.rigid_body import RobotParameters
    from sphere_env.models.shell import ShellCalibration

    _, logs = _trials(args, required=(args.channel,))
    fits, ps = [], []
    for log in logs:
        if log.pressure_kpa is None:
            raise LogError(f"trial {log.name!r}: 'pressure_kpa' is null; free-decay curves need a pressure per trial")
        fit = fit_free_decay(log.t_s, log[args.channel])
        fits.append(fit)
        ps.append(log.pressure_kpa)
        print(f"{log.name}: p={log.pressure_kpa} kPa  ω_n={fit.omega_n:.4f} [{fit.omega_n_ci[0]:.4f}, {fit.omega_n_ci[1]:.4f}] rad/s"
              f"  ζ={fit.zeta:.4f} [{fit.zeta_ci[0]:.4f}, {fit.zeta_ci[1]:.4f}]  log-dec ζ={fit.logdec_zeta:.4f}")
    curve = fit_pressure_curves(ps, [f.omega_n for f in fits], [f.zeta for f in fits])
    print(json.dumps(curve.as_dict(), indent=1))
    base = ShellCalibration.load(args.base)
    data = calibration_dict(curve, base, provenance={
        "omega_n, zeta": f"free-decay fits of '{args.channel}' on {[log.name for log in logs]} ({args.manifest})"})
    data["trial_fits"] = {log.name: f.as_dict() for log, f in zip(logs, fits)}
    if args.out:
        write_yaml(args.out, data, "# Written by python -m sphere_env.calibration shell")
        print(f"wrote {args.out}")
    if args.plot:
        plot_pressure_curves(args.plot, ps, fits, curve, RobotParameters.from_urdf().omega_point_rad_s)
        print(f"wrote {args.plot}")
    return 0


def cmd_steer_fit(args) -> int:
    from sphere_env.calibration.decay import write_yaml
    from sphere_env.calibration.shell_fit import trial_rmse
    from sphere_env.calibration.steer_fit import steer_fit
    from sphere_env.models.shell import ShellCalibration

    man, logs = _trials(args, required=("phi", "theta"))
    base = ShellCalibration.load(args.base)
    p0 = base.check_pressure(args.pressure_kpa if args.pressure_kpa is not None else base.nominal_pressure_kpa,
                             "--pressure-kpa")
    names = [log.name for log in logs]
    if args.fit_on:
        missing = [n for n in args.fit_on if n not in names]
        if missing:
            raise LogError(f"--fit-on {missing}: no such trial in {names} (manifest {args.manifest})")
    fit_logs = [log for log in logs if not args.fit_on or log.name in args.fit_on]
    raw, record = steer_fit(fit_logs, args.models, p0, base, forms=args.forms, steer_friction=args.steer_friction,
                            drive_friction=args.drive_friction, max_nfev=args.max_nfev, log_to=print,
                            workers=args.workers)
    for model, fit in record["models"].items():
        per = trial_rmse(fit.pop("pool"), logs)
        for name, r in per.items():
            tag = "fit" if name in record["fit_on"] else "held out"
            print(f"  {model} {name} ({tag}): RMSE phi {r['phi']:.4f} rad, theta {r['theta']:.4f} rad")
        fit["rmse_rad"] = per
    if args.match_kd:
        import tempfile

        from sphere_env.calibration.sensitivity import match_dissipation

        with tempfile.TemporaryDirectory() as tmp:
            path = write_yaml(Path(tmp) / "cal.yaml", raw)
            m = match_dissipation(path, p0, time_step_s=args.time_step_s)
        # k_d holds at the plant step it was matched at: record that step
        raw = dict(raw, hydroelastic=dict(raw["hydroelastic"], k_d=m["k_d"],
                                          fitted_time_step_s=m["time_step_s"]))
        print(f"hydroelastic k_d = {m['k_d']:.4f} (d = {m['dissipation_s_per_m']:.4f} s/m): locked-steer decay "
              f"zeta = {m['zeta_sim']:.4f} matches zeta(p0) = {m['target_zeta']:.4f}")
    if args.out:
        ShellCalibration.from_dict(raw, source=str(args.out))  # validated (incl. stand-still) before writing
        raw = dict(raw, steer_fit=_jsonable(record))
        raw["steer_fit"]["how"] = (
            f"python -m sphere_env.calibration {' '.join(shlex.quote(a) for a in sys.argv[1:])}; "
            f"the segments' pressure is unknown: the fitted law is stated at nominal_pressure_kpa = {p0} "
            "and the slopes of omega_n(p), zeta(p) are kept from the base calibration")
        write_yaml(args.out, raw, "# Written by python -m sphere_env.calibration steer-fit")
        print(f"wrote {args.out}")
    return 0


def _jsonable(x):
    """Plain floats/lists/dicts for YAML (numpy scalars and tuples converted)."""
    return json.loads(json.dumps(x, default=float))


def cmd_friction(args) -> int:
    from sphere_env.calibration.friction_fit import fit_friction, leave_one_out, plot_stand_overlay, write_preset

    _, logs = _trials(args, required=("theta",))
    fixed = tuple(args.fixed) if args.fixed is not None else None
    fit = fit_friction(logs, args.law, args.joint, fixed=fixed, fit_offset=args.fit_offset, starts=args.starts,
                       seed=args.seed)
    print(json.dumps(fit.as_dict(), indent=1))
    if args.loo:
        for row in leave_one_out(logs, law=args.law, joint=args.joint, fixed=fixed, fit_offset=args.fit_offset,
                                 starts=args.starts, seed=args.seed):
            print(f"held out {row['held_out']}: test RMSE {row['test_rmse_rad']:.4f} rad, "
                  f"train RMSE {json.dumps({k: round(v, 4) for k, v in row['train_rmse_rad'].items()})}")
    if args.plot:
        plot_stand_overlay(args.plot, logs, {f"{args.law} fit": (fit.model, fit.theta_offset_rad)})
        print(f"wrote {args.plot}")
    if args.preset_file:
        names = [log.name for log in logs]
        write_preset(args.preset_file, args.preset_name or f"{args.law}_{args.joint}", fit.model,
                     f"fitted by `python -m sphere_env.calibration friction` on {names}; "
                     f"theta RMSE {json.dumps({k: round(v, 4) for k, v in fit.rmse_per_trial.items()})} rad")
        print(f"wrote preset into {args.preset_file}")
    return 0


def cmd_sensitivity(args) -> int:
    from sphere_env.calibration.sensitivity import plot_sweep, sensitivity_table, sweep
    from sphere_env.models.shell import ShellCalibration

    cal = ShellCalibration.load(args.calibration)
    ps = args.pressure_kpa or [cal.pressure_range_kpa[0], cal.nominal_pressure_kpa, cal.pressure_range_kpa[1]]
    for p in ps:
        cal.check_pressure(p, "--pressure-kpa")
    rows = sweep(ps, args.calibration, workers=args.workers, duration_s=args.duration_s)
    print(sensitivity_table(rows))
    if args.plot:
        plot_sweep(args.plot, rows)
    return 0


def cmd_kd_step(args) -> int:
    from sphere_env.calibration.decay import write_yaml
    from sphere_env.calibration.sensitivity import match_dissipation_at_step
    from sphere_env.models.shell import ShellCalibration

    cal = ShellCalibration.load(args.calibration)  # validated before anything runs
    if args.pressure_kpa is not None:
        cal.check_pressure(args.pressure_kpa, "--pressure-kpa")
    m = match_dissipation_at_step(args.calibration, args.time_step_s, args.pressure_kpa)
    hyd = dict(cal.raw["hydroelastic"])
    steps = [e for e in hyd.get("k_d_by_time_step", []) if not math.isclose(e["time_step_s"], m["time_step_s"])]
    hyd["k_d_by_time_step"] = sorted(steps + [{"time_step_s": m["time_step_s"], "k_d": round(m["k_d"], 5)}],
                                     key=lambda e: e["time_step_s"])
    raw = dict(cal.raw, hydroelastic=hyd)
    ShellCalibration.from_dict(raw, source=str(args.out))  # validated before writing
    write_yaml(args.out, raw)
    print(f"k_d at time_step_s={m['time_step_s']:g} s: {m['k_d']:.5f} (locked-steer decay at {m['pressure_kpa']:g} kPa: "
          f"zeta {m['zeta_sim']:.4f}, the calibration's k_d {cal.k_d:g} gives {m['reference_zeta']:.4f} at its "
          f"{m['reference_time_step_s']:g} s) -> {args.out}")
    return 0


def cmd_kd_pressure(args) -> int:
    from sphere_env.calibration.decay import write_yaml
    from sphere_env.calibration.sensitivity import match_dissipation_by_pressure
    from sphere_env.models.shell import ShellCalibration, interpolate_k_d

    cal = ShellCalibration.load(args.calibration)  # validated before anything runs
    if args.pressure_kpa is not None:
        for q in args.pressure_kpa:
            cal.check_pressure(q, "--pressure-kpa")
        lo, hi = cal.pressure_range_kpa
        if len(set(args.pressure_kpa)) < 2 or min(args.pressure_kpa) > lo or max(args.pressure_kpa) < hi:
            raise ValueError(f"--pressure-kpa: value {args.pressure_kpa!r} must hold at least 2 pressures spanning "
                             f"the calibrated range [{lo}, {hi}] kPa (k_d is not extrapolated)")
    rows = match_dissipation_by_pressure(args.calibration, args.time_step_s, args.pressure_kpa)
    step = rows[0]["time_step_s"]
    table = [{"pressure_kpa": r["pressure_kpa"], "k_d": round(r["k_d"], 5)} for r in rows]
    # the single k_d of the step is the table's value at the nominal pressure (the loader checks it)
    k_d_nominal = round(interpolate_k_d([(e["pressure_kpa"], e["k_d"]) for e in table], cal.nominal_pressure_kpa), 5)
    hyd = dict(cal.raw["hydroelastic"])
    if cal.fitted_time_step_s is None or math.isclose(step, cal.fitted_time_step_s, rel_tol=1e-9):
        hyd.update(k_d=k_d_nominal, k_d_by_pressure=table, fitted_time_step_s=step)
        # refits at other steps kept the damping of the k_d replaced here (as calibration_at drops them)
        if hyd.pop("k_d_by_time_step", None):
            print("dropped hydroelastic.k_d_by_time_step: its refits matched the replaced k_d; refit them "
                  "(kd-step, kd-pressure)")
    else:
        steps = [e for e in hyd.get("k_d_by_time_step", []) if not math.isclose(e["time_step_s"], step)]
        hyd["k_d_by_time_step"] = sorted(
            steps + [{"time_step_s": step, "k_d": k_d_nominal, "k_d_by_pressure": table}],
            key=lambda e: e["time_step_s"])
    raw = dict(cal.raw, hydroelastic=hyd)
    ShellCalibration.from_dict(raw, source=str(args.out))  # validated before writing
    write_yaml(args.out, raw)
    for r in rows:
        print(f"time_step_s={step:g} s, {r['pressure_kpa']:g} kPa: k_d {r['k_d']:.5f} (locked-steer decay zeta "
              f"{r['zeta_sim']:.4f}, zeta(p) {r['target_zeta']:.4f})")
    print(f"k_d at the nominal {cal.nominal_pressure_kpa:g} kPa: {k_d_nominal:.5f} -> {args.out}")
    return 0


def cmd_validate(args) -> int:
    from sphere_env.calibration.validate import (
        parse_tolerances,
        plot_overlays,
        tolerance_failures,
        validate,
        validation_table,
        write_records,
    )

    tol = parse_tolerances(args.tol)
    _, logs = _trials(args)
    rows = validate(logs, args.models, steer_friction=args.steer_friction, drive_friction=args.drive_friction,
                    calibration=args.calibration, default_pressure_kpa=args.pressure_kpa, workers=args.workers)
    print(validation_table(rows))
    if args.json:
        write_records(args.json, rows)
        print(f"wrote {args.json}")
    if args.plot:
        plot_overlays(args.plot, logs, rows)
        print(f"wrote {args.plot}")
    bad = tolerance_failures(rows, tol, args.tol_models)
    for msg in bad:
        print(f"TOLERANCE {'NOT CHECKED' if 'not compared' in msg or 'nothing compared' in msg else 'EXCEEDED'}: "
              f"{msg}", file=sys.stderr)
    return 1 if bad else 0


def cmd_events(args) -> int:
    import os

    from sphere_env.calibration.events import events_table, find_events, manifest_entries, write_manifest_entries
    from sphere_env.calibration.logs import TIME_UNITS, ColumnMapping, load_log

    mapping = ColumnMapping.roboball() if args.mapping is None else ColumnMapping.load(args.mapping)
    if args.time_unit is not None:
        if args.time_unit not in TIME_UNITS:
            raise LogError(f"--time-unit: value {args.time_unit!r}; allowed: {list(TIME_UNITS)}")
        from dataclasses import replace

        mapping = replace(mapping, time=(mapping.time[0], args.time_unit))
    log = load_log(args.log, mapping)
    events = find_events(log)
    print(f"{args.log}: {len(log.t_s)} samples over {log.t_s[-1]:.2f} s (time unit {mapping.time[1]}); "
          f"{len(events)} free-motion event(s)")
    print(events_table(events))
    if args.json:
        print(json.dumps([e.as_dict() for e in events], indent=1))
    if args.write_manifest and not events:
        print(f"no free-motion events in {args.log}: {args.write_manifest} not written", file=sys.stderr)
        return 1
    if args.write_manifest:
        out = Path(args.write_manifest).resolve()
        log_path = Path(args.log).resolve()
        if out.exists():
            root = load_manifest(out).data_root.resolve()
        else:
            root = log_path.parent
        try:
            file = str(log_path.relative_to(root))
        except ValueError:
            file = str(log_path)
        entries = manifest_entries(log, events, file, args.group or log_path.parent.name, args.duration_s)
        for e in entries:
            if args.mapping is not None:
                e["mapping"] = str(Path(args.mapping).resolve())
            e["time_unit"] = mapping.time[1]
        write_manifest_entries(out, entries, os.path.relpath(root, out.parent))
        print(f"wrote {len(entries)} entr{'y' if len(entries) == 1 else 'ies'} into {out}")
    return 0


def cmd_report(args) -> int:
    from sphere_env.calibration.report import build_report

    man = load_manifest(args.manifest, args.data_root)
    if not man.available():
        print(f"report: real logs not found at {man.data_root}; nothing written", file=sys.stderr)
        return 2
    cmd = "python -m sphere_env.calibration " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    path = build_report(man, args.out, cmd, workers=args.workers, starts=args.starts,
                        sensitivity=not args.no_sensitivity)
    print(f"wrote {path}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    # usage lines read "sphere-env calibrate ..." from the sphere-env command (which sets argv[0])
    prog = sys.argv[0] if sys.argv[0].startswith("sphere-env") else "python -m sphere_env.calibration"
    ap = argparse.ArgumentParser(prog=prog, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
                                 allow_abbrev=False)
    sub = ap.add_subparsers(dest="command", required=True)

    def common(p, group=None):
        p.add_argument("--manifest", default=str(DEFAULT_MANIFEST), help="trial manifest YAML")
        p.add_argument("--data-root", default=None, help="override the manifest's data_root")
        p.add_argument("--group", default=group, help=f"manifest group (default {group})")
        p.add_argument("--trial", nargs="*", help="only these trial names")

    p = sub.add_parser("shell", help="free decays at several pressures -> ω_n(p), ζ(p) calibration file")
    common(p, "locked_steer")
    p.add_argument("--channel", default="phi", choices=["phi", "theta"], help="decaying channel (rad)")
    p.add_argument("--base", default=None, help="calibration whose V(p) and hydroelastic settings are kept")
    p.add_argument("--out", help="calibration YAML to write")
    p.add_argument("--plot", help="PNG of data, fits and the point-contact line")
    p.set_defaults(func=cmd_shell)

    p = sub.add_parser("steer-fit", help="free-motion segments (steer_plane trials, free windows) -> shell law")
    common(p, "steer_free")
    p.add_argument("--models", nargs="+", default=["injected", "hydroelastic"], choices=["injected", "hydroelastic"])
    p.add_argument("--forms", nargs="+", default=["linear", "saturating", "quadratic"],
                   choices=["linear", "saturating", "quadratic"],
                   help="steer-law forms to try; with several, the one with the least held-out phi RMSE is fitted")
    p.add_argument("--pressure-kpa", type=PRESSURE_KPA, default=None,
                   help="pressure the fit is stated at (default: the base calibration's nominal; the segments' "
                        "own pressure may be unknown)")
    p.add_argument("--fit-on", nargs="*", help="trial names to fit on (others are validation); with two or more, "
                   "each is also left out in turn (leave-one-window-out) and its held-out RMSE recorded")
    p.add_argument("--workers", type=WORKERS, default=1, help="processes for the cross-validation folds (default 1)")
    p.add_argument("--max-nfev", type=MAX_NFEV, default=60, help="simulations allowed per fit (refused if not converged)")
    p.add_argument("--steer-friction", default="majd_steer")
    p.add_argument("--drive-friction", default="majd_drive", help="drive friction on free windows")
    p.add_argument("--base", default=None, help="starting calibration (slopes, V(p) shape are kept)")
    p.add_argument("--match-kd", action="store_true",
                   help="then set hydroelastic k_d so the locked-steer hydroelastic decay has ζ(p0)")
    p.add_argument("--time-step-s", type=TIME_STEP_S, default=None,
                   help="plant step [s] the k_d match runs at and is recorded for (default: the twin's)")
    p.add_argument("--out", help="calibration YAML to write")
    p.set_defaults(func=cmd_steer_fit)

    p = sub.add_parser("friction", help="stand swings -> friction parameters")
    common(p, "stand_swing")
    p.add_argument("--law", default="majd", choices=["viscous", "coulomb", "majd"])
    p.add_argument("--joint", default="steer", choices=["steer"])
    p.add_argument("--fixed", nargs="*", default=None, help="parameters held at their start value")
    p.add_argument("--fit-offset", action="store_true", help="also fit an encoder offset θ_0 [rad]")
    p.add_argument("--starts", type=STARTS, default=4)
    p.add_argument("--seed", type=SEED, default=0)
    p.add_argument("--loo", action="store_true", help="also run leave-one-out")
    p.add_argument("--plot", help="overlay PNG (paper Fig. 7)")
    p.add_argument("--preset-file", help="presets YAML to write the fit into")
    p.add_argument("--preset-name", help="preset name (default <law>_<joint>)")
    p.set_defaults(func=cmd_friction)

    p = sub.add_parser("sensitivity", help="hydroelastic ±50%% sweep (paper Fig. 11)")
    p.add_argument("--calibration", default=None)
    p.add_argument("--pressure-kpa", type=PRESSURE_KPA, nargs="*", help="pressures [kPa] (default: the calibration's)")
    renamed(p, "--pressures-kpa", "--pressure-kpa")
    p.add_argument("--workers", type=WORKERS, default=None)
    p.add_argument("--duration-s", type=DURATION_S, default=6.0)
    p.add_argument("--plot")
    p.set_defaults(func=cmd_sensitivity)

    p = sub.add_parser("kd-step", help="hydroelastic k_d refitted at another plant step (k_d_by_time_step)")
    p.add_argument("--calibration", default=None, help="calibration YAML (default: the shipped one)")
    p.add_argument("--time-step-s", type=TIME_STEP_S, required=True, help="plant step [s] to refit k_d at")
    p.add_argument("--pressure-kpa", type=PRESSURE_KPA, default=None, help="pressure of the decays (default: nominal)")
    p.add_argument("--out", required=True, help="calibration YAML to write (the input plus the refit)")
    p.set_defaults(func=cmd_kd_step)

    p = sub.add_parser("kd-pressure", help="hydroelastic k_d against pressure at a plant step, each fitted so "
                       "the locked-steer decay has ζ(p) (k_d_by_pressure)")
    p.add_argument("--calibration", default=None, help="calibration YAML (default: the shipped one)")
    p.add_argument("--time-step-s", type=TIME_STEP_S, required=True, help="plant step [s] the decays run at")
    renamed(p, "--pressures-kpa", "--pressure-kpa")
    p.add_argument("--pressure-kpa", type=PRESSURE_KPA, nargs="+", default=None,
                   help="pressures [kPa] to fit k_d at, spanning the calibrated range (default: its ends, the "
                        "nominal, 5 even points and both sides of a low_pressure_mesh switch)")
    p.add_argument("--out", required=True, help="calibration YAML to write (the input plus the table)")
    p.set_defaults(func=cmd_kd_pressure)

    p = sub.add_parser("events", help="free-motion events in a long log; optionally write manifest entries")
    p.add_argument("log", help="CSV log (RoboBall names, or --mapping)")
    p.add_argument("--mapping", default=None, help="column mapping YAML for other naming")
    p.add_argument("--time-unit", default=None, help="time column unit, overriding the mapping's (s|ms|us|ns)")
    p.add_argument("--write-manifest", default=None, metavar="PATH",
                   help="add one fixture:free entry per event to this manifest (created if missing)")
    p.add_argument("--group", default=None, help="group of the written entries (default: the log's folder)")
    p.add_argument("--duration-s", type=DURATION_S, default=None,
                   help="cap each written window at this many seconds from its start")
    p.add_argument("--json", action="store_true", help="also print the events as JSON")
    p.set_defaults(func=cmd_events)

    p = sub.add_parser("validate", help="logs against shell models; exit 1 past a tolerance")
    common(p, None)
    p.add_argument("--models", nargs="+", default=["point", "injected", "hydroelastic"])
    p.add_argument("--calibration", default=None)
    p.add_argument("--pressure-kpa", type=PRESSURE_KPA, default=None, help="pressure for trials without one")
    p.add_argument("--steer-friction", default="majd_steer")
    p.add_argument("--drive-friction", default="majd_drive")
    p.add_argument("--tol", nargs="*", help="limits like phi=0.1 theta=0.12 omega_d=0.5 pendulum_pitch=0.05 "
                   "pme=15; exit 1 if one is exceeded or could not be checked on a trial")
    p.add_argument("--tol-models", nargs="*", default=None, help="models the tolerance applies to (default all)")
    p.add_argument("--json", default=None, metavar="PATH",
                   help="write one record per trial and model (trial, model, rmse_phi_rad, rmse_theta_rad, ...)")
    p.add_argument("--workers", type=WORKERS, default=1, help="processes for the (trial, model) runs (default 1)")
    p.add_argument("--plot")
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("report", help="regenerate the committed validation report")
    p.add_argument("--manifest", default=str(DEFAULT_MANIFEST))
    p.add_argument("--data-root", default=None)
    p.add_argument("--out", default=str(Path("evaluation") / "results" / "validation"))
    p.add_argument("--workers", type=WORKERS, default=None)
    p.add_argument("--starts", type=STARTS, default=2)
    p.add_argument("--no-sensitivity", action="store_true")
    p.set_defaults(func=cmd_report)
    for p in sub.choices.values():  # a flag is spelled in full (no prefix of it), so a renamed flag is named
        p.allow_abbrev = False
        if "--pressure-kpa" in p._option_string_actions:
            renamed(p, "--pressure", "--pressure-kpa")
    return ap


#: Output-file options of the subcommands, checked before any fit runs.
OUTPUT_OPTIONS = ("out", "plot", "json", "preset_file", "write_manifest")


def check_output_paths(args) -> None:
    """Refuse an output path that is a folder or lies under a file (:data:`OutputFile`), before
    anything is computed, so that a bad second output cannot fail after the first one was written."""
    for name in OUTPUT_OPTIONS:
        value = getattr(args, name, None)
        # report --out is a folder; events --json is a flag (print JSON), not a path
        if not isinstance(value, str) or not value:
            continue
        if args.command == "report" and name == "out":
            OUTPUT_FOLDER(value, "--out")
            continue
        OUTPUT_FILE(value, f"--{name.replace('_', '-')}")


def main(argv: list[str] | None = None) -> int:
    from sphere_env.parallel import sigterm_as_interrupt

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        check_output_paths(args)
        with sigterm_as_interrupt():  # SIGTERM unwinds as Ctrl-C: workers stopped, staging removed
            return args.func(args)
    except (ValueError, OSError) as err:  # LogError, config errors and failed writes: named, nothing written
        print(f"{parser.prog} {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{parser.prog} {args.command}: interrupted; workers stopped, no partial output", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
