"""The commands of ``python -m sphere_env.calibration`` (one function per subcommand, called with the
parsed arguments; the parser and the error handling are in :mod:`sphere_env.calibration.__main__`)."""

from __future__ import annotations

import itertools
import json
import math
import shlex
import sys
from pathlib import Path

from sphere_env.calibration.logs import LogError
from sphere_env.calibration.manifest import load_manifest


def _trials(args, required=()):
    man = load_manifest(args.manifest, args.data_root)
    specs = man.group(args.group) if args.group else list(man.trials)
    if getattr(args, "trial", None):
        specs = [man.by_name(n) for n in args.trial]
    return man, [s.load(required=required) for s in specs]


def _shared_logs(args, command: str):
    """The manifest of a command that reads every log of it (``report``, ``pressure-study``), or None
    after saying on stderr that its logs are missing and nothing is written."""
    man = load_manifest(args.manifest, args.data_root)
    if not man.available():
        print(f"{command}: real logs not found at {man.data_root}; nothing written", file=sys.stderr)
        return None
    return man


def cmd_shell(args) -> int:
    from sphere_env.analysis.decay import fit_free_decay
    from sphere_env.calibration.decay import calibration_dict, fit_pressure_curves, plot_pressure_curves, write_yaml
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
        print(
            f"{log.name}: p={log.pressure_kpa} kPa  ω_n={fit.omega_n:.4f} [{fit.omega_n_ci[0]:.4f}, {fit.omega_n_ci[1]:.4f}] rad/s"
            f"  ζ={fit.zeta:.4f} [{fit.zeta_ci[0]:.4f}, {fit.zeta_ci[1]:.4f}]  log-dec ζ={fit.logdec_zeta:.4f}"
        )
    curve = fit_pressure_curves(ps, [f.omega_n for f in fits], [f.zeta for f in fits])
    print(json.dumps(curve.as_dict(), indent=1))
    base = ShellCalibration.load(args.base)
    data = calibration_dict(
        curve,
        base,
        provenance={
            "omega_n, zeta": f"free-decay fits of '{args.channel}' on {[log.name for log in logs]} ({args.manifest})"
        },
    )
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

    names_held = [name for name, _ in args.hold]
    if len(set(names_held)) < len(names_held):
        raise ValueError(f"--hold: a parameter is named twice in {names_held}; give one NAME=V1,V2,... per parameter")
    holds = [dict(zip(names_held, vals)) for vals in itertools.product(*(v for _, v in args.hold))]
    if len(holds) > 1 and "injected" not in args.models:
        raise ValueError(
            f"--hold: {len(holds)} candidates are chosen on the injected model's held-out error, but --models "
            f"is {args.models}; add injected or give one value per parameter"
        )
    man, logs = _trials(args, required=("phi", "theta"))
    base = ShellCalibration.load(args.base)
    p0 = base.check_pressure(
        args.pressure_kpa if args.pressure_kpa is not None else base.nominal_pressure_kpa, "--pressure-kpa"
    )
    names = [log.name for log in logs]
    if args.fit_on:
        missing = [n for n in args.fit_on if n not in names]
        if missing:
            raise LogError(f"--fit-on {missing}: no such trial in {names} (manifest {args.manifest})")
    fit_logs = [log for log in logs if not args.fit_on or log.name in args.fit_on]
    raw, record = steer_fit(
        fit_logs,
        args.models,
        p0,
        base,
        forms=args.forms,
        steer_friction=args.steer_friction,
        drive_friction=args.drive_friction,
        max_nfev=args.max_nfev,
        log_to=print,
        workers=args.workers,
        holds=holds,
    )
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
        raw = dict(raw, hydroelastic=dict(raw["hydroelastic"], k_d=m["k_d"], fitted_time_step_s=m["time_step_s"]))
        print(
            f"hydroelastic k_d = {m['k_d']:.4f} (d = {m['dissipation_s_per_m']:.4f} s/m): locked-steer decay "
            f"zeta = {m['zeta_sim']:.4f} matches zeta(p0) = {m['target_zeta']:.4f}"
        )
    if args.out:
        ShellCalibration.from_dict(raw, source=str(args.out))  # validated (incl. stand-still) before writing
        # The base's records of earlier shell fits describe another fit than this file's: they give
        # way to a pointer at this file's steer_fit record (assumptions such as the slopes are kept).
        prov = {k: v for k, v in (raw.get("provenance") or {}).items() if k not in SHELL_FIT_PROVENANCE}
        prov["shell_fit"] = "MEASURED: the steer_fit record below (windows, values, intervals, held-out errors)"
        raw = dict(raw, provenance=prov, steer_fit=_jsonable(record))
        raw["steer_fit"]["how"] = (
            f"python -m sphere_env.calibration {' '.join(shlex.quote(a) for a in sys.argv[1:])}; "
            f"the segments' pressure is unknown: the fitted law is stated at nominal_pressure_kpa = {p0} "
            "and the slopes of omega_n(p), zeta(p) are kept from the base calibration"
        )
        write_yaml(args.out, raw, "# Written by python -m sphere_env.calibration steer-fit")
        print(f"wrote {args.out}")
    return 0


