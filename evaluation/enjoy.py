"""Watch a trained policy: roll out a training run folder on its env, live in Meshcat or as MP4s.

    python -m evaluation.enjoy runs/ppo_RampDescent-v2_<time>_s0 --meshcat
    python -m evaluation.enjoy runs/<run>@best --episodes 3 --pressure-kpa 5 --shell-model hydroelastic \\
        --video out/videos
    sphere-env enjoy runs/<run> --stochastic --seed 4

The run folder is what ``training/train.py`` writes (``config.yaml``, ``model.zip``,
``vecnormalize.json``; ``<run>@best`` takes ``best/``). The policy is loaded as the evaluation loads a
``<run>`` controller (:class:`sphere_env.evaluation.controller_specs.PolicyController`: its
VecNormalize statistics and training env kwargs come with it) and each episode is rolled out as one
evaluation cell (:func:`sphere_env.evaluation.cells.rollout`): randomization off, the pressure
fixed (default: the calibration's nominal pressure), episode ``k`` seeded with ``seed + k``.

``--meshcat`` shows the episodes live (the URL is printed; paced at ``--realtime-rate``).
``--video FOLDER`` renders them (``rgb_array``) into ``FOLDER/<label>_<shell model>_<p>kPa_s<seed>.mp4``
through ``RecordVideo`` (the ``video`` extra), moved into place when every episode has finished.

Refused before anything runs, with the field named: options the schema
(:class:`sphere_env.evaluation.command_options.EnjoyFields`) refuses (a run that is not a folder, an unknown
shell model or env id, a pressure that is not a finite number, episodes outside [1, 10000], a
negative seed, env kwargs the command sets itself, a video folder that is a file); then a run folder
without ``config.yaml``, without its model, or without the VecNormalize statistics it was trained
with; a model that does not load; an env id other than the run's (unless ``--allow-env-mismatch``);
a pressure outside the calibrated range.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from sphere_env.cli import renamed
from sphere_env.evaluation.command_options import EnjoyFields, ViewOptions
from sphere_env.params import SHELL_MODELS
from sphere_env.schemas import validate


class EnjoySpec(EnjoyFields):
    """What to watch (fields and their checks: :class:`sphere_env.evaluation.command_options.EnjoyFields`).
    ``run`` is a run folder, optionally ``@best``; ``None`` fields take the run's own values (env id,
    shell model) or the calibration's nominal pressure [kPa]."""

    def resolve(self) -> dict[str, Any]:
        """Check the run folder against the options (ValueError naming the field) and return the
        resolved settings: ``folder``, ``which``, ``config``, ``env_id``, ``shell_model``,
        ``friction``, ``pressure_kpa``, ``env_kwargs``, ``label``."""
        from sphere_env.envs.kwargs import check_episode_length
        from sphere_env.evaluation.controller_specs import check_spec, env_kwargs_of, run_path
        from sphere_env.models.shell import ShellCalibration
        from sphere_env.physics.config import DEFAULT_SHELL_MODEL
        from sphere_env.training.run_folder import load_config

        path, _, which = self.run.partition("@")
        folder = run_path(path)
        cfg = load_config(folder)  # "run: ... has no config.yaml" / cannot be read
        which = which or "model"
        env_id = self.env_id or cfg.env_id
        try:  # the model and its statistics are there and load, trained on env_id (or allowed not to be)
            check_spec(f"{folder}@{which}", env_id, self.allow_env_mismatch)
        except ValueError as err:
            raise ValueError(str(err).replace("controller: ", "run: ", 1)) from None
        env_kwargs = {**env_kwargs_of(f"{folder}@{which}"), **self.env_kwargs}
        check_episode_length(env_id, env_kwargs)
        shell = self.shell_model or cfg.env_kwargs.get("shell_model", DEFAULT_SHELL_MODEL)
        cal = ShellCalibration.load(env_kwargs.get("calibration"))
        pressure = cal.nominal_pressure_kpa if self.pressure_kpa is None else self.pressure_kpa
        cal.check_pressure(pressure, "field 'pressure_kpa'")
        name = path if path == "pretrained" else folder.name
        label = self.label or (name if which == "model" else f"{name}@best")
        return {
            "folder": folder,
            "which": which,
            "config": cfg,
            "env_id": env_id,
            "shell_model": shell,
            "friction": cfg.env_kwargs.get("friction_model", "majd"),
            "pressure_kpa": float(pressure),
            "env_kwargs": env_kwargs,
            "label": label,
        }


