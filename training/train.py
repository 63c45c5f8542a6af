"""Train a stable-baselines3 agent (PPO or SAC) on a sphere_env id; one self-describing run folder.

    python -m training.train --env sphere_env/RampDescent-v2 --algo ppo
    python -m training.train --env sphere_env/Roll-v1 --algo sac -n 2e5 --seed 3
    python -m training.train --env sphere_env/RampDescent-v2 --algo ppo -conf my.yml \\
        --hyperparams n_envs:4 learning_rate:lin_3e-4 \\
        --env-kwargs shell_model:"'hydroelastic'" randomization:"{'pressure_kpa': [3, 10]}"
    python -m training.train -i runs/<run>/model.zip -n 1e5      # a new run from a trained model
    python -m training.train --resume runs/<run> -n 1e6           # continue from the last checkpoint
    python -m training.train --seeds 0 1 2 --ray-address auto     # a sweep (sphere_env.training.sweep)

The flags are rl-zoo3's (``-conf/--conf-file``, ``-params/--hyperparams key:value``,
``--env-kwargs``, ``--eval-env-kwargs``, ``-n``, ``--seed``, ``--eval-freq``, ``--eval-episodes``,
``--save-freq``, ``-f/--log-folder``, ``-tb/--tensorboard-log``, ``-i/--trained-agent``), and the
hyperparameter files are rl-zoo3 files (:mod:`sphere_env.training.config`). ``key:value`` values
are Python literals as in rl-zoo3; text that is not one stays a string. ``--env-kwargs`` (as in
``evaluate`` and ``enjoy``: ``key:value`` items or one YAML mapping ``'{shell_model: point}'``) are
merged key by key over the file's ``env_kwargs`` (rl-zoo3 replaces the mapping). Everything is validated
before a file is written.

The best model is chosen on fixed evaluation episodes: randomization off (``--eval-env-kwargs``
changes the evaluation env), the pressures ``--eval-pressures-kpa`` (default the calibration's low,
nominal and high) in turn, episode k with seed ``seed + 10000 + k`` (:class:`EvaluationEpisodes`).

A run folder holds::

    config.yaml              resolved config: env kwargs (randomization spec as given and resolved),
                             evaluation env kwargs and pressures, hyperparameters, seeds, versions
                             (drake, torch, sb3, sphere_env, ...) and the command
    model.zip                final model          vecnormalize.json  its VecNormalize statistics
    best/best_model.zip      best on the evaluation episodes, best/vecnormalize.json
    checkpoints/             rl_model_<steps>_steps.zip (+ _vecnormalize_ .json, SAC: _replay_buffer_, and
                             _training_state_ .json: the envs', curriculum's and process's random
                             state, which --resume restores)
    learning_curve.csv/.png  training episodes and evaluations against env steps
    monitor/                 Monitor CSVs (info keywords: pressure_kpa, is_success)
    eval/evaluations.npz     EvalCallback log          tb/  TensorBoard logs (or -tb)
"""

from __future__ import annotations

import argparse
import sys
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from sphere_env.cli import parse_env_kwargs, parse_key_values
from sphere_env.parallel import sigterm_as_interrupt
from sphere_env.schemas import validate
from sphere_env.training.config import TrainConfig, resolve_config
from sphere_env.training.run_folder import RUNS, default_run_dir, load_config
from sphere_env.training.run_options import RunFolders, check_sweep_options
from sphere_env.training.session import TrainingInterrupted
from sphere_env.training.trainer import train


class StoreDict(argparse.Action):
    """rl-zoo3's ``key:value ...`` arguments as a dict: each value is read as a Python literal
    (``ast.literal_eval``: numbers, strings in quotes, True/False/None, lists, tuples, dicts); text
    that is not a literal stays a string (``learning_rate:lin_5e-4``, ``policy_kwargs:"dict(...)"``),
    as rl-zoo3 users write it. A value that opens a mapping or list but is not a Python literal
    (YAML flow style ``{base: full}``) is refused: write ``{'base': 'full'}``."""

    def __call__(self, parser, namespace, values, option_string=None):
        try:
            parse = parse_env_kwargs if self.dest.endswith("env_kwargs") else parse_key_values
            setattr(namespace, self.dest, {**(getattr(namespace, self.dest, None) or {}), **parse(values, self.dest)})
        except ValueError as err:
            parser.exit(2, f"{parser.prog}: error: {err}\n")


