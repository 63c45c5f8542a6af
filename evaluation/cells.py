"""One evaluation cell: an episode of a controller in a fixed env, run inside a worker process.

A job (a picklable mapping: ``controller``, ``spec``, ``env_id``, ``shell_model``, ``friction``,
``pressure_kpa``, ``seed``, ``env_kwargs``, optionally ``randomization`` (a fault's events) and
``condition`` (default ``nominal``)) is rolled out by :func:`rollout` into a row of metrics
(:data:`sphere_env.evaluation.metrics.KEY_COLUMNS` and the episode metrics) and a trace of
:data:`~sphere_env.evaluation.metrics.TRACE_CHANNELS`. A worker keeps its envs and controllers
between jobs; :func:`run_jobs` runs jobs in-process, on a local process pool or on Ray, results in
job order.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from sphere_env.evaluation.controller_specs import check_action, make_controller
from sphere_env.evaluation.metrics import KEY_COLUMNS, TRACE_CHANNELS, episode_metrics
from sphere_env.parallel import run_parallel

_ENVS: dict[str, Any] = {}
_CONTROLLERS: dict[tuple[str, str], Any] = {}


def _env(job: Mapping[str, Any], record_replay: bool = False, render_mode: str | None = None):
    import gymnasium as gym

    import sphere_env  # noqa: F401

    events = job.get("randomization", "off")  # a fault grid's events; else nothing randomized
    key = json.dumps(
        [job["env_id"], job["shell_model"], job["friction"], job["env_kwargs"], events, record_replay, render_mode],
        sort_keys=True,
        default=str,
    )
    env = _ENVS.get(key)
    if env is None:
        env = gym.make(
            job["env_id"],
            shell_model=job["shell_model"],
            friction_model=job["friction"],
            randomization=events,
            record_replay=record_replay,
            render_mode=render_mode,
            **job["env_kwargs"],
        )
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
    elif getattr(controller, "needs_env", False):  # a loaded policy whose action combination needs an env
        controller.check_env(env, job["spec"])
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
    row = {k: job.get(k, "nominal") if k == "condition" else job[k] for k in KEY_COLUMNS}
    row.update(
        {
            "return": ret,
            "length": n,
            "is_success": bool(info.get("is_success", False)),
            "reached_runout": bool(info.get("reached_runout", n > 0 and trace["on_ramp"][-1] < 0.5)),
            "terminated": bool(terminated),
            "truncated": bool(truncated),
            "omega_ref_rad_s": float(trace["omega_ref"][0]) if n else math.nan,
            "omega_ref_after_rad_s": float(trace["omega_ref"][-1]) if n else math.nan,
            "truncation_reason": info.get("truncation_reason", ""),
        }
    )
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


def run_jobs(
    jobs: Sequence[Mapping[str, Any]],
    workers: int | None = None,
    ray_address: str | None = None,
    progress: bool = False,
) -> list[tuple[dict[str, Any], dict[str, np.ndarray]]]:
    """Run cells in job order: in-process (``workers=1``), on a local process pool, or on Ray."""
    return run_parallel(_run_job, jobs, workers=workers, progress=progress, ray_address=ray_address)


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
