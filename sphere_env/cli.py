"""The ``sphere-env`` command: one entry point for training, evaluation, calibration and the demo.

    sphere-env train --env sphere_env/RampDescent-v2 --algo ppo
    sphere-env evaluate --controller zero pd ppo=runs/<run>
    sphere-env enjoy runs/<run> --meshcat
    sphere-env export runs/<run>
    sphere-env calibrate report
    sphere-env demo

Each subcommand passes its arguments unchanged to the module's own command line
(``sphere-env train --help`` is ``python -m sphere_env.training.train --help``). A subcommand
whose optional dependencies are missing stops with the ``pip install`` line that provides them.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class Command:
    module: str  # module with ``main(argv)``
    summary: str
    needs: tuple[tuple[str, str], ...]  # (importable module, extra that provides it)


COMMANDS = {
    "train": Command("sphere_env.training.train", "train a PPO/SAC policy (stable-baselines3; rl-zoo3 flags and YAML, sweeps on Ray)",
                     (("stable_baselines3", "train"), ("torch", "train"), ("tensorboard", "train"),
                      ("matplotlib", "train"))),
    "evaluate": Command("sphere_env.evaluation.evaluate",
                        "evaluate controllers or trained policies over seeds x pressures x friction",
                        (("matplotlib", "eval"), ("tqdm", "eval"))),
    "enjoy": Command("sphere_env.evaluation.enjoy", "watch a trained run in Meshcat or record it as MP4s",
                     (("stable_baselines3", "train"), ("torch", "train"))),
    "export": Command("sphere_env.evaluation.export",
                      "export a trained policy (VecNormalize folded in) to ONNX or TorchScript for the robot",
                      (("stable_baselines3", "train"), ("torch", "train"))),
    "calibrate": Command("sphere_env.calibration.__main__",
                         "fit and validate the shell and friction models against robot logs",
                         (("matplotlib", "eval"),)),
    "demo": Command("sphere_env.evaluation.demo", "train PPO briefly and compare it with the baselines",
                    (("stable_baselines3", "train"), ("torch", "train"), ("tensorboard", "train"),
                     ("matplotlib", "eval"), ("tqdm", "eval"))),
}


def missing_extras(command: Command) -> list[str]:
    """Extras (``train``, ``eval``) whose modules ``command`` needs but cannot import."""
    extras = []
    for module, extra in command.needs:
        if importlib.util.find_spec(module) is None and extra not in extras:
            extras.append(extra)
    return extras


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sphere-env", description="sphere_env: Drake digital twin and Gymnasium environments of a "
        "soft, pendulum-driven spherical robot.",
        epilog="`sphere-env <command> --help` shows the options of a command.")
    sub = parser.add_subparsers(dest="command", metavar="<command>", required=True)
    for name, cmd in COMMANDS.items():
        # add_help=False: --help goes to the command's own parser, which knows its options.
        sub.add_parser(name, help=cmd.summary, add_help=False)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``sphere-env <command> [args...]``; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    if not argv or argv[0] not in COMMANDS:
        parser.parse_args(argv[:1] or ["--help"])  # prints usage/help and exits
        return 2
    name, rest = argv[0], argv[1:]
    cmd = COMMANDS[name]
    wants_help = "-h" in rest or "--help" in rest
    missing = [] if wants_help else missing_extras(cmd)
    if missing:
        extras = ",".join(missing)
        parser.exit(2, f"sphere-env {name}: needs optional dependencies; install them with\n"
                       f"    pip install \"sphere_env[{extras}]\"\n")
    module = importlib.import_module(cmd.module)
    old_argv0 = sys.argv[0]
    sys.argv[0] = f"sphere-env {name}"  # usage lines read "sphere-env train ..." (argparse's prog)
    try:
        result = module.main(rest)
    finally:
        sys.argv[0] = old_argv0
    return result if isinstance(result, int) else 0


if __name__ == "__main__":
    sys.exit(main())
