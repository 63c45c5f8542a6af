"""Evaluate controllers on a sphere_env task over pressures × shell models × friction presets × seeds.

    python -m evaluation.evaluate --controller zero pd ppo=runs/<run> \\
        --pressure-kpa 3 8.5 14 --shell-models point injected hydroelastic --seeds 0 1 2 --out out/eval
    python -m evaluation.evaluate --controller mypkg.ctrl:policy --friction majd viscous
    python -m evaluation.evaluate --controller zero --pme-log my_ramp_log.csv --pme-log-pressure 8
    python -m evaluation.evaluate ... --ray-address local      # or auto / ray://host:10001
    python -m evaluation.evaluate --controller pd --shell-models point --seeds 0 --video out/videos

Every cell is a controlled experiment: the env's randomization is off, the pressure is fixed
through ``reset(options={"pressure_kpa": p})``, and the seed fixes the episode's command (ω_ref),
so all controllers, models and pressures see the same commands. Cells run in parallel on a local
process pool (default) or on a Ray cluster (``--ray-address``; ``pip install -e .[ray]``); each
cell is a pure function of its job, so the CSV is identical either way.

Writes into ``--out``: ``episodes.csv`` (one row per episode, metrics of
:mod:`sphere_env.evaluation.metrics`), ``traces.npz``, ``report.md`` (tables), ``plots/*.png`` (drive
velocity vs time per pressure and model; error bars per pressure and model as in the paper's
Figs. 13–14; success and tracking error vs pressure; PME) and ``replay_*.html`` (Meshcat).
``--video FOLDER`` also renders every episode of the grid (``rgb_array``, in the workers) into
``FOLDER/<controller>_<shell model>_<pressure>kPa_s<seed>.mp4`` through ``RecordVideo``
(:mod:`sphere_env.evaluation.video`; the ``video`` extra); rendering leaves the episodes unchanged.
Everything is validated first (grid, env kwargs, controllers: model files load, the policy's training
env id matches ``--env`` unless ``--allow-env-mismatch``, each controller returns 2 numbers); outputs
are then written into a temporary folder beside ``--out`` and moved into place at the end, replacing
the files an earlier sweep wrote there (other files are kept). A failure leaves ``--out`` as it was.

PME (eq. 12) for zero torque: every ordered pair of shell models (reference = "experiment") over
the reference's on-ramp samples, and optionally against a user log: a CSV with columns ``t_s`` and
``omega_d`` [rad/s] and optionally ``on_ramp`` (0/1; default: every sample counts).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import os
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from sphere_env.cli import parse_env_kwargs, renamed  # noqa: F401 - parse_env_kwargs re-exported
from sphere_env.evaluation.controller_specs import check_action, check_spec, env_kwargs_of, make_controller, split_label
from sphere_env.evaluation.metrics import PME_MIN_SPEED_RAD_S, TRACE_CHANNELS, episode_metrics, pme_between
from sphere_env.evaluation.plots import plot_drive_velocity, plot_error_bars, plot_pme, plot_success_tracking
from sphere_env.files import staged_folder
from sphere_env.models.shell import SHELL_MODELS
from sphere_env.parallel import run_parallel
from sphere_env.schemas import validate
from sphere_env.schemas.evaluation import SweepFields

METRIC_COLUMNS = ("return", "length", "is_success", "reached_runout", "terminated", "truncated",
                  "tracking_rmse_rad_s", "mean_omega_d_rad_s", "lateral_drift_m", "energy_j", "peak_torque_nm",
                  "time_on_ramp_s", "omega_ref_rad_s", "omega_ref_after_rad_s")
KEY_COLUMNS = ("controller", "env_id", "shell_model", "friction", "pressure_kpa", "seed")
#: What a sweep writes into ``out`` (replaced as a whole when ``out`` is reused).
OUTPUT_NAMES = ("episodes.csv", "traces.npz", "pme.csv", "report.md", "plots")


@dataclass
class SweepSpec:
    """A grid to evaluate. Pressures in kPa; ``controllers`` are ``label=spec`` strings
    (:mod:`sphere_env.evaluation.controller_specs`)."""

    controllers: list[str]
    env_id: str = "sphere_env/RampDescent-v3"
    pressures_kpa: list[float] = field(default_factory=lambda: [3.0, 8.5, 14.0])
    shell_models: list[str] = field(default_factory=lambda: list(SHELL_MODELS))
    frictions: list[str] = field(default_factory=lambda: ["majd"])
    seeds: list[int] = field(default_factory=lambda: [0, 1])
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    allow_env_mismatch: bool = False  # evaluate a policy on an env id it was not trained on

    def jobs(self) -> list[dict[str, Any]]:
        """One picklable job per cell, grouped so that a worker reuses its envs."""
        out = []
        for label, spec in (split_label(c) for c in self.controllers):
            kw = {**env_kwargs_of(spec), **self.env_kwargs}
            for model in self.shell_models:
                for fr in self.frictions:
                    for p in self.pressures_kpa:
                        for s in self.seeds:
                            out.append(dict(controller=label, spec=spec, env_id=self.env_id, shell_model=model,
                                            friction=fr, pressure_kpa=float(p), seed=int(s), env_kwargs=kw))
        return out

    def validate(self) -> None:
        """Refuse bad grids before any worker starts (ValueError naming the field)."""
        import gymnasium as gym

        import sphere_env  # noqa: F401

        validate(SweepFields, dataclasses.asdict(self))
        if self.env_id not in gym.registry:
            raise ValueError(f"field 'env_id' = {self.env_id!r}: unknown env id")
        labels = [split_label(c)[0] for c in self.controllers]
        if len(set(labels)) != len(labels):
            raise ValueError(f"field 'controllers' = {self.controllers!r}: labels must be unique, got {labels}")
        for c in self.controllers:
            check_spec(split_label(c)[1], self.env_id, self.allow_env_mismatch)
        from sphere_env.models.shell import ShellCalibration

        lo, hi = ShellCalibration.load(self.env_kwargs.get("calibration")).pressure_range_kpa
        for p in self.pressures_kpa:
            if not lo <= float(p) <= hi:
                raise ValueError(f"pressures: {p} kPa outside the calibrated range [{lo}, {hi}] kPa")
        envs: dict[str, Any] = {}
        try:
            for c in self.controllers:  # each controller acts once: the action must be 2 numbers
                label, cspec = split_label(c)
                # the env the controller's cells run in: a trained policy's own env kwargs, then the sweep's
                kw = {**env_kwargs_of(cspec), **self.env_kwargs}
                key = json.dumps(kw, sort_keys=True, default=str)
                if key not in envs:
                    try:
                        envs[key] = gym.make(self.env_id, shell_model="point", randomization="off", **kw)
                    except TypeError as err:
                        raise ValueError(f"env_kwargs: {err}") from None
                env = envs[key]
                ctrl = make_controller(cspec, env)
                if hasattr(ctrl, "reset"):
                    ctrl.reset()
                obs, info = env.reset(seed=self.seeds[0])
                try:
                    action = ctrl(obs, info)
                except Exception as err:  # noqa: BLE001 - the user's controller failed on a valid observation
                    raise ValueError(f"controller: {label!r} failed on the first observation: "
                                     f"{type(err).__name__}: {err}") from None
                check_action(label, action)
        finally:
            for env in envs.values():
                env.close()
        for fr in self.frictions:
            from sphere_env.models.friction import resolve_friction

            try:
                resolve_friction(fr, "drive")
                resolve_friction(fr, "steer")
            except ValueError as err:
                raise ValueError(f"frictions: {err}") from None


# ---- one cell (runs in a worker) -------------------------------------------------------------------------
_ENVS: dict[str, Any] = {}
_CONTROLLERS: dict[tuple[str, str], Any] = {}


def _env(job: Mapping[str, Any], record_replay: bool = False, render_mode: str | None = None):
    import gymnasium as gym

    import sphere_env  # noqa: F401

    events = job.get("randomization", "off")  # a fault grid's events; else nothing randomized
    key = json.dumps([job["env_id"], job["shell_model"], job["friction"], job["env_kwargs"], events, record_replay,
                      render_mode], sort_keys=True, default=str)
    env = _ENVS.get(key)
    if env is None:
        env = gym.make(job["env_id"], shell_model=job["shell_model"], friction_model=job["friction"],
                       randomization=events, record_replay=record_replay, render_mode=render_mode,
                       **job["env_kwargs"])
        if not record_replay:
            _ENVS[key] = env
    return env


def rollout(job: Mapping[str, Any], env=None, controller=None) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Run one episode of ``job``; returns (row of metrics, trace)."""
    env = env or _env(job)
    u = env.unwrapped
    if controller is None:
        ck = (job["spec"], json.dumps([job["env_id"], job["env_kwargs"]], sort_keys=True, default=str))
        controller = _CONTROLLERS.get(ck)
        if controller is None:
            controller = _CONTROLLERS[ck] = make_controller(job["spec"], env)
    if hasattr(controller, "reset"):
        controller.reset()
    obs, info = env.reset(seed=job["seed"], options={"pressure_kpa": job["pressure_kpa"]})
    ramp_end = u.ramp_end_x_m
    lay = u.observation_layout
    i_wd, i_ref, i_td, i_qd = lay["omega_d"], lay["omega_ref"], lay["theta_dot"], lay["drive_rate"]
    dt = u.control_period_s
    tr: dict[str, list[float]] = {k: [] for k in TRACE_CHANNELS}
    ret, n, terminated, truncated = 0.0, 0, False, False
    while not (terminated or truncated):
        a = np.clip(check_action(job["controller"], controller(obs, info)), -1.0, 1.0)
        obs, r, terminated, truncated, info = env.step(a)
        ret += float(r)
        n += 1
        pos = info.get("position_m", (math.nan, math.nan, math.nan))
        tr["t_s"].append(n * dt)
        tr["omega_d"].append(float(obs[i_wd]))
        tr["omega_ref"].append(float(obs[i_ref]))
        tr["x_m"].append(float(pos[0]))
        tr["y_m"].append(float(pos[1]))
        tr["z_m"].append(float(pos[2]))
        tau = info["motor_torque_nm"]  # applied joint torques [τ_steer, τ_drive]
        tr["tau_steer_nm"].append(float(tau[0]))
        tr["tau_drive_nm"].append(float(tau[1]))
        tr["theta_dot"].append(float(obs[i_td]))
        tr["drive_rate"].append(float(obs[i_qd]))
        tr["on_ramp"].append(float(pos[0] < ramp_end))
        tr["reward"].append(float(r))
    trace = {k: np.asarray(v) for k, v in tr.items()}
    row = {k: job[k] for k in KEY_COLUMNS}
    row.update({"return": ret, "length": n, "is_success": bool(info.get("is_success", False)),
                "reached_runout": bool(info.get("reached_runout", n > 0 and trace["on_ramp"][-1] < 0.5)),
                "terminated": bool(terminated), "truncated": bool(truncated),
                "omega_ref_rad_s": float(trace["omega_ref"][0]) if n else math.nan,
                "omega_ref_after_rad_s": float(trace["omega_ref"][-1]) if n else math.nan,
                "truncation_reason": info.get("truncation_reason", "")})
    row.update(episode_metrics(trace, dt))
    if "tracking_samples" in info:  # the task's own judgement (what its success uses)
        row["tracking_rmse_rad_s"] = float(info["tracking_rmse_rad_s"]) if info["tracking_samples"] else math.nan
    return row, trace


