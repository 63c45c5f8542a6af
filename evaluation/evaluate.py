"""Evaluate controllers on a sphere_env task over pressures × shell models × friction presets × seeds.

    python -m evaluation.evaluate --controller zero pd ppo=runs/<run> \\
        --pressure-kpa 3 8.5 14 --shell-models point injected hydroelastic --seeds 0 1 2 --out out/eval
    python -m evaluation.evaluate --controller mypkg.ctrl:policy --friction majd viscous
    python -m evaluation.evaluate --controller zero --pme-log my_ramp_log.csv --pme-log-pressure-kpa 8
    python -m evaluation.evaluate ... --ray-address local      # or auto / ray://host:10001
    python -m evaluation.evaluate --controller pd --shell-models point --seeds 0 --video out/videos
    python -m evaluation.evaluate --controller zero pd pretrained --faults all --fault-seeds 0 \
        --calibrations free_robot v0_linear

Every cell is a controlled experiment: the env's randomization is off, the pressure is fixed
through ``reset(options={"pressure_kpa": p})``, and the seed fixes the episode's command (ω_ref),
so all controllers, models and pressures see the same commands. ``--faults NAME... | all`` and
``--calibrations NAME...`` add conditions, each evaluated over the same grid: a named fault of
:data:`sphere_env.evaluation.faults.GRADED_FAULTS` (its events and env kwargs; ``all``: the
graded grid; ``--fault-seeds``: fewer seeds for them) or a shipped calibration
(``calibration=<name>``); free randomization stays refused (:mod:`sphere_env.evaluation.conditions`).
Cells run in parallel on a local
process pool (default) or on a Ray cluster (``--ray-address``; ``pip install -e .[ray]``); each
cell is a pure function of its job, so the CSV is identical either way.

Writes into ``--out``: ``episodes.csv`` (one row per episode and its ``condition``, metrics of
:mod:`sphere_env.evaluation.metrics`), ``traces.npz``, ``report.md`` (tables;
:mod:`sphere_env.evaluation.sweep_report`), ``plots/*.png`` (drive
velocity vs time per pressure and model; error bars per pressure and model as in the paper's
Figs. 13–14; success and tracking error vs pressure; PME; all of the nominal grid; with faults,
success vs each fault family's level) and ``replay_*.html`` (Meshcat).
``--video FOLDER`` also renders every episode of the grid (``rgb_array``, in the workers) into
``FOLDER/<controller>_<shell model>_<pressure>kPa_s<seed>.mp4`` through ``RecordVideo``
(:mod:`sphere_env.evaluation.video`; the ``video`` extra); rendering leaves the episodes unchanged.
Everything is validated first: the grid and the options are loaded through typed schemas
(:mod:`sphere_env.evaluation.schemas`: unknown keys, wrong types and values out of range refused by
field name), then the controllers are checked (model files load, the policy's training env id matches
``--env`` unless ``--allow-env-mismatch``, each controller returns 2 numbers); outputs
are then written into a temporary folder beside ``--out`` and moved into place at the end, replacing
the files an earlier sweep wrote there (other files are kept). A failure leaves ``--out`` as it was.
``--out`` is locked while the sweep runs (``--out/.lock``, as a run folder): a second evaluation
into it is refused, naming the process that holds it. A controller's label names its files through
:func:`sphere_env.files.file_stem` (characters other than letters, digits, ``.``, ``-``, ``@`` and
``_`` become ``-``); two labels that give the same name are refused.

PME (eq. 12) for zero torque: every ordered pair of shell models (reference = "experiment") over
the reference's on-ramp samples, and optionally against a user log: a CSV with columns ``t_s`` and
``omega_d`` [rad/s] and optionally ``on_ramp`` (0/1; default: every sample counts).
"""

from __future__ import annotations

import argparse
import json
import secrets
import time
from pathlib import Path
from typing import Annotated, Any, Literal, Mapping, Sequence

import numpy as np
from pydantic import Field