class Paced:
    """Wraps a controller: publishes to Meshcat before each action and waits so that simulated time
    runs at ``realtime_rate`` × wall time (0: no waiting)."""

    def __init__(self, controller: Callable, env: Any, realtime_rate: float):
        self.controller, self.env, self.rate = controller, env, realtime_rate
        self._t0 = time.perf_counter()
        self._steps = 0

    def reset(self) -> None:
        if hasattr(self.controller, "reset"):
            self.controller.reset()
        self._t0 = time.perf_counter()
        self._steps = 0

    def __call__(self, obs, info=None):
        u = self.env.unwrapped
        u.twin.publish()
        if self.rate > 0:
            wait = self._steps * u.control_period_s / self.rate - (time.perf_counter() - self._t0)
            if wait > 0:
                time.sleep(wait)
        self._steps += 1
        return self.controller(obs, info)


def make_policy(folder: Path, which: str, deterministic: bool, seed: int, env: Any = None) -> Callable:
    """The run's policy as a controller ``(obs, info) -> action``; stochastic actions are seeded.
    With ``env``, a policy that cannot read its observations is refused."""
    from sphere_env.evaluation.controller_specs import PolicyController

    policy = PolicyController(folder, which)
    if env is not None:
        policy.check_env(env, str(folder))
    if deterministic:
        return policy
    policy.model.set_random_seed(seed)

    def sample(obs, info=None):
        return policy.act(obs, info, deterministic=False)

    sample.reset = policy.reset  # type: ignore[attr-defined]

    return sample


def _make_env(r: dict[str, Any], render_mode: str | None, meshcat: bool):
    """The run's env, randomization off, at the resolved shell model and friction; env kwargs it
    refuses raised as a ValueError naming ``env_kwargs``."""
    import gymnasium as gym

    try:
        return gym.make(
            r["env_id"],
            shell_model=r["shell_model"],
            friction_model=r["friction"],
            randomization="off",
            render_mode=render_mode,
            meshcat=meshcat,
            **r["env_kwargs"],
        )
    except TypeError as err:
        raise ValueError(f"env_kwargs: {err}") from None


def _play(env, controller, r: dict[str, Any], spec: EnjoySpec, seed: int, video, video_work) -> dict[str, Any]:
    """One episode as an evaluation cell, recorded into ``video_work`` when given; its row of
    metrics (with the MP4's final path under ``video``)."""
    from sphere_env.evaluation.cells import rollout
    from sphere_env.evaluation.video import record_episode, video_name

    job = {
        "controller": r["label"],
        "spec": str(spec.run),
        "env_id": r["env_id"],
        "shell_model": r["shell_model"],
        "friction": r["friction"],
        "pressure_kpa": r["pressure_kpa"],
        "seed": seed,
        "env_kwargs": r["env_kwargs"],
    }
    if video_work is None:
        return rollout(job, env=env, controller=controller)[0]
    name = video_name(r["label"], r["shell_model"], r["pressure_kpa"], seed)
    row, _ = record_episode(env, video_work, name, lambda rec: rollout(job, env=rec, controller=controller))
    row["video"] = str(Path(video) / f"{name}.mp4")
    return row


def _said(k: int, row: Mapping[str, Any]) -> str:
    """The line that reports episode ``k``."""
    return (
        f"episode {k}: seed {row['seed']}, {row['pressure_kpa']:g} kPa, {row['shell_model']}: "
        f"return {row['return']:.3f}, {row['length']} steps, success {bool(row['is_success'])}, "
        f"tracking RMSE {row['tracking_rmse_rad_s']:.3f} rad/s"
        + (f", truncated ({row['truncation_reason']})" if row["truncation_reason"] else "")
    )