def _run_job(job: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    if job.get("video_dir"):  # render the episode into <video_dir>/<video_name>.mp4
        from sphere_env.evaluation.video import record_episode

        env = _env(job, render_mode="rgb_array")
        return record_episode(env, job["video_dir"], job["video_name"], lambda rec: rollout(job, env=rec))
    return rollout(job)


def video_name_of(job: Mapping[str, Any], spec: SweepSpec) -> str:
    """An episode's video file stem (the friction preset is named only when the grid has several)."""
    from sphere_env.evaluation.video import video_name

    return video_name(job["controller"], job["shell_model"], job["pressure_kpa"], job["seed"],
                      job["friction"] if len(spec.frictions) > 1 else "")


# ---- executors -----------------------------------------------------------------------------------------
def run_jobs(jobs: Sequence[Mapping[str, Any]], workers: int | None = None, ray_address: str | None = None,
             progress: bool = False) -> list[tuple[dict[str, Any], dict[str, np.ndarray]]]:
    """Run cells in job order: in-process (``workers=1``), on a local process pool, or on Ray."""
    return run_parallel(_run_job, jobs, workers=workers, progress=progress, ray_address=ray_address)


# ---- outputs -------------------------------------------------------------------------------------------
def _fmt(v: Any) -> str:
    if isinstance(v, bool):
        return str(int(v))
    if isinstance(v, float):
        return repr(v)
    return str(v)


def write_csv(rows: Sequence[Mapping[str, Any]], path: Path) -> Path:
    cols = list(KEY_COLUMNS) + list(METRIC_COLUMNS) + ["truncation_reason"]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in rows:
            w.writerow([_fmt(r.get(c, "")) for c in cols])
    return path


def pme_rows(rows: Sequence[Mapping[str, Any]], traces: Sequence[Mapping[str, np.ndarray]],
             controller: str = "zero") -> list[dict[str, Any]]:
    """PME [%] of every ordered pair of shell models (reference → simulation) per (pressure,
    friction, seed) for ``controller``'s episodes."""
    cells: dict[tuple, dict[str, Mapping[str, np.ndarray]]] = {}
    for r, tr in zip(rows, traces):
        if r["controller"] == controller:
            cells.setdefault((r["pressure_kpa"], r["friction"], r["seed"]), {})[r["shell_model"]] = tr
    out = []
    for (p, fr, s), by_model in sorted(cells.items()):
        for ref, te in by_model.items():
            for sim, ts in by_model.items():
                if ref == sim:
                    continue
                out.append(dict(pressure_kpa=p, friction=fr, seed=s, reference=ref, simulation=sim,
                                pme_percent=pme_between(te["t_s"], te["omega_d"], te["on_ramp"], ts["t_s"], ts["omega_d"])))
    return out


def load_user_log(path: str | Path) -> dict[str, np.ndarray]:
    """A user ramp log: CSV with ``t_s``, ``omega_d`` [rad/s], optional ``on_ramp`` (0/1)."""
    import pandas as pd

    try:
        df = pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError) as err:
        raise ValueError(f"pme_log: cannot read {str(path)!r}: {err}") from None
    for col in ("t_s", "omega_d"):
        if col not in df:
            raise ValueError(f"pme_log: {str(path)!r} has no column {col!r} (needs t_s, omega_d[, on_ramp])")
    if len(df) < 2:
        raise ValueError(f"pme_log: {str(path)!r} has {len(df)} samples; at least 2 are needed")
    try:
        t = df["t_s"].to_numpy(float)
        w = df["omega_d"].to_numpy(float)
    except ValueError as err:
        raise ValueError(f"pme_log: {str(path)!r}: t_s and omega_d must be numbers ({err})") from None
    if not (np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)):
        raise ValueError(f"pme_log: {str(path)!r} column t_s must be finite and strictly increasing")
    on = df["on_ramp"].to_numpy(bool) if "on_ramp" in df else np.ones(len(t), bool)
    return {"t_s": t - t[0], "omega_d": w, "on_ramp": on}