from sphere_env.cli import parse_env_kwargs, renamed
from sphere_env.evaluation.cells import run_jobs, save_replay
from sphere_env.evaluation.conditions import (
    NOMINAL,
    check_condition_envs,
    condition_jobs,
    condition_rates,
    conditions_markdown,
    plot_fault_curves,
)
from sphere_env.evaluation.controller_specs import check_action, check_spec, env_kwargs_of, make_controller
from sphere_env.evaluation.plots import plot_drive_velocity, plot_error_bars, plot_pme, plot_success_tracking
from sphere_env.evaluation.schemas import EvaluateOptions, ReplayCell, SweepFields
from sphere_env.evaluation.sweep_report import (
    aggregate,
    load_user_log,
    pme_log_rows,
    pme_rows,
    write_csv,
    write_pme_csv,
    write_report,
)
from sphere_env.files import file_stem, staged_folder, swap_folder
from sphere_env.models.shell import ShellCalibration
from sphere_env.parallel import default_workers
from sphere_env.params import SHELL_MODELS
from sphere_env.schemas import allowed, checker, validate

#: What a sweep writes into ``out`` (replaced as a whole when ``out`` is reused).
OUTPUT_NAMES = ("episodes.csv", "traces.npz", "pme.csv", "report.md", "plots")


class SweepSpec(SweepFields):
    """A grid to evaluate (fields and their checks: :class:`sphere_env.evaluation.schemas.SweepFields`).
    Pressures in kPa; ``controllers`` are ``label=spec`` texts or ``{label, spec}`` mappings
    (:mod:`sphere_env.evaluation.controller_specs`)."""

    def jobs(self) -> list[dict[str, Any]]:
        """One picklable job per cell, grouped so that a worker reuses its envs: per controller the
        nominal grid, then its conditions (:func:`sphere_env.evaluation.conditions.condition_jobs`)."""
        return condition_jobs(self, {c.label: {**env_kwargs_of(c.spec), **self.env_kwargs} for c in self.controllers})

    def check(self) -> None:
        """Refuse controllers that cannot run on this grid, before any worker starts (ValueError
        naming the controller): a model that does not load or was trained on another env id, env
        kwargs the env does not take, a first action that is not 2 numbers."""
        import gymnasium as gym

        for c in self.controllers:
            check_spec(c.spec, self.env_id, self.allow_env_mismatch)
        envs: dict[str, Any] = {}
        try:
            for c in self.controllers:  # each controller acts once: the action must be 2 numbers
                # the env the controller's cells run in: a trained policy's own env kwargs, then the sweep's
                kw = {**env_kwargs_of(c.spec), **self.env_kwargs}
                key = json.dumps(kw, sort_keys=True, default=str)
                if key not in envs:
                    try:
                        envs[key] = gym.make(self.env_id, shell_model="point", randomization="off", **kw)
                    except TypeError as err:
                        raise ValueError(f"env_kwargs: {err}") from None
                env = envs[key]
                ctrl = make_controller(c.spec, env)
                if hasattr(ctrl, "reset"):
                    ctrl.reset()
                obs, info = env.reset(seed=self.seeds[0])
                try:
                    action = ctrl(obs, info)
                except Exception as err:  # noqa: BLE001 - the user's controller failed on a valid observation
                    raise ValueError(
                        f"controller: {c.label!r} failed on the first observation: {type(err).__name__}: {err}"
                    ) from None
                check_action(c.label, action)
        finally:
            for env in envs.values():
                env.close()
        check_condition_envs(self.jobs())


def video_name_of(job: Mapping[str, Any], spec: SweepSpec) -> str:
    """An episode's video file stem (the friction preset is named only when the grid has several)."""
    from sphere_env.evaluation.video import video_name

    extra = [job["condition"].partition(":")[2]] if job.get("condition", NOMINAL) != NOMINAL else []
    extra += [job["friction"]] if len(spec.frictions) > 1 else []
    return video_name(job["controller"], job["shell_model"], job["pressure_kpa"], job["seed"], "_".join(extra))


