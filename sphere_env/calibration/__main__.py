"""CLI: ``python -m sphere_env.calibration <command>``.

Commands
  shell        free-decay logs at several pressures -> ω_n(p), ζ(p) -> calibration YAML + plot
  steer-fit    steer-plane logs at one pressure -> injected / hydroelastic parameters -> calibration YAML
  friction     stand-swing logs -> friction law parameters -> preset YAML + overlay plot (+ leave-one-out)
  sensitivity  hydroelastic ±50 % sweep (paper Fig. 11) on a process pool
  kd-step      hydroelastic k_d refitted at another plant step -> calibration YAML (k_d_by_time_step)
  kd-pressure  hydroelastic k_d against pressure at a plant step, fitted to ζ(p) -> calibration YAML (k_d_by_pressure)
  pressure-fit one inflation pressure per recording, estimated from its free motion with a fixed calibration
  pressure-study both shipped calibrations with a pressure per shared recording -> evaluation/results/validation/
  events       free-motion events (release or push, then free decay) in a long log [-> manifest entries]
  validate     any manifest's logs against any shell models; exit 1 if a tolerance is exceeded
  drive-fit    driven windows replayed, the drive direction fitted on one part and tested on the other
  report       regenerate evaluation/results/validation/ from the real logs
Every command reads a trial manifest (``--manifest``, default ``assets/logs/roboball.yaml``).
Bad input exits with status 2 and a message naming the file, line/column or field.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from sphere_env.calibration.commands import (
    cmd_drive_fit,
    cmd_events,
    cmd_friction,
    cmd_kd_pressure,
    cmd_kd_step,
    cmd_pressure_fit,
    cmd_pressure_study,
    cmd_report,
    cmd_sensitivity,
    cmd_shell,
    cmd_steer_fit,
    cmd_validate,
)
from sphere_env.cli import renamed
from sphere_env.files import OutputFile, OutputFolder
from sphere_env.models.calibration_schema import STEER_LAW_FORMS
from sphere_env.params import PARAMETERS
from sphere_env.resources import asset_path
from sphere_env.schemas import Finite, checker, cli_type, count, number

DEFAULT_MANIFEST = asset_path("logs", "roboball.yaml")
# argparse types of the numeric flags: bounded, refused with argparse's one-line error (exit 2)
WORKERS = cli_type(count(1, 1024), int, "workers")
STARTS = cli_type(count(1, 100), int, "starts")
SEED = cli_type(count(0, 2**32 - 1), int, "seed")
MAX_NFEV = cli_type(count(1, 100_000), int, "max_nfev")
TIME_STEP_S = cli_type(PARAMETERS["time_step_s"].value_type, float, "time_step_s")
PRESSURE_KPA = cli_type(Finite, float, "pressure_kpa")  # against the calibration's range once it is loaded
DURATION_S = cli_type(number(gt=0.0, le=600.0, words="a simulated time in (0, 600] s"), float, "duration_s")
OUTPUT_FILE = checker(OutputFile)
OUTPUT_FOLDER = checker(OutputFolder)


def HOLD(text: str) -> tuple[str, tuple[float, ...]]:
    """``--hold`` item NAME=VALUE[,VALUE...]: a fitted parameter held at each value in turn."""
    from sphere_env.calibration.shell_params import check_hold

    name, sep, values = text.partition("=")
    try:
        if not sep or not values:
            raise ValueError("expected NAME=VALUE[,VALUE...]")
        vals = tuple(float(v) for v in values.split(","))
        for v in vals:
            check_hold({name: v}, "--hold")
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"{text!r}: {err}") from None
    return name, vals


def _common(p, group=None) -> None:
    """The manifest flags most commands share."""
    p.add_argument("--manifest", default=str(DEFAULT_MANIFEST), help="trial manifest YAML")
    p.add_argument("--data-root", default=None, help="override the manifest's data_root")
    p.add_argument("--group", default=group, help=f"manifest group (default {group})")
    p.add_argument("--trial", nargs="*", help="only these trial names")


def _add_shell(sub) -> None:
    """The ``shell`` command and its flags."""
    p = sub.add_parser("shell", help="free decays at several pressures -> ω_n(p), ζ(p) calibration file")
    _common(p, "locked_steer")
    p.add_argument("--channel", default="phi", choices=["phi", "theta"], help="decaying channel (rad)")
    p.add_argument("--base", default=None, help="calibration whose V(p) and hydroelastic settings are kept")
    p.add_argument("--out", help="calibration YAML to write")
    p.add_argument("--plot", help="PNG of data, fits and the point-contact line")
    p.set_defaults(func=cmd_shell)


def _add_steer_fit(sub) -> None:
    """The ``steer-fit`` command and its flags."""
    p = sub.add_parser("steer-fit", help="free-motion segments (steer_plane trials, free windows) -> shell law")
    _common(p, "steer_free")
    p.add_argument("--models", nargs="+", default=["injected", "hydroelastic"], choices=["injected", "hydroelastic"])
    p.add_argument(
        "--forms",
        nargs="+",
        default=list(STEER_LAW_FORMS),
        choices=list(STEER_LAW_FORMS),
        help="steer-law forms to try; with several, the one with the least held-out phi RMSE is fitted",
    )
    p.add_argument(
        "--hold",
        nargs="+",
        type=HOLD,
        default=[],
        metavar="NAME=VALUE[,VALUE...]",
        help="parameters held instead of fitted (e.g. amplitude_scale_rad=0.05,0.07,0.1 omega_n=2.3); "
        "several values are candidates chosen by held-out phi RMSE, as forms are",
    )
    p.add_argument(
        "--pressure-kpa",
        type=PRESSURE_KPA,
        default=None,
        help="pressure the fit is stated at (default: the base calibration's nominal; the segments' "
        "own pressure may be unknown)",
    )
    p.add_argument(
        "--fit-on",
        nargs="*",
        help="trial names to fit on (others are validation); with two or more, "
        "each is also left out in turn (leave-one-window-out) and its held-out RMSE recorded",
    )
    p.add_argument("--workers", type=WORKERS, default=1, help="processes for the cross-validation folds (default 1)")
    p.add_argument(
        "--max-nfev", type=MAX_NFEV, default=60, help="simulations allowed per fit (refused if not converged)"
    )
    p.add_argument("--steer-friction", default="majd_steer")
    p.add_argument("--drive-friction", default="majd_drive", help="drive friction on free windows")
    p.add_argument("--base", default=None, help="starting calibration (slopes, V(p) shape are kept)")
    p.add_argument(
        "--match-kd",
        action="store_true",
        help="then set hydroelastic k_d so the locked-steer hydroelastic decay has ζ(p0)",
    )
    p.add_argument(
        "--time-step-s",
        type=TIME_STEP_S,
        default=None,
        help="plant step [s] the k_d match runs at and is recorded for (default: the twin's)",
    )
    p.add_argument("--out", help="calibration YAML to write")
    p.set_defaults(func=cmd_steer_fit)


def _add_friction(sub) -> None:
    """The ``friction`` command and its flags."""
    p = sub.add_parser("friction", help="stand swings -> friction parameters")
    _common(p, "stand_swing")
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


def _add_sensitivity(sub) -> None:
    """The ``sensitivity`` command and its flags."""
    p = sub.add_parser("sensitivity", help="hydroelastic ±50%% sweep (paper Fig. 11)")
    p.add_argument("--calibration", default=None)
    p.add_argument("--pressure-kpa", type=PRESSURE_KPA, nargs="*", help="pressures [kPa] (default: the calibration's)")
    renamed(p, "--pressures-kpa", "--pressure-kpa")
    p.add_argument("--workers", type=WORKERS, default=None)
    p.add_argument("--duration-s", type=DURATION_S, default=6.0)
    p.add_argument("--plot")
    p.set_defaults(func=cmd_sensitivity)


def _add_kd_step(sub) -> None:
    """The ``kd-step`` command and its flags."""
    p = sub.add_parser("kd-step", help="hydroelastic k_d refitted at another plant step (k_d_by_time_step)")
    p.add_argument("--calibration", default=None, help="calibration YAML (default: the shipped one)")
    p.add_argument("--time-step-s", type=TIME_STEP_S, required=True, help="plant step [s] to refit k_d at")
    p.add_argument("--pressure-kpa", type=PRESSURE_KPA, default=None, help="pressure of the decays (default: nominal)")
    p.add_argument("--out", required=True, help="calibration YAML to write (the input plus the refit)")
    p.set_defaults(func=cmd_kd_step)


def _add_kd_pressure(sub) -> None:
    """The ``kd-pressure`` command and its flags."""
    p = sub.add_parser(
        "kd-pressure",
        help="hydroelastic k_d against pressure at a plant step, each fitted so "
        "the locked-steer decay has ζ(p) (k_d_by_pressure)",
    )
    p.add_argument("--calibration", default=None, help="calibration YAML (default: the shipped one)")
    p.add_argument("--time-step-s", type=TIME_STEP_S, required=True, help="plant step [s] the decays run at")
    renamed(p, "--pressures-kpa", "--pressure-kpa")
    p.add_argument(
        "--pressure-kpa",
        type=PRESSURE_KPA,
        nargs="+",
        default=None,
        help="pressures [kPa] to fit k_d at, spanning the calibrated range (default: its ends, the "
        "nominal, 5 even points and both sides of a low_pressure_mesh switch)",
    )
    p.add_argument("--out", required=True, help="calibration YAML to write (the input plus the table)")
    p.set_defaults(func=cmd_kd_pressure)


def _add_pressure_fit(sub) -> None:
    """The ``pressure-fit`` command and its flags."""
    p = sub.add_parser(
        "pressure-fit",
        help="one inflation pressure per recording, estimated from its free motion with a fixed calibration",
    )
    _common(p, "free_robot")
    p.add_argument("--models", nargs="+", default=["injected", "hydroelastic"], choices=["injected", "hydroelastic"])
    p.add_argument("--calibration", default=None, help="calibration YAML held fixed (default: the shipped one)")
    p.add_argument("--steer-friction", default="majd_steer")
    p.add_argument("--drive-friction", default="majd_drive", help="drive friction on free windows")
    p.add_argument("--json", default=None, metavar="PATH", help="write every estimate and its profile")
    p.set_defaults(func=cmd_pressure_fit)


def _add_pressure_study(sub) -> None:
    """The ``pressure-study`` command and its flags."""
    p = sub.add_parser(
        "pressure-study",
        help="both shipped calibrations with one pressure per shared recording (one twin for every log?)",
    )
    p.add_argument("--manifest", default=str(DEFAULT_MANIFEST))
    p.add_argument("--data-root", default=None)
    p.add_argument("--out", default=str(Path("evaluation") / "results" / "validation" / "pressure_per_log.json"))
    p.set_defaults(func=cmd_pressure_study)


def _add_events(sub) -> None:
    """The ``events`` command and its flags."""
    p = sub.add_parser("events", help="free-motion events in a long log; optionally write manifest entries")
    p.add_argument("log", help="CSV log (RoboBall names, or --mapping)")
    p.add_argument("--mapping", default=None, help="column mapping YAML for other naming")
    p.add_argument("--time-unit", default=None, help="time column unit, overriding the mapping's (s|ms|us|ns)")
    p.add_argument(
        "--write-manifest",
        default=None,
        metavar="PATH",
        help="add one fixture:free entry per event to this manifest (created if missing)",
    )
    p.add_argument("--group", default=None, help="group of the written entries (default: the log's folder)")
    p.add_argument(
        "--duration-s",
        type=DURATION_S,
        default=None,
        help="cap each written window at this many seconds from its start",
    )
    p.add_argument("--json", action="store_true", help="also print the events as JSON")
    p.set_defaults(func=cmd_events)


def _add_validate(sub) -> None:
    """The ``validate`` command and its flags."""
    p = sub.add_parser("validate", help="logs against shell models; exit 1 past a tolerance")
    _common(p, None)
    p.add_argument("--models", nargs="+", default=["point", "injected", "hydroelastic"])
    p.add_argument("--calibration", default=None)
    p.add_argument("--pressure-kpa", type=PRESSURE_KPA, default=None, help="pressure for trials without one")
    p.add_argument("--steer-friction", default="majd_steer")
    p.add_argument("--drive-friction", default="majd_drive")
    p.add_argument(
        "--tol",
        nargs="*",
        help="limits like phi=0.1 theta=0.12 omega_d=0.5 pendulum_pitch=0.05 "
        "pme=15; exit 1 if one is exceeded or could not be checked on a trial",
    )
    p.add_argument("--tol-models", nargs="*", default=None, help="models the tolerance applies to (default all)")
    p.add_argument(
        "--json",
        default=None,
        metavar="PATH",
        help="write one record per trial and model (trial, model, rmse_phi_rad, rmse_theta_rad, ...)",
    )
    p.add_argument("--workers", type=WORKERS, default=1, help="processes for the (trial, model) runs (default 1)")
    p.add_argument("--plot")
    p.set_defaults(func=cmd_validate)


def _add_drive_fit(sub) -> None:
    """The ``drive-fit`` command and its flags."""
    p = sub.add_parser(
        "drive-fit",
        help="driven windows replayed (pendulum tracking the log), drive direction fitted on one part, tested on the other",
    )
    p.add_argument("--manifest", default=str(DEFAULT_MANIFEST), help="trial manifest YAML")
    p.add_argument("--data-root", default=None, help="override the manifest's data_root")
    p.add_argument(
        "--fit-on",
        nargs=2,
        default=["drive_forward", "drive_backward"],
        metavar=("FIRST", "SECOND"),
        help="the two driven windows: fitted on each, tested on the other",
    )
    p.add_argument("--whole", default="drive_all", help="the whole segment, replayed only ('' for none)")
    p.add_argument("--calibrations", nargs="+", default=["default", "free_robot"], help="calibrations replayed")
    p.add_argument("--base", nargs="+", default=["free_robot", "default"], help="calibrations the fits start from")
    p.add_argument(
        "--steer-group",
        default="free_robot",
        help="free-motion windows replayed without and with each soft fit ('' for none)",
    )
    p.add_argument("--max-nfev", type=MAX_NFEV, default=20, help="replays allowed per fit")
    p.add_argument(
        "--json", default=None, metavar="PATH", help="write the results (evaluation/results/validation/drive_fit.json)"
    )
    p.set_defaults(func=cmd_drive_fit)


def _add_report(sub) -> None:
    """The ``report`` command and its flags."""
    p = sub.add_parser("report", help="regenerate the committed validation report")
    p.add_argument("--manifest", default=str(DEFAULT_MANIFEST))
    p.add_argument("--data-root", default=None)
    p.add_argument("--out", default=str(Path("evaluation") / "results" / "validation"))
    p.add_argument("--workers", type=WORKERS, default=None)
    p.add_argument("--starts", type=STARTS, default=2)
    p.add_argument("--no-sensitivity", action="store_true")
    p.set_defaults(func=cmd_report)


def build_parser() -> argparse.ArgumentParser:
    # usage lines read "sphere-env calibrate ..." from the sphere-env command (which sets argv[0])
    prog = sys.argv[0] if sys.argv[0].startswith("sphere-env") else "python -m sphere_env.calibration"
    ap = argparse.ArgumentParser(
        prog=prog, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter, allow_abbrev=False
    )
    sub = ap.add_subparsers(dest="command", required=True)

    for add in (
        _add_shell,
        _add_steer_fit,
        _add_friction,
        _add_sensitivity,
        _add_kd_step,
        _add_kd_pressure,
        _add_pressure_fit,
        _add_pressure_study,
        _add_events,
        _add_validate,
        _add_drive_fit,
        _add_report,
    ):
        add(sub)
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