def enjoy(
    spec: EnjoySpec,
    meshcat: bool = False,
    video: str | Path | None = None,
    realtime_rate: float = 1.0,
    wait_for_enter: bool = False,
    say: Callable[[str], None] = print,
) -> list[dict[str, Any]]:
    """Roll out ``spec.episodes`` episodes; returns one row of metrics per episode (the evaluation's
    columns). ``video``: folder for the MP4s; ``meshcat``: live view."""
    from sphere_env.evaluation.video import check_video_support, staged_videos

    view = validate(ViewOptions, dict(meshcat=meshcat, video=video, realtime_rate=realtime_rate))
    meshcat, video = view.meshcat, view.video
    if video is not None:
        check_video_support()
    r = spec.resolve()
    import torch

    torch.set_num_threads(1)
    env = _make_env(r, "rgb_array" if video is not None else ("human" if meshcat else None), bool(meshcat))
    rows = []
    try:
        controller = make_policy(r["folder"], r["which"], spec.deterministic, spec.seed, env)
        if meshcat:
            say(f"Meshcat: {env.unwrapped.meshcat.web_url()}")
            controller = Paced(controller, env, view.realtime_rate)
        with staged_videos(video) as video_work:
            for k in range(spec.episodes):
                row = _play(env, controller, r, spec, spec.seed + k, video, video_work)
                if meshcat:
                    env.unwrapped.twin.publish()  # the last state
                rows.append(row)
                say(_said(k, row))
        for row in rows:
            if "video" in row:
                say(f"video: {row['video']}")
        if meshcat and wait_for_enter:
            input(f"Meshcat still serving at {env.unwrapped.meshcat.web_url()}; press Enter to quit ")
    finally:
        env.close()
    return rows


def main(argv: Sequence[str] | None = None) -> list[dict[str, Any]]:
    from sphere_env.cli import parse_env_kwargs

    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter, allow_abbrev=False
    )
    parser.add_argument(
        "run", help="training run folder (config.yaml, model.zip, vecnormalize.json); <run>@best for its best model"
    )
    parser.add_argument("--episodes", type=int, default=1, help="number of episodes (seeds seed, seed+1, ...)")
    parser.add_argument(
        "--pressure-kpa",
        type=float,
        default=None,
        help="inflation pressure [kPa] (default: the calibration's nominal pressure)",
    )
    renamed(parser, "--pressure", "--pressure-kpa")
    parser.add_argument("--shell-model", default=None, help=f"{' | '.join(SHELL_MODELS)} (default: the run's)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first episode")
    det = parser.add_mutually_exclusive_group()
    det.add_argument(
        "--deterministic",
        dest="deterministic",
        action="store_true",
        default=True,
        help="the policy's deterministic action (default)",
    )
    det.add_argument(
        "--stochastic", dest="deterministic", action="store_false", help="sample actions from the policy's distribution"
    )
    parser.add_argument("--meshcat", action="store_true", help="show the episodes live in Meshcat (URL printed)")
    parser.add_argument(
        "--realtime-rate",
        type=float,
        default=1.0,
        help="with --meshcat: simulated seconds per wall-clock second (0: as fast as possible)",
    )
    parser.add_argument(
        "--video", default=None, help="folder for one MP4 per episode (<label>_<shell model>_<p>kPa_s<seed>.mp4)"
    )
    parser.add_argument(
        "--label", default=None, help="controller name in the video file names (default: the run folder's name)"
    )
    parser.add_argument("--env", default=None, help="env id (default: the run's)")
    parser.add_argument(
        "--allow-env-mismatch",
        action="store_true",
        help="run the policy on an env id other than the one it was trained on",
    )
    parser.add_argument(
        "--env-kwargs",
        nargs="+",
        default=[],
        metavar="KWARGS",
        help="extra env kwargs: one YAML mapping, e.g. '{render_size: [640, 480]}', or key:value items (as train)",
    )
    args = parser.parse_args(argv)
    try:
        spec = EnjoySpec(
            run=args.run,
            episodes=args.episodes,
            pressure_kpa=args.pressure_kpa,
            shell_model=args.shell_model,
            seed=args.seed,
            deterministic=args.deterministic,
            env_id=args.env,
            allow_env_mismatch=args.allow_env_mismatch,
            env_kwargs=parse_env_kwargs(args.env_kwargs),
            label=args.label,
        )
        return enjoy(
            spec,
            meshcat=args.meshcat,
            video=args.video,
            realtime_rate=args.realtime_rate,
            wait_for_enter=args.meshcat and sys.stdin.isatty(),
        )
    except (ValueError, OSError) as err:  # OSError: a failed write
        parser.exit(2, f"{parser.prog}: error: {err}\n")


if __name__ == "__main__":
    from sphere_env.evaluation.enjoy import main as _main

    _main()