def pme_log_rows(log: Mapping[str, np.ndarray], rows, traces, pressure_kpa: float | None,
                 controller: str = "zero") -> list[dict[str, Any]]:
    """PME [%] of each shell model's zero-torque trace against a user log (nearest pressure)."""
    cand = [(r, tr) for r, tr in zip(rows, traces) if r["controller"] == controller]
    if not cand:
        return []
    ps = sorted({r["pressure_kpa"] for r, _ in cand})
    p = ps[0] if pressure_kpa is None else min(ps, key=lambda x: abs(x - pressure_kpa))
    out = []
    for r, tr in cand:
        if r["pressure_kpa"] == p:
            out.append(dict(pressure_kpa=p, friction=r["friction"], seed=r["seed"], reference="log",
                            simulation=r["shell_model"],
                            pme_percent=pme_between(log["t_s"], log["omega_d"], log["on_ramp"], tr["t_s"], tr["omega_d"])))
    return out


def aggregate(rows: Sequence[Mapping[str, Any]], by: Sequence[str]) -> list[dict[str, Any]]:
    """Mean (and std) of the metrics per group ``by``; success rate."""
    groups: dict[tuple, list] = {}
    for r in rows:
        groups.setdefault(tuple(r[k] for k in by), []).append(r)
    out = []
    for key, rs in groups.items():
        d = dict(zip(by, key))
        d["episodes"] = len(rs)
        d["success_rate"] = float(np.mean([r["is_success"] for r in rs]))
        d["reached_runout_rate"] = float(np.mean([r["reached_runout"] for r in rs]))
        for m in ("return", "tracking_rmse_rad_s", "mean_omega_d_rad_s", "lateral_drift_m", "energy_j",
                  "peak_torque_nm", "time_on_ramp_s"):
            v = np.array([r[m] for r in rs], float)
            d[m] = float(np.nanmean(v))
            d[m + "_std"] = float(np.nanstd(v))
        out.append(d)
    return out