def _config_flags(parser: argparse.ArgumentParser) -> None:
    """The env, the algorithm, its hyperparameters and the env kwargs (rl-zoo3's flags)."""
    parser.add_argument("--env", default="sphere_env/RampDescent-v3", help="registered env id")
    parser.add_argument("--algo", default="ppo", help="ppo or sac")
    parser.add_argument(
        "-conf",
        "--conf-file",
        type=Path,
        default=None,
        help="hyperparameter YAML (default: the shipped training/hyperparams/<algo>.yml)",
    )
    parser.add_argument(
        "-params",
        "--hyperparams",
        "--params",
        dest="hyperparams",
        nargs="+",
        action=StoreDict,
        default={},
        metavar="KEY:VALUE",
        help="override hyperparameters, e.g. n_envs:4 learning_rate:1e-3 (values as Python literals)",
    )
    parser.add_argument(
        "--env-kwargs",
        nargs="+",
        action=StoreDict,
        default={},
        metavar="KEY:VALUE",
        help="env kwargs merged over the YAML's env_kwargs, e.g. shell_model:'hydroelastic' "
        "randomization:\"{'base': 'full'}\"",
    )
    parser.add_argument(
        "--eval-env-kwargs",
        nargs="+",
        action=StoreDict,
        default={},
        metavar="KEY:VALUE",
        help="evaluation env kwargs over the training ones (default randomization:'off')",
    )


def _budget_and_sweep_flags(parser: argparse.ArgumentParser) -> None:
    """The budget, the seed and the sweep's seeds, trials and Ray address."""
    parser.add_argument("-n", "--n-timesteps", type=float, default=None, help="total env steps (overrides the YAML)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (-1: draw one, as rl-zoo3)")
    parser.add_argument(
        "--seeds",
        type=int,
        nargs="+",
        default=None,
        help="train one run per seed (a sweep: one folder per trial, aggregate learning curve)",
    )
    parser.add_argument(
        "--trial",
        action="append",
        default=None,
        metavar="'KEY:VALUE ...'",
        help="a sweep configuration: --hyperparams overrides in one quoted string; repeat for more",
    )
    parser.add_argument(
        "--ray-address",
        default=None,
        help="run the sweep's trials as Ray tasks: 'local' (start one), 'auto', or ray://host:port",
    )


def _run_folder_flags(parser: argparse.ArgumentParser) -> None:
    """Where the run goes and what it starts from."""
    parser.add_argument("-f", "--log-folder", type=Path, default=RUNS, help="folder of the run folders (default runs/)")
    parser.add_argument(
        "--run-dir",
        type=Path,
        default=None,
        help="exact run (or sweep) folder (default <log-folder>/<algo>_<env>_<time>_s<seed>)",
    )
    parser.add_argument(
        "--resume",
        type=Path,
        default=None,
        help="continue this run folder from its last checkpoint, with its config.yaml (takes -n, --no-progress, -v only)",
    )
    parser.add_argument(
        "-i",
        "--trained-agent",
        type=Path,
        default=None,
        help="start from this model.zip (with its VecNormalize statistics) in a new run folder",
    )


def _evaluation_and_checkpoint_flags(parser: argparse.ArgumentParser) -> None:
    """Evaluations, checkpoints and logs."""
    parser.add_argument("--eval-freq", type=int, default=None, help="env steps between evaluations (<= 0: none)")
    parser.add_argument(
        "--eval-episodes",
        type=int,
        default=6,
        help="episodes per evaluation, cycling over --eval-pressures-kpa (default 6)",
    )
    parser.add_argument(
        "--eval-pressures-kpa",
        type=float,
        nargs="*",
        default=None,
        help="evaluation pressures (default: the calibration's low, nominal, high; "
        "none given: the eval env's randomization draws them)",
    )
    parser.add_argument(
        "--save-freq",
        "--checkpoint-freq",
        dest="save_freq",
        type=int,
        default=None,
        help="env steps between checkpoints (<= 0: only the final one)",
    )