#: Provenance entries of a calibration that record a shell fit (replaced when steer-fit writes a new one).
SHELL_FIT_PROVENANCE = ("injected_fit", "hydroelastic_fit", "form_choice")


def _jsonable(x):
    """Plain floats/lists/dicts for YAML (numpy scalars and tuples converted)."""
    return json.loads(json.dumps(x, default=float))


def cmd_friction(args) -> int:
    from sphere_env.calibration.friction_fit import fit_friction, leave_one_out, plot_stand_overlay, write_preset

    _, logs = _trials(args, required=("theta",))
    fixed = tuple(args.fixed) if args.fixed is not None else None
    fit = fit_friction(
        logs, args.law, args.joint, fixed=fixed, fit_offset=args.fit_offset, starts=args.starts, seed=args.seed
    )
    print(json.dumps(fit.as_dict(), indent=1))
    if args.loo:
        for row in leave_one_out(
            logs,
            law=args.law,
            joint=args.joint,
            fixed=fixed,
            fit_offset=args.fit_offset,
            starts=args.starts,
            seed=args.seed,
        ):
            print(
                f"held out {row['held_out']}: test RMSE {row['test_rmse_rad']:.4f} rad, "
                f"train RMSE {json.dumps({k: round(v, 4) for k, v in row['train_rmse_rad'].items()})}"
            )
    if args.plot:
        plot_stand_overlay(args.plot, logs, {f"{args.law} fit": (fit.model, fit.theta_offset_rad)})
        print(f"wrote {args.plot}")
    if args.preset_file:
        names = [log.name for log in logs]
        write_preset(
            args.preset_file,
            args.preset_name or f"{args.law}_{args.joint}",
            fit.model,
            f"fitted by `python -m sphere_env.calibration friction` on {names}; "
            f"theta RMSE {json.dumps({k: round(v, 4) for k, v in fit.rmse_per_trial.items()})} rad",
        )
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
    hyd["k_d_by_time_step"] = sorted(
        steps + [{"time_step_s": m["time_step_s"], "k_d": round(m["k_d"], 5)}], key=lambda e: e["time_step_s"]
    )
    raw = dict(cal.raw, hydroelastic=hyd)
    ShellCalibration.from_dict(raw, source=str(args.out))  # validated before writing
    write_yaml(args.out, raw)
    print(
        f"k_d at time_step_s={m['time_step_s']:g} s: {m['k_d']:.5f} (locked-steer decay at {m['pressure_kpa']:g} kPa: "
        f"zeta {m['zeta_sim']:.4f}, the calibration's k_d {cal.k_d:g} gives {m['reference_zeta']:.4f} at its "
        f"{m['reference_time_step_s']:g} s) -> {args.out}"
    )
    return 0


def cmd_kd_pressure(args) -> int:
    from sphere_env.calibration.decay import write_yaml
    from sphere_env.calibration.sensitivity import match_dissipation_by_pressure
    from sphere_env.models.calibration_schema import interpolate_k_d
    from sphere_env.models.shell import ShellCalibration

    cal = ShellCalibration.load(args.calibration)  # validated before anything runs
    if args.pressure_kpa is not None:
        for q in args.pressure_kpa:
            cal.check_pressure(q, "--pressure-kpa")
        lo, hi = cal.pressure_range_kpa
        if len(set(args.pressure_kpa)) < 2 or min(args.pressure_kpa) > lo or max(args.pressure_kpa) < hi:
            raise ValueError(
                f"--pressure-kpa: value {args.pressure_kpa!r} must hold at least 2 pressures spanning "
                f"the calibrated range [{lo}, {hi}] kPa (k_d is not extrapolated)"
            )
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
            print(
                "dropped hydroelastic.k_d_by_time_step: its refits matched the replaced k_d; refit them "
                "(kd-step, kd-pressure)"
            )
    else:
        steps = [e for e in hyd.get("k_d_by_time_step", []) if not math.isclose(e["time_step_s"], step)]
        hyd["k_d_by_time_step"] = sorted(
            steps + [{"time_step_s": step, "k_d": k_d_nominal, "k_d_by_pressure": table}],
            key=lambda e: e["time_step_s"],
        )
    raw = dict(cal.raw, hydroelastic=hyd)
    ShellCalibration.from_dict(raw, source=str(args.out))  # validated before writing
    write_yaml(args.out, raw)
    for r in rows:
        print(
            f"time_step_s={step:g} s, {r['pressure_kpa']:g} kPa: k_d {r['k_d']:.5f} (locked-steer decay zeta "
            f"{r['zeta_sim']:.4f}, zeta(p) {r['target_zeta']:.4f})"
        )
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
    rows = validate(
        logs,
        args.models,
        steer_friction=args.steer_friction,
        drive_friction=args.drive_friction,
        calibration=args.calibration,
        default_pressure_kpa=args.pressure_kpa,
        workers=args.workers,
    )
    print(validation_table(rows))
    if args.json:
        from sphere_env.models.shell import ShellCalibration

        write_records(args.json, rows, ShellCalibration.load(args.calibration).raw)
        print(f"wrote {args.json}")
    if args.plot:
        plot_overlays(args.plot, logs, rows)
        print(f"wrote {args.plot}")
    bad = tolerance_failures(rows, tol, args.tol_models)
    for msg in bad:
        print(
            f"TOLERANCE {'NOT CHECKED' if 'not compared' in msg or 'nothing compared' in msg else 'EXCEEDED'}: {msg}",
            file=sys.stderr,
        )
    return 1 if bad else 0