def replay_job(cell: ReplayCell, spec: SweepSpec, i: int = 0) -> dict[str, Any]:
    """The job of replay ``i`` (``cell``'s blank fields: the grid's first controller, shell model and
    seed, its middle pressure), refused unless its controller is one of the grid's and its pressure
    inside the calibrated range."""
    ctrl = checker(
        Annotated[
            Literal[tuple(spec.labels)],
            Field(
                json_schema_extra=allowed(  # type: ignore[valid-type]
                    f"a label of the sweep's controllers {spec.labels}"
                )
            ),
        ]
    )(cell.controller or spec.labels[0], f"field 'replays[{i}].controller'")
    p = spec.pressures_kpa[len(spec.pressures_kpa) // 2] if cell.pressure_kpa is None else cell.pressure_kpa
    ShellCalibration.load(spec.env_kwargs.get("calibration")).check_pressure(p, f"field 'replays[{i}].pressure_kpa'")
    cspec = spec.controllers[spec.labels.index(ctrl)].spec
    return dict(
        controller=ctrl,
        spec=cspec,
        env_id=spec.env_id,
        shell_model=cell.shell_model or spec.shell_models[0],
        friction=spec.frictions[0],
        pressure_kpa=float(p),
        seed=spec.seeds[0] if cell.seed is None else cell.seed,
        env_kwargs={**env_kwargs_of(cspec), **spec.env_kwargs},
    )


def evaluate(
    spec: SweepSpec,
    out: str | Path,
    workers: int | None = None,
    ray_address: str | None = None,
    replays: Sequence[str | Mapping[str, Any]] = ("",),
    pme_log: str | Path | None = None,
    pme_log_pressure_kpa: float | None = None,
    pme_reference: str = "hydroelastic",
    plots: bool = True,
    progress: bool = False,
    extra_report: str = "",
    video: str | Path | None = None,
) -> dict[str, Any]:
    """Run the sweep and write CSV, traces, report, plots and replays into ``out``, and with
    ``video`` one MP4 per episode into that folder (moved into place when the sweep succeeded).
    The options are loaded as :class:`~sphere_env.evaluation.schemas.EvaluateOptions` and the
    controllers checked (:meth:`SweepSpec.check`) before anything runs.

    :returns: dict with ``rows`` (every episode, each naming its ``condition``), ``conditions``
        (:func:`~sphere_env.evaluation.conditions.condition_rates`), ``pme``, ``files`` (name ->
        path), ``wall_s``, and the nominal grid's aggregates ``agg_controller``, ``agg_model``.
    """
    from sphere_env.evaluation.video import check_video_support, staged_videos

    opts = validate(
        EvaluateOptions,
        dict(
            out=out,
            workers=workers,
            ray_address=ray_address,
            replays=list(replays),
            pme_log=pme_log,
            pme_log_pressure_kpa=pme_log_pressure_kpa,
            pme_reference=pme_reference,
            plots=plots,
            progress=progress,
            extra_report=extra_report,
            video=video,
        ),
    )
    if opts.video is not None:
        check_video_support()
    spec.check()
    replay_jobs = [replay_job(cell, spec, i) for i, cell in enumerate(opts.replays)]
    log = load_user_log(opts.pme_log) if opts.pme_log is not None else None
    with _staging(opts.out) as work, staged_videos(opts.video) as video_work:
        res = _sweep(spec, opts, work, replay_jobs, log, video_work)
    res["files"] = {k: opts.out / v.relative_to(work) if v.is_relative_to(work) else v for k, v in res["files"].items()}
    return res


def _produced(name: str) -> bool:
    """Whether a sweep writes an entry of this name into its output folder."""
    return name in OUTPUT_NAMES or (name.startswith("replay_") and name.endswith(".html"))


def _replace_outputs(work: Path, out: Path) -> None:
    """Replace what an earlier sweep wrote into ``out`` by the contents of ``work`` as one set (a
    folder swap); other files in ``out`` stay."""
    swap_folder(work, out, _produced)


def _staging(out: Path):
    """A fresh temporary folder beside ``out``, ``out`` locked meanwhile (a second sweep into it is
    refused by name); on success its contents replace what an earlier sweep wrote into ``out``, on
    failure it is removed and ``out`` is left as it was (:func:`sphere_env.files.staged_folder`)."""
    return staged_folder(out, _replace_outputs, lock="out")


def _sweep(
    spec: SweepSpec, opts: EvaluateOptions, out: Path, replay_jobs, log, video_work: Path | None = None
) -> dict[str, Any]:
    if opts.plots:
        (out / "plots").mkdir()
    jobs = spec.jobs()
    videos: dict[str, Path] = {}
    if video_work is not None:
        for job in jobs:
            job["video_dir"], job["video_name"] = str(video_work), video_name_of(job, spec)
            videos[f"video {job['video_name']}"] = opts.video / f"{job['video_name']}.mp4"
    t0 = time.perf_counter()
    results = run_jobs(jobs, opts.workers, opts.ray_address, opts.progress)
    wall = time.perf_counter() - t0
    all_rows = [r for r, _ in results]
    files: dict[str, Path] = {"episodes CSV": write_csv(all_rows, out / "episodes.csv")}
    np.savez_compressed(out / "traces.npz", **{f"{i}_{k}": v for i, (_, t) in enumerate(results) for k, v in t.items()})
    files["traces"] = out / "traces.npz"
    # the nominal grid's episodes: the summaries, plots and PME; the conditions are summarized apart
    nominal = [(r, t) for r, t in results if r["condition"] == NOMINAL]
    rows = [r for r, _ in nominal]
    traces = [t for _, t in nominal]
    pmes: list[dict[str, Any]] = []
    if "zero" in spec.labels:
        pmes = pme_rows(rows, traces, "zero")
        if log is not None:
            pmes += pme_log_rows(log, rows, traces, opts.pme_log_pressure_kpa, "zero")
    if pmes:
        files["PME CSV"] = write_pme_csv(pmes, out / "pme.csv")
    agg_model = aggregate(rows, ("controller", "shell_model", "friction", "pressure_kpa"))
    agg_ctrl = aggregate(rows, ("controller",))
    if opts.plots:
        files["drive velocity plot"] = plot_drive_velocity(rows, traces, spec, out / "plots" / "drive_velocity.png")
        files["error-bar plot"] = plot_error_bars(rows, traces, spec, out / "plots" / "error_bars.png")
        files["success/tracking plot"] = plot_success_tracking(agg_model, spec, out / "plots" / "success_tracking.png")
        ref = opts.pme_reference if opts.pme_reference in spec.shell_models else spec.shell_models[-1]
        ref = "log" if log is not None else ref
        p = plot_pme(pmes, out / "plots" / "pme.png", ref)
        if p is not None:
            files["PME plot"] = p
        calibrated = ShellCalibration.load(spec.env_kwargs.get("calibration")).pressure_range_kpa
        p = plot_fault_curves(all_rows, spec.labels, out / "plots" / "fault_curves.png", calibrated)
        if p is not None:
            files["fault curves plot"] = p
    for rj in replay_jobs:
        name = f"replay_{file_stem(rj['controller'])}_{rj['shell_model']}_{rj['pressure_kpa']:g}kPa_s{rj['seed']}.html"
        files[f"replay {rj['controller']} {rj['shell_model']} {rj['pressure_kpa']:g} kPa"] = save_replay(rj, out / name)
    files.update(videos)
    workers = opts.workers or default_workers()
    executor = (
        f"Ray at {opts.ray_address}"
        if opts.ray_address
        else (f"process pool of {workers} workers" if workers > 1 else "in-process")
    )
    files["report"] = write_report(
        out,
        spec,
        rows,
        agg_model,
        agg_ctrl,
        pmes,
        files,
        wall,
        executor,
        opts.extra_report,
        conditions_markdown(all_rows, spec),
        len(all_rows),
    )
    return {
        "rows": all_rows,
        "conditions": condition_rates(all_rows),
        "pme": pmes,
        "files": files,
        "wall_s": wall,
        "agg_controller": agg_ctrl,
        "agg_model": agg_model,
    }


def build_parser() -> argparse.ArgumentParser:
    """The flags in three groups: the grid (:func:`_add_grid`), the conditions under model error
    (:func:`_add_conditions`) and the outputs (:func:`_add_outputs`)."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter, allow_abbrev=False
    )
    _add_grid(parser)
    _add_conditions(parser)
    _add_outputs(parser)
    return parser


def _add_grid(parser: argparse.ArgumentParser) -> None:
    """The controllers, env and grid of episodes (pressures x shell models x frictions x seeds)."""
    parser.add_argument(
        "--controller",
        nargs="+",
        default=["zero", "pd"],
        help="zero | pd | <run folder>[@best] | module:function, each optionally label=...",
    )
    parser.add_argument("--env", default="sphere_env/RampDescent-v3")
    parser.add_argument(
        "--pressure-kpa",
        type=float,
        nargs="+",
        default=[3.0, 8.5, 14.0],
        help="inflation pressures [kPa] (default: 3 8.5 14, the demo's grid)",
    )
    renamed(parser, "--pressures", "--pressure-kpa")
    renamed(parser, "--pressure", "--pressure-kpa")
    parser.add_argument("--shell-models", nargs="+", default=list(SHELL_MODELS))
    parser.add_argument(
        "--friction", nargs="+", default=["majd"], help="friction presets (majd, viscous, coulomb, none)"
    )
    parser.add_argument(
        "--seeds", type=int, nargs="+", default=[0, 1, 2], help="evaluation seeds (default: the demo's 0 1 2)"
    )


def _add_conditions(parser: argparse.ArgumentParser) -> None:
    """The conditions under model error: faults and calibrations, and their seeds."""
    parser.add_argument(
        "--faults",
        nargs="+",
        default=[],
        metavar="NAME",
        help="add one condition per named fault (or 'all': the graded fault grid), each over the same grid",
    )
    parser.add_argument(
        "--calibrations",
        nargs="+",
        default=[],
        metavar="NAME",
        help="add one condition per shipped calibration (default, free_robot, hydroelastic_fast, v0_linear)",
    )
    parser.add_argument(
        "--fault-seeds", type=int, nargs="+", default=None, help="seeds of the fault conditions (default: --seeds)"
    )


def _add_outputs(parser: argparse.ArgumentParser) -> None:
    """The env's extra kwargs, where the results go, the workers that make them, replays, PME, a
    trained policy on another env, and videos (in the order ``--help`` lists them)."""
    parser.add_argument(
        "--env-kwargs",
        nargs="+",
        default=[],
        metavar="KWARGS",
        help="extra env kwargs: one YAML mapping '{k: v, ...}' or key:value items (as train)",
    )
    parser.add_argument("--out", default=None, help="output folder (default out/eval/<time>)")
    parser.add_argument("--workers", type=int, default=None, help="process-pool size (default: all cores)")
    parser.add_argument(
        "--ray-address", default=None, help="run on Ray: 'local' (start one), 'auto', or ray://host:port"
    )
    parser.add_argument(
        "--replay",
        nargs="*",
        default=[""],
        help="episodes to save as Meshcat HTML: controller,shell_model,pressure,seed (blank = defaults)",
    )
    parser.add_argument("--pme-log", default=None, help="CSV log (t_s, omega_d[, on_ramp]) for PME")
    parser.add_argument("--pme-log-pressure-kpa", type=float, default=None, help="the log's pressure [kPa]")
    renamed(parser, "--pme-log-pressure", "--pme-log-pressure-kpa")
    parser.add_argument("--pme-reference", default="hydroelastic", help="reference model of the PME plot")
    parser.add_argument(
        "--allow-env-mismatch",
        action="store_true",
        help="evaluate trained policies on an env id other than the one they were trained on",
    )
    parser.add_argument(
        "--video", default=None, help="folder for one MP4 per episode (<controller>_<shell model>_<p>kPa_s<seed>.mp4)"
    )


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    parser = build_parser()
    args = parser.parse_args(argv)

    # default: a new folder per run (a random suffix: evaluations started in one second differ)
    out = args.out or str(Path("out/eval") / f"{time.strftime('%Y%m%d-%H%M%S')}_{secrets.token_hex(3)}")
    from sphere_env.parallel import sigterm_as_interrupt

    try:
        env_kwargs = parse_env_kwargs(args.env_kwargs)
        spec = SweepSpec(
            controllers=args.controller,
            env_id=args.env,
            pressures_kpa=args.pressure_kpa,
            shell_models=args.shell_models,
            frictions=args.friction,
            seeds=args.seeds,
            env_kwargs=env_kwargs,
            allow_env_mismatch=args.allow_env_mismatch,
            faults=args.faults,
            calibrations=args.calibrations,
            fault_seeds=args.fault_seeds,
        )
        with sigterm_as_interrupt():
            res = evaluate(
                spec,
                out,
                args.workers,
                args.ray_address,
                args.replay,
                args.pme_log,
                args.pme_log_pressure_kpa,
                args.pme_reference,
                progress=True,
                video=args.video,
            )
    except (ValueError, OSError) as err:  # OSError: a write that failed after the checks (disk full)
        parser.exit(2, f"{parser.prog}: error: {err}\n")
    except KeyboardInterrupt:
        parser.exit(130, f"{parser.prog}: interrupted; nothing written to {out} (workers stopped)\n")
    print(res["files"]["report"].read_text())
    for k, v in res["files"].items():
        print(f"{k}: {v.resolve()}")
    return res


if __name__ == "__main__":
    # Run the package copy (sphere_env.evaluation.evaluate), also under `python -m evaluation.evaluate`, so
    # that worker processes unpickle this module's functions by a name they can import.
    from sphere_env.evaluation.evaluate import main as _main

    _main()