# ---- plots ---------------------------------------------------------------------------------------------
def save_replay(job: Mapping[str, Any], path: Path) -> Path:
    """Re-run one cell in-process with Meshcat recording and write the HTML replay."""
    env = _env(job, record_replay=True)
    try:
        _, tr = rollout(job, env=env, controller=make_controller(job["spec"], env))
        # Camera beside the path, looking at its middle, so the whole episode is in view.
        p0 = np.array([tr["x_m"][0], tr["y_m"][0], tr["z_m"][0]])
        p1 = np.array([tr["x_m"][-1], tr["y_m"][-1], tr["z_m"][-1]])
        mid = 0.5 * (p0 + p1)
        span = max(float(np.linalg.norm(p1 - p0)), 1.0)
        env.unwrapped.meshcat.SetCameraPose(mid + np.array([0.0, -1.1 * span - 1.0, 0.35 * span + 0.5]), mid)
        return env.unwrapped.save_replay(path)
    finally:
        env.close()


# ---- report --------------------------------------------------------------------------------------------
def write_report(out: Path, spec: SweepSpec, rows, agg_model, agg_ctrl, pmes, files: Mapping[str, Path],
                 wall_s: float, executor: str, extra: str = "") -> Path:
    from sphere_env.evaluation.reporting import machine_info, markdown_table

    info = machine_info()
    lines = [
        "# Controller evaluation",
        "",
        f"`{spec.env_id}`, randomization off; pressures {', '.join(f'{p:g}' for p in spec.pressures_kpa)} kPa × "
        f"shell models {', '.join(spec.shell_models)} × friction {', '.join(spec.frictions)} × seeds "
        f"{', '.join(map(str, spec.seeds))} → {len(rows)} episodes in {wall_s:.0f} s ({executor}).",
        f"Machine: {info['cpu']}, {info['cores']} cores; drake {info['drake']}, torch {info['torch']}, "
        f"sb3 {info['stable_baselines3']}, commit {info['commit']}.",
        "",
        "Controllers: " + ", ".join(f"`{split_label(c)[0]}` = `{split_label(c)[1]}`" for c in spec.controllers),
        "",
    ]
    if extra:
        lines += [extra, ""]
    ctrl_cols = [("controller", "controller", ""), ("episodes", "episodes", "{:d}"),
                 ("success_rate", "success", "{:.0%}"), ("reached_runout_rate", "reached run-out", "{:.0%}"),
                 ("return", "return", "{:.2f}"), ("tracking_rmse_rad_s", "tracking RMSE rad/s", "{:.2f}"),
                 ("lateral_drift_m", "lateral drift m", "{:.3f}"), ("energy_j", "energy J", "{:.1f}"),
                 ("peak_torque_nm", "peak torque N m", "{:.1f}"), ("time_on_ramp_s", "time on ramp s", "{:.2f}")]
    lines += ["## Summary per controller (all cells)", "", markdown_table(agg_ctrl, ctrl_cols), ""]
    cols = [("controller", "controller", ""), ("shell_model", "shell model", ""), ("friction", "friction", ""),
            ("pressure_kpa", "pressure kPa", "{:g}"), ("success_rate", "success", "{:.0%}"),
            ("reached_runout_rate", "reached run-out", "{:.0%}"), ("return", "return", "{:.2f}"), ("tracking_rmse_rad_s", "tracking RMSE rad/s", "{:.2f}"),
            ("mean_omega_d_rad_s", "mean ω_d rad/s", "{:.2f}"), ("lateral_drift_m", "lateral drift m", "{:.3f}"),
            ("energy_j", "energy J", "{:.1f}"), ("peak_torque_nm", "peak torque N m", "{:.1f}")]
    lines += ["## Per controller, shell model and pressure (mean over seeds)", "",
              markdown_table(sorted(agg_model, key=lambda a: (a["controller"], a["shell_model"], a["friction"],
                                                               a["pressure_kpa"])), cols), ""]
    if pmes:
        pm = aggregate_pme(pmes)
        lines += ["## Point Mean Error (eq. 12), zero-torque descent", "",
                  "PME = mean over the reference's on-ramp samples of (ω_e − ω_s)/ω_e × 100 %, ω_e the "
                  f"reference's and ω_s the simulation's drive velocity (samples with |ω_e| < {PME_MIN_SPEED_RAD_S} "
                  "rad/s, the release, left out); positive when "
                  "the simulation underestimates the reference. Mean ± std over seeds.", "",
                  markdown_table(pm, [("reference", "reference", ""), ("simulation", "simulation", ""),
                                      ("friction", "friction", ""), ("pressure_kpa", "pressure kPa", "{:g}"),
                                      ("pme", "PME %", "")]), ""]
    lines += ["## Files", ""] + [f"- {k}: `{v.relative_to(out) if v.is_relative_to(out) else v}`"
                                  for k, v in files.items()]
    path = out / "report.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def aggregate_pme(pmes: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    groups: dict[tuple, list[float]] = {}
    for r in pmes:
        groups.setdefault((r["reference"], r["simulation"], r["friction"], r["pressure_kpa"]), []).append(r["pme_percent"])
    return [dict(reference=k[0], simulation=k[1], friction=k[2], pressure_kpa=k[3],
                 pme=f"{np.mean(v):+.1f} ± {np.std(v):.1f}") for k, v in sorted(groups.items())]