def cmd_drive_fit(args) -> int:
    from sphere_env.calibration.drive_study import drive_study
    from sphere_env.files import write_text_atomic

    man = load_manifest(args.manifest, args.data_root)
    parts = {name: man.by_name(name).load() for name in args.fit_on}
    for name, log in parts.items():
        if (log.meta or {}).get("kind") != "driven":
            raise LogError(f"manifest {args.manifest!r}: trial {name!r} is not a driven window (kind: driven)")
    whole = man.by_name(args.whole).load() if args.whole else None
    steer = [t.load() for t in man.group(args.steer_group)] if args.steer_group else []
    out = drive_study(parts, whole, args.calibrations, args.base, args.max_nfev, print, steer)
    if args.json:
        write_text_atomic(Path(args.json), json.dumps(out, indent=1) + "\n")
        print(f"wrote {args.json}")
    return 0


def cmd_pressure_fit(args) -> int:
    from sphere_env.calibration.pressure_fit import by_recording, fit_pressure
    from sphere_env.files import write_text_atomic
    from sphere_env.models.shell import ShellCalibration

    _, logs = _trials(args, required=("phi", "theta"))
    cal = ShellCalibration.load(args.calibration)
    other = [f"{log.name} ({log.fixture})" for log in logs if log.fixture not in ("steer_plane", "free")]
    if other:  # refused before any fit runs, not after the first recordings were fitted
        raise LogError(f"trials {other}: a pressure estimate needs 'steer_plane' or 'free' windows")
    fits = []
    for model in args.models:
        for group in by_recording(logs):
            fit = fit_pressure(
                group, model, cal, steer_friction=args.steer_friction, drive_friction=args.drive_friction
            )
            fits.append(fit)
            near = f"{fit.near_best_kpa[0]:g}-{fit.near_best_kpa[1]:g}"
            print(
                f"{model} {'+'.join(fit.logs)}: {fit.pressure_kpa:.2f} kPa (within 10 % of the best RMSE: {near} kPa), "
                f"pooled RMSE {fit.pooled_rmse_rad:.4f} rad"
            )
            for name, r in fit.rmse_rad.items():
                print(f"  {name}: RMSE phi {r['phi']:.4f} rad, theta {r['theta']:.4f} rad")
            for note in fit.notes:
                print(f"  note: {note}")
    if args.json:
        record = {"calibration": str(cal.source), "fits": [f.as_dict() for f in fits]}
        write_text_atomic(args.json, json.dumps(record, indent=1) + "\n")
        print(f"wrote {args.json}")
    return 0


def cmd_pressure_study(args) -> int:
    from sphere_env.calibration.pressure_fit import pressure_study
    from sphere_env.files import write_text_atomic

    man = _shared_logs(args, "pressure-study")
    if man is None:
        return 2
    record = pressure_study(man, log_to=lambda line: print(line, flush=True))
    write_text_atomic(args.out, json.dumps(record, indent=1) + "\n")
    print(f"wrote {args.out}")
    return 0


def cmd_events(args) -> int:
    import os

    from sphere_env.calibration.events import events_table, find_events, manifest_entries, write_manifest_entries
    from sphere_env.calibration.log_csv import load_log
    from sphere_env.calibration.logs import TIME_UNITS, ColumnMapping

    mapping = ColumnMapping.roboball() if args.mapping is None else ColumnMapping.load(args.mapping)
    if args.time_unit is not None:
        if args.time_unit not in TIME_UNITS:
            raise LogError(f"--time-unit: value {args.time_unit!r}; allowed: {list(TIME_UNITS)}")
        from dataclasses import replace

        mapping = replace(mapping, time=(mapping.time[0], args.time_unit))
    log = load_log(args.log, mapping)
    events = find_events(log)
    print(
        f"{args.log}: {len(log.t_s)} samples over {log.t_s[-1]:.2f} s (time unit {mapping.time[1]}); "
        f"{len(events)} free-motion event(s)"
    )
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

    man = _shared_logs(args, "report")
    if man is None:
        return 2
    cmd = "python -m sphere_env.calibration " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    path = build_report(
        man, args.out, cmd, workers=args.workers, starts=args.starts, sensitivity=not args.no_sensitivity
    )
    print(f"wrote {path}")
    return 0
