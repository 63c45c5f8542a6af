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
from typing import Any


def renamed(parser: argparse.ArgumentParser, old: str, new: str) -> None:
    """Refuse the former spelling ``old`` of an option with a message naming ``new`` (one CLI
    convention across subcommands: ``--pressure-kpa``, YAML env kwargs)."""

    class _Renamed(argparse.Action):
        def __call__(self, parser, namespace, values, option_string=None):
            parser.error(f"{old}: renamed; use {new}")

    parser.add_argument(old, nargs="*", action=_Renamed, help=argparse.SUPPRESS)


#: Deepest nesting of a command-line value (a Python literal or YAML); deeper input is refused by name.
MAX_LITERAL_DEPTH = 50


def _depth(value: Any, limit: int = MAX_LITERAL_DEPTH + 1) -> int:
    """How deeply ``value``'s lists, tuples, sets and dicts nest (counted up to ``limit``)."""
    if limit <= 0 or not isinstance(value, (list, tuple, set, frozenset, dict)):
        return 0
    items = list(value.keys()) + list(value.values()) if isinstance(value, dict) else list(value)
    return 1 + max((_depth(v, limit - 1) for v in items), default=0)


def parse_key_values(items: Sequence[str], field_name: str = "hyperparams") -> dict[str, Any]:
    """``["key:value", ...]`` as rl-zoo3's StoreDict reads them: each value a Python literal
    (``ast.literal_eval``); text that is not one stays a string (``lin_5e-4``), but text opening a
    mapping or list must be a literal (``{'base': 'full'}``), nested at most
    :data:`MAX_LITERAL_DEPTH` levels."""
    import ast

    from sphere_env.schemas import shown

    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition(":")
        key = key.strip()
        if not sep or not key:
            hint = " (a hyperparameter file goes to -conf/--conf-file)" if item.endswith((".yml", ".yaml")) else ""
            raise ValueError(f"{field_name}: {shown(item)} must be key:value{hint}")
        try:
            val = ast.literal_eval(text.strip())
        except (ValueError, SyntaxError, RecursionError, MemoryError):
            if text.strip().startswith(("{", "[", "(")):
                raise ValueError(
                    f"{field_name}.{key}: value {shown(text)} is not a Python literal (values are read as in "
                    "rl-zoo3: quote strings inside mappings, e.g. {'base': 'full'}; at most "
                    f"{MAX_LITERAL_DEPTH} levels deep)"
                ) from None
            val = text.strip()
        if _depth(val) > MAX_LITERAL_DEPTH:
            raise ValueError(
                f"{field_name}.{key}: value {shown(text)} is nested deeper than {MAX_LITERAL_DEPTH} levels"
            )
        out[key] = val
    return out


def parse_yaml_mapping(text: str, field_name: str = "env_kwargs") -> dict[str, Any]:
    """A YAML mapping without repeated keys (``{}`` for empty text), within the bounds of
    :mod:`sphere_env.safe_yaml` (size, depth, alias expansion)."""
    import yaml

    from sphere_env import safe_yaml
    from sphere_env.schemas import shown

    try:
        value = safe_yaml.load(text)
    except yaml.YAMLError as err:
        problem = " ".join(str(err).split())
        raise ValueError(f"{field_name}: {shown(text)} is not valid YAML: {problem}") from None
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise ValueError(
            f"{field_name}: value {shown(value)} must be a YAML mapping such as '{{observation_noise_scale: 0.5}}'"
        )
    return value


def parse_env_kwargs(items: str | Sequence[str], field_name: str = "env_kwargs") -> dict[str, Any]:
    """``--env-kwargs``, the same in every subcommand: one YAML mapping (``'{shell_model: point}'``)
    or rl-zoo3's ``key:value`` items (:func:`parse_key_values`)."""
    from sphere_env.schemas import shown

    items = [items] if isinstance(items, str) else list(items)
    if len(items) == 1 and (not items[0].strip() or items[0].strip().startswith("{")):
        return parse_yaml_mapping(items[0], field_name)
    for item in items:
        if ":" not in item or not item.partition(":")[0].strip():
            raise ValueError(
                f"{field_name}: {shown(item)} must be a YAML mapping such as '{{shell_model: point}}' or key:value items"
            )
    return parse_key_values(items, field_name)


@dataclass(frozen=True)
class Command:
    module: str  # module with ``main(argv)``
    summary: str
    needs: tuple[tuple[str, str], ...]  # (importable module, extra that provides it)


COMMANDS = {
    "train": Command(
        "sphere_env.training.train",
        "train a PPO/SAC policy (stable-baselines3; rl-zoo3 flags and YAML, sweeps on Ray)",
        (("stable_baselines3", "train"), ("torch", "train"), ("tensorboard", "train"), ("matplotlib", "train")),
    ),
    "evaluate": Command(
        "sphere_env.evaluation.evaluate",
        "evaluate controllers or trained policies over seeds x pressures x friction",
        (("matplotlib", "eval"), ("tqdm", "eval")),
    ),
    "enjoy": Command(
        "sphere_env.evaluation.enjoy",
        "watch a trained run in Meshcat or record it as MP4s",
        (("stable_baselines3", "train"), ("torch", "train")),
    ),
    "export": Command(
        "sphere_env.evaluation.export",
        "export a trained policy (VecNormalize folded in) to ONNX or TorchScript for the robot",
        (("stable_baselines3", "train"), ("torch", "train")),
    ),
    "calibrate": Command(
        "sphere_env.calibration.__main__",
        "fit and validate the shell and friction models against robot logs",
        (("matplotlib", "eval"),),
    ),
    "demo": Command(
        "sphere_env.evaluation.demo",
        "train PPO briefly and compare it with the baselines",
        (
            ("stable_baselines3", "train"),
            ("torch", "train"),
            ("tensorboard", "train"),
            ("matplotlib", "eval"),
            ("tqdm", "eval"),
        ),
    ),
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
        prog="sphere-env",
        description="sphere_env: Drake digital twin and Gymnasium environments of a "
        "soft, pendulum-driven spherical robot.",
        epilog="`sphere-env <command> --help` shows the options of a command.",
    )
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
        parser.exit(
            2,
            f"sphere-env {name}: needs optional dependencies; install them with\n"
            f'    pip install "sphere_env[{extras}]"\n',
        )
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