# ---- the whole sweep -----------------------------------------------------------------------------------
def parse_replay(text: str, spec: SweepSpec) -> dict[str, Any]:
    """``controller,shell_model,pressure_kpa,seed`` (missing fields: first of the grid)."""
    parts = [p.strip() for p in text.split(",")] if text else []
    labels = [split_label(c)[0] for c in spec.controllers]
    ctrl = parts[0] if len(parts) > 0 and parts[0] else labels[0]
    if ctrl not in labels:
        raise ValueError(f"replay: controller {ctrl!r} not in {labels}")
    model = parts[1] if len(parts) > 1 and parts[1] else spec.shell_models[0]
    if model not in SHELL_MODELS:
        raise ValueError(f"replay: shell model {model!r} not in {list(SHELL_MODELS)}")
    try:
        p = float(parts[2]) if len(parts) > 2 and parts[2] else spec.pressures_kpa[len(spec.pressures_kpa) // 2]
        seed = int(parts[3]) if len(parts) > 3 and parts[3] else spec.seeds[0]
    except ValueError:
        raise ValueError(f"replay: {text!r} must be controller,shell_model,pressure_kpa,seed (numbers for the "
                         "last two)") from None
    from sphere_env.models.shell import ShellCalibration

    ShellCalibration.load(spec.env_kwargs.get("calibration")).check_pressure(p, "replay: pressure_kpa")
    if seed < 0:
        raise ValueError(f"replay: seed {seed} must be >= 0")
    cspec = dict(split_label(c) for c in spec.controllers)[ctrl]
    return dict(controller=ctrl, spec=cspec, env_id=spec.env_id, shell_model=model, friction=spec.frictions[0],
                pressure_kpa=p, seed=seed, env_kwargs={**env_kwargs_of(cspec), **spec.env_kwargs})


def evaluate(spec: SweepSpec, out: str | Path, workers: int | None = None, ray_address: str | None = None,
             replays: Sequence[str] = ("",), pme_log: str | Path | None = None, pme_log_pressure: float | None = None,
             pme_reference: str = "hydroelastic", plots: bool = True, progress: bool = False,
             extra_report: str = "", video: str | Path | None = None) -> dict[str, Any]:
    """Run the sweep and write CSV, traces, report, plots and replays into ``out``, and with
    ``video`` one MP4 per episode into that folder (moved into place when the sweep succeeded).

    :returns: dict with ``rows``, ``pme``, ``files`` (name -> path), ``wall_s``.
    """
    from sphere_env.evaluation.video import check_video_support, staged_videos

    out = Path(out)
    check_out_dir(out)
    if video is not None:
        video = check_video_support(video)
        if ray_address is not None:
            raise ValueError("video: not available with --ray-address (Ray workers may not share this file "
                             "system); record videos with the local process pool")
    spec.validate()
    if pme_reference not in (*SHELL_MODELS, "log"):
        raise ValueError(f"pme_reference: value {pme_reference!r}; allowed: {[*SHELL_MODELS, 'log']}")
    replay_jobs = [parse_replay(r, spec) for r in replays]
    log = load_user_log(pme_log) if pme_log else None
    with _staging(out) as work, staged_videos(video) as video_work:
        res = _sweep(spec, work, workers, ray_address, replay_jobs, log, pme_log_pressure, pme_reference, plots,
                     progress, extra_report, video, video_work)
    res["files"] = {k: out / v.relative_to(work) if v.is_relative_to(work) else v for k, v in res["files"].items()}
    return res


def check_out_dir(out: Path) -> None:
    """Refuse an ``--out`` that is a file, or lies under one."""
    for p in (out, *out.parents):
        if p.exists() and not p.is_dir():
            raise ValueError(f"out: {str(out)!r} cannot be an output folder: {str(p)!r} is a file")


def _replace_outputs(work: Path, out: Path) -> None:
    """Replace what an earlier sweep wrote into ``out`` (:data:`OUTPUT_NAMES`, ``replay_*.html``)
    by the contents of ``work``."""
    for p in [*(out / n for n in OUTPUT_NAMES), *out.glob("replay_*.html")]:
        if p.is_dir():
            shutil.rmtree(p)
        elif p.exists():
            p.unlink()
    for p in work.iterdir():
        p.rename(out / p.name)


def _staging(out: Path):
    """A fresh temporary folder beside ``out``; on success its contents replace what an earlier sweep
    wrote into ``out``, on failure it is removed and ``out`` is left as it was
    (:func:`sphere_env.files.staged_folder`)."""
    return staged_folder(out, _replace_outputs)


def _sweep(spec: SweepSpec, out: Path, workers, ray_address, replay_jobs, log, pme_log_pressure, pme_reference,
           plots, progress, extra_report, video: Path | None = None, video_work: Path | None = None) -> dict[str, Any]:
    if plots:
        (out / "plots").mkdir()
    jobs = spec.jobs()
    videos: dict[str, Path] = {}
    if video_work is not None:
        for job in jobs:
            job["video_dir"], job["video_name"] = str(video_work), video_name_of(job, spec)
            videos[f"video {job['video_name']}"] = video / f"{job['video_name']}.mp4"
    t0 = time.perf_counter()
    results = run_jobs(jobs, workers, ray_address, progress)
    wall = time.perf_counter() - t0
    rows = [r for r, _ in results]
    traces = [t for _, t in results]
    files: dict[str, Path] = {"episodes CSV": write_csv(rows, out / "episodes.csv")}
    np.savez_compressed(out / "traces.npz", **{f"{i}_{k}": v for i, t in enumerate(traces) for k, v in t.items()})
    files["traces"] = out / "traces.npz"
    pmes: list[dict[str, Any]] = []
    labels = [split_label(c)[0] for c in spec.controllers]
    if "zero" in labels:
        pmes = pme_rows(rows, traces, "zero")
        if log is not None:
            pmes += pme_log_rows(log, rows, traces, pme_log_pressure, "zero")
    if pmes:
        with open(out / "pme.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(pmes[0]))
            w.writeheader()
            w.writerows(pmes)
        files["PME CSV"] = out / "pme.csv"
    agg_model = aggregate(rows, ("controller", "shell_model", "friction", "pressure_kpa"))
    agg_ctrl = aggregate(rows, ("controller",))
    if plots:
        files["drive velocity plot"] = plot_drive_velocity(rows, traces, spec, out / "plots" / "drive_velocity.png")
        files["error-bar plot"] = plot_error_bars(rows, traces, spec, out / "plots" / "error_bars.png")
        files["success/tracking plot"] = plot_success_tracking(agg_model, spec, out / "plots" / "success_tracking.png")
        ref = pme_reference if pme_reference in spec.shell_models else spec.shell_models[-1]
        ref = "log" if log is not None else ref
        p = plot_pme(pmes, out / "plots" / "pme.png", ref)
        if p is not None:
            files["PME plot"] = p
    for rj in replay_jobs:
        name = f"replay_{rj['controller']}_{rj['shell_model']}_{rj['pressure_kpa']:g}kPa_s{rj['seed']}.html"
        files[f"replay {rj['controller']} {rj['shell_model']} {rj['pressure_kpa']:g} kPa"] = save_replay(rj, out / name)
    files.update(videos)
    executor = f"Ray at {ray_address}" if ray_address else (
        f"process pool of {workers or max(len(os.sched_getaffinity(0)), 1)} workers" if (workers or 2) > 1 else "in-process")
    files["report"] = write_report(out, spec, rows, agg_model, agg_ctrl, pmes, files, wall, executor, extra_report)
    return {"rows": rows, "pme": pmes, "files": files, "wall_s": wall, "agg_controller": agg_ctrl,
            "agg_model": agg_model}


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--controller", nargs="+", default=["zero", "pd"],
                        help="zero | pd | <run folder>[@best] | module:function, each optionally label=...")
    parser.add_argument("--env", default="sphere_env/RampDescent-v3")
    parser.add_argument("--pressure-kpa", type=float, nargs="+", default=[3.0, 8.5, 14.0],
                        help="inflation pressures [kPa] (default: 3 8.5 14, the demo's grid)")
    renamed(parser, "--pressures", "--pressure-kpa")
    parser.add_argument("--shell-models", nargs="+", default=list(SHELL_MODELS))
    parser.add_argument("--friction", nargs="+", default=["majd"], help="friction presets (majd, viscous, coulomb, none)")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="evaluation seeds (default: the demo's 0 1 2)")
    parser.add_argument("--env-kwargs", nargs="+", default=[], metavar="KWARGS",
                        help="extra env kwargs: one YAML mapping '{k: v, ...}' or key:value items (as train)")
    parser.add_argument("--out", type=Path, default=None, help="output folder (default out/eval/<time>)")
    parser.add_argument("--workers", type=int, default=None, help="process-pool size (default: all cores)")
    parser.add_argument("--ray-address", default=None, help="run on Ray: 'local' (start one), 'auto', or ray://host:port")
    parser.add_argument("--replay", nargs="*", default=[""],
                        help="episodes to save as Meshcat HTML: controller,shell_model,pressure,seed (blank = defaults)")
    parser.add_argument("--pme-log", type=Path, default=None, help="CSV log (t_s, omega_d[, on_ramp]) for PME")
    parser.add_argument("--pme-log-pressure", type=float, default=None, help="log's pressure [kPa]")
    parser.add_argument("--pme-reference", default="hydroelastic", help="reference model of the PME plot")
    parser.add_argument("--allow-env-mismatch", action="store_true",
                        help="evaluate trained policies on an env id other than the one they were trained on")
    parser.add_argument("--video", type=Path, default=None,
                        help="folder for one MP4 per episode (<controller>_<shell model>_<p>kPa_s<seed>.mp4)")
    args = parser.parse_args(argv)

    out = args.out or Path("out/eval") / time.strftime("%Y%m%d-%H%M%S")
    from sphere_env.parallel import sigterm_as_interrupt

    try:
        env_kwargs = parse_env_kwargs(args.env_kwargs)
        spec = SweepSpec(controllers=args.controller, env_id=args.env, pressures_kpa=args.pressure_kpa,
                         shell_models=args.shell_models, frictions=args.friction, seeds=args.seeds,
                         env_kwargs=env_kwargs, allow_env_mismatch=args.allow_env_mismatch)
        with sigterm_as_interrupt():
            res = evaluate(spec, out, args.workers, args.ray_address, args.replay, args.pme_log,
                           args.pme_log_pressure, args.pme_reference, progress=True, video=args.video)
    except ValueError as err:
        parser.exit(2, f"{parser.prog}: error: {err}\n")
    except KeyboardInterrupt:
        parser.exit(130, f"{parser.prog}: interrupted; nothing written to {out} (workers stopped)\n")
    print((out / "report.md").read_text())
    for k, v in res["files"].items():
        print(f"{k}: {v.resolve()}")
    return res


if __name__ == "__main__":
    # Run the package copy (sphere_env.evaluation.evaluate), also under `python -m evaluation.evaluate`, so
    # that worker processes unpickle this module's functions by a name they can import.
    from sphere_env.evaluation.evaluate import main as _main

    _main()