def _process_flags(parser: argparse.ArgumentParser) -> None:
    """TensorBoard, torch threads and device, replay buffer, progress and verbosity."""
    parser.add_argument(
        "-tb", "--tensorboard-log", type=Path, default=None, help="TensorBoard folder (default <run>/tb)"
    )
    parser.add_argument("--torch-threads", "--num-threads", dest="torch_threads", type=int, default=1)
    parser.add_argument("--device", default="cpu", help="torch device (default cpu)")
    parser.add_argument(
        "--save-replay-buffer",
        action="store_true",
        help="SAC: keep the replay buffer in every checkpoint (hundreds of MB); without it a "
        "resumed run starts with an empty buffer",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("-v", "--verbose", type=int, default=0)


def build_parser() -> argparse.ArgumentParser:
    """The command line: rl-zoo3's ``train.py`` flags for what this trainer does, plus its own."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter, allow_abbrev=False
    )
    _config_flags(parser)
    _budget_and_sweep_flags(parser)
    _run_folder_flags(parser)
    _evaluation_and_checkpoint_flags(parser)
    _process_flags(parser)
    return parser


#: What a resume takes from its command line; everything else comes from the run's config.yaml.
RESUME_FLAGS = ("resume", "n_timesteps", "no_progress", "verbose")


def refuse_resume_flags(argv: Sequence[str]) -> None:
    """Refuse, naming them, the flags given with ``--resume`` that a resume would not apply (the
    run continues with the configuration in its ``config.yaml``: env, algorithm, hyperparameters,
    env kwargs, seeds, evaluation and checkpoint periods...)."""
    parser = build_parser()
    for action in parser._actions:
        action.default = argparse.SUPPRESS  # only what the command line gives is in the namespace
    given = vars(parser.parse_args(argv))
    ignored = [a for a in parser._actions if a.dest in given and a.dest not in RESUME_FLAGS]
    if ignored:
        names = ", ".join("/".join(a.option_strings) for a in ignored)
        raise ValueError(
            f"resume: {names} cannot change a resumed run, which continues with the configuration in its "
            "config.yaml; a resume takes -n/--n-timesteps, --no-progress and -v only (train a new run, "
            "or -i <run>/model.zip, to change the rest)"
        )


def main(argv: Sequence[str] | None = None) -> Path:
    parser = build_parser()
    args = parser.parse_args(argv)
    argv = list(argv if argv is not None else sys.argv[1:])
    command = [sys.executable, "-m", "sphere_env.training.train", *argv]
    try:
        if args.resume is not None:
            refuse_resume_flags(argv)
        if args.resume is None:
            validate(RunFolders, {"log_folder": args.log_folder, "run_dir": args.run_dir})
        with sigterm_as_interrupt():
            if args.resume is not None:
                run = _resume(args, command)
            elif args.seeds is not None or args.trial is not None or args.ray_address is not None:
                from sphere_env.training.sweep import run_sweep

                run = run_sweep(
                    sweep_configs(args),
                    args.run_dir or default_sweep_dir(args),
                    ray_address=args.ray_address,
                    command=command,
                )
            else:
                cfg = _config_from_args(args, args.hyperparams, args.seed)
                run = train(
                    cfg,
                    args.run_dir or default_run_dir(cfg, args.log_folder),
                    progress_bar=not args.no_progress,
                    verbose=args.verbose,
                    command=command,
                )
    except ValueError as err:
        parser.exit(2, f"{parser.prog}: error: {err}\n")
    except OSError as err:  # a write that failed after the checks (disk full, a folder removed meanwhile)
        parser.exit(2, f"{parser.prog}: error: {err}\n")
    except TrainingInterrupted as err:
        parser.exit(130, f"{parser.prog}: {err}\n")
    except KeyboardInterrupt:
        parser.exit(130, f"{parser.prog}: interrupted before training started; nothing saved\n")
    print(f"run folder: {run.resolve()}")
    return run


def _seed(seed: int) -> int:
    """rl-zoo3's ``--seed -1``: draw a seed."""
    return int(np.random.default_rng().integers(2**31 - 1)) if seed < 0 else seed


def _config_from_args(args: argparse.Namespace, hyperparams: Mapping[str, Any], seed: int) -> TrainConfig:
    overrides = dict(hyperparams)
    if args.n_timesteps is not None:
        overrides["n_timesteps"] = args.n_timesteps
    return resolve_config(
        args.env,
        args.algo,
        args.conf_file,
        overrides,
        seed=_seed(seed),
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        eval_env_kwargs=args.eval_env_kwargs,
        eval_pressures_kpa=args.eval_pressures_kpa,
        checkpoint_freq=args.save_freq,
        device=args.device,
        torch_threads=args.torch_threads,
        env_kwargs=args.env_kwargs,
        tensorboard_log=args.tensorboard_log,
        trained_agent=args.trained_agent,
        save_replay_buffer=args.save_replay_buffer,
    )


def sweep_configs(args: argparse.Namespace) -> list[TrainConfig]:
    """One validated config per trial: every ``--trial`` (or the plain overrides) × every seed."""
    opts = check_sweep_options(
        seeds=args.seeds if args.seeds is not None else [args.seed],
        trained_agent=args.trained_agent,
        tensorboard_log=args.tensorboard_log,
    )
    trials = (
        [dict(args.hyperparams)]
        if not args.trial
        else [{**args.hyperparams, **parse_key_values(t.split(), "trial")} for t in args.trial]
    )
    return [_config_from_args(args, h, s) for h in trials for s in opts.seeds]


def default_sweep_dir(args: argparse.Namespace) -> Path:
    import secrets

    stamp = datetime.now(UTC).strftime("%Y%m%d-%H%M%S")  # + a random suffix: sweeps started in one second differ
    return args.log_folder / f"sweep_{args.algo}_{args.env.split('/')[-1]}_{stamp}_{secrets.token_hex(3)}"


def _resume(args: argparse.Namespace, command: Sequence[str]) -> Path:
    cfg = load_config(args.resume)
    if args.n_timesteps is not None:
        cfg.n_timesteps = args.n_timesteps  # checked with the rest by resolve_config
    cfg = resolve_config(
        cfg.env_id,
        cfg.algo,
        cfg.hyperparams_file or None,
        overrides=_stored_overrides(cfg),
        seed=cfg.seed,
        eval_freq=cfg.eval_freq,
        eval_episodes=cfg.eval_episodes,
        eval_env_kwargs=cfg.eval_env_kwargs,
        eval_pressures_kpa=cfg.eval_pressures_kpa,
        checkpoint_freq=cfg.checkpoint_freq,
        device=cfg.device,
        torch_threads=cfg.torch_threads,
        tensorboard_log=cfg.tensorboard_log,
    )
    return train(
        cfg, args.resume, resume=True, progress_bar=not args.no_progress, verbose=args.verbose, command=command
    )


def _stored_overrides(cfg: TrainConfig) -> dict[str, Any]:
    """A stored config as YAML-section overrides (so a resume re-validates exactly what ran)."""
    return {
        "n_envs": cfg.n_envs,
        "n_workers": cfg.n_workers,
        "n_threads": cfg.n_threads,
        "n_timesteps": cfg.n_timesteps,
        "policy": cfg.policy,
        "normalize": cfg.normalize if cfg.normalize is not None else False,
        "env_kwargs": cfg.env_kwargs,
        "env_wrapper": cfg.env_wrapper or None,
        "callback": cfg.callback or None,
        **cfg.hyperparams,
    }


if __name__ == "__main__":
    main()
