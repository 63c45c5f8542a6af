"""Export a trained policy for the robot: raw observation in, deterministic action out, with the
run's VecNormalize statistics folded in, as ONNX (default) or TorchScript, and its layout beside it.

    python -m evaluation.export runs/ppo_RampDescent-v2_<time>_s0            # -> <run>/export/
    python -m evaluation.export runs/<run>@best --format torchscript --out deploy/
    sphere-env export runs/<run>

Writes into ``--out`` (default ``<run>/export``, ``<run>/export_best`` for ``@best``):

``policy.onnx`` or ``policy.pt``
    input ``observation`` (batch, n_obs) float32, the env's raw observation; output ``action``
    (batch, 2) float32 in [-1, 1]. Inside: VecNormalize's
    clip((obs − mean) / sqrt(var + eps), −clip_obs, clip_obs) (in float64, as VecNormalize computes
    it), the policy network, and SB3's deterministic action (PPO: the Gaussian mean clipped to the
    action box, as ``predict`` does; SAC: tanh of the mean). A row with a NaN or infinite component
    is refused with the action [0, 0] (zero torque), never a NaN action. A policy trained with an
    asymmetric critic takes the observation without its privileged components.

    A policy trained inside ``sphere_env.wrappers.PDResidualAction`` (residual control over the PD
    baseline) is exported together with that PD: inputs ``observation`` and ``state`` (batch, 3)
    float64, outputs ``action`` and ``next_state`` (batch, 3) float64, where action =
    clip(PD(observation, state) + scale · clip(network(observation), −1, 1), −1, 1) with the PD's
    preset gains, limits and control period for the run's env
    (:class:`sphere_env.controllers_torch.PendulumPDModule`). ``state`` is the PD's:
    [speed-error integral (rad), previous ω_d (rad/s), 1 while there is no previous ω_d]; pass
    [0, 0, 1] at the start of every run and the previous step's ``next_state`` afterwards. Other
    wrappers that change the action are refused (``env_wrapper``).
``policy.json``
    the observation layout (index, name, unit, meaning, how the robot computes it from its sensors
    (``from_sensors``: channels, computation, frame, unit; :mod:`sphere_env.tasks.sensors`) and the
    normalization statistics), the
    action layout (normalized range, motor torque limits [N m], joints and sign conventions), env
    id and kwargs, shell model, control frequency [Hz], the algorithm, the check below and the
    software versions; for a residual policy also ``state`` (its components, units and reset value)
    and ``residual`` (scale, formula, the PD's gains).

Before anything is written, the exported file is run (onnxruntime, or the TorchScript module) on
observations recorded from env rollouts of the run's own policy at the calibration's lowest,
nominal and highest pressures, and compared with ``model.predict(vecnormalize.normalize_obs(obs),
deterministic=True)``; a largest difference above ``--tol`` (default 1e-5) refuses the export. A
residual policy's file is run one step at a time along those episodes, its state reset at each
episode's start and carried through it, and compared with the actions evaluation's
:class:`~sphere_env.evaluation.controller_specs.PolicyController` (the same PD + scale × residual)
took there.
Both files are written into a staging folder beside ``--out`` that replaces it whole at the end (files
of ``--out`` that no export writes are carried over), so the policy file and ``policy.json`` always
come from the same export; a failed or interrupted export leaves ``--out`` as it was. The run folder
is read under its lock (``<run>/.lock``): while a training (a resumed run) holds it, the export is
refused, naming that process, rather than reading a model in the middle of being written.

ONNX needs the ``export`` extra (onnx, onnxscript for ``torch.onnx.export``; onnxruntime for the
check: about 120 MB); TorchScript needs nothing beyond torch (recent torch marks TorchScript deprecated; it still works and
loads in C++ with ``torch::jit::load``).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from sphere_env.evaluation.command_options import ExportOptions
from sphere_env.evaluation.export_graph import (
    policy_module,
    residual_layout,
    residual_module,
    run_exported,
    run_exported_episodes,
    write_onnx,
    write_torchscript,
)
from sphere_env.evaluation.schemas import EXPORT_FORMATS
from sphere_env.files import folder_lock, swap_folder
from sphere_env.schemas import validate
from sphere_env.tasks.sensors import FROM_OPERATOR, FROM_SENSORS

ONNX_PACKAGES = ("onnx", "onnxscript", "onnxruntime")
DEFAULT_TOL = 1e-5
#: Steps recorded per check episode (one episode per pressure: lowest, nominal, highest).
CHECK_STEPS = 100
#: The one wrapper (``env_wrapper``) whose action combination is exported with the network.
RESIDUAL_WRAPPER = "sphere_env.wrappers.PDResidualAction"


def residual_kwargs(env_wrapper: Sequence[Mapping[str, Mapping[str, Any]]], run: str) -> dict[str, Any] | None:
    """The kwargs of a run's :data:`RESIDUAL_WRAPPER` entry, or None for a run trained on the bare
    env. ``env_wrapper``: the run's entries that change the action (``PolicyController.env_wrapper``:
    the training-only ones left out). Any other combination is refused (ValueError naming the field,
    its value and what is allowed)."""
    paths = [path for item in env_wrapper for path in item]
    if not paths:
        return None
    if paths != [RESIDUAL_WRAPPER]:
        from sphere_env.wrappers import TRAINING_ONLY_WRAPPERS

        raise ValueError(
            f"env_wrapper: run {run!r} was trained inside {paths}, which cannot be exported; allowed: one "
            f"{RESIDUAL_WRAPPER} entry (exported with its PD), besides the training-only "
            f"{list(TRAINING_ONLY_WRAPPERS)}"
        )
    return dict(next(item[RESIDUAL_WRAPPER] for item in env_wrapper if RESIDUAL_WRAPPER in item))


def check_supported(model: Any, algo: str) -> None:
    """Refuse policies this exporter does not reproduce (ValueError naming the field)."""
    from gymnasium import spaces

    obs_space, act_space, policy = model.observation_space, model.action_space, model.policy
    problems = [
        (algo not in ("ppo", "sac"), f"algo: {algo!r} cannot be exported; allowed: ['ppo', 'sac']"),
        (
            not (isinstance(obs_space, spaces.Box) and len(obs_space.shape) == 1),
            f"policy: observation space {obs_space} is not a flat Box",
        ),
        (not isinstance(act_space, spaces.Box), f"policy: action space {act_space} is not a Box"),
        (
            algo == "ppo" and policy.squash_output,
            "policy: PPO with squash_output (gSDE) cannot be exported; train without squash_output",
        ),
        (
            type(policy).__name__ not in ("ActorCriticPolicy", "SACPolicy", "MlpPolicy", "AsymmetricActorCriticPolicy"),
            f"policy: {type(policy).__name__} cannot be exported; allowed: MlpPolicy, AsymmetricMlpPolicy",
        ),
    ]
    for failed, message in problems:
        if failed:
            raise ValueError(message)


def check_onnx_support() -> None:
    """Refuse an ONNX export without its packages, before anything runs."""
    import importlib.util

    missing = [m for m in ONNX_PACKAGES if importlib.util.find_spec(m) is None]
    if missing:
        raise ValueError(
            f"format: onnx needs {', '.join(missing)}; install them with "
            'pip install "sphere_env[export]", or use --format torchscript'
        )


def record_episodes(
    controller: Any, env: Any, pressures_kpa: Sequence[float], steps: int = CHECK_STEPS, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rollouts of ``controller`` (reset at each episode's start; one episode per pressure, up to
    ``steps`` steps each; seeds ``seed``, ``seed + 1``, ...): the raw observations (n, n_obs)
    float32, the actions the controller gave on them (n, 2) float32, and which rows start an
    episode (n,) bool."""
    obs_out, act_out, starts = [], [], []
    for k, p in enumerate(pressures_kpa):
        if hasattr(controller, "reset"):
            controller.reset()
        obs, info = env.reset(seed=seed + k, options={"pressure_kpa": float(p)})
        for i in range(steps):
            action = np.asarray(controller(obs, info), dtype=np.float32)
            obs_out.append(obs)
            act_out.append(action)
            starts.append(i == 0)
            obs, _, terminated, truncated, info = env.step(np.clip(action, -1.0, 1.0))
            if terminated or truncated:
                break
    return np.asarray(obs_out, np.float32), np.asarray(act_out, np.float32), np.asarray(starts, bool)


def sb3_actions(controller: Any, obs: np.ndarray) -> np.ndarray:
    """``model.predict(vecnormalize.normalize_obs(obs), deterministic=True)``, batched."""
    action, _ = controller.model.predict(controller.normalize(obs), deterministic=True)
    return np.asarray(action, dtype=np.float32)


def _versions(fmt: str) -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    from sphere_env.provenance import software_versions

    out = software_versions()
    for pkg in ONNX_PACKAGES if fmt == "onnx" else ():
        try:
            out[pkg] = version(pkg)
        except PackageNotFoundError:
            out[pkg] = "absent"
    return out


def _recorded(
    controller: Any, r: Mapping[str, Any], residual: Mapping[str, Any] | None
) -> tuple[dict[str, Any], Any, dict[str, Any] | None]:
    """The run's env (randomization off) at the calibration's low, nominal and high pressures:
    ``(recorded, base, residual_info)``. ``recorded``: the observations the controller met there
    (as SB3 takes them), its actions on them (a residual policy's: the PD's included), which rows
    start an episode, the observation layout (each component with how the robot computes it), the
    action layout, the control rate [Hz] and the pressures [kPa]. For a policy trained inside
    ``PDResidualAction`` (``residual``: its kwargs), ``base`` is the PD it was trained over, built
    as evaluation builds it, with ``residual_info`` its layout in ``policy.json``; else both None."""
    import gymnasium as gym

    from sphere_env.models.shell import ShellCalibration

    env = gym.make(
        r["env_id"], shell_model=r["shell_model"], friction_model=r["friction"], randomization="off", **r["env_kwargs"]
    )
    try:
        u = env.unwrapped
        cal = ShellCalibration.load(r["env_kwargs"].get("calibration"))
        lo, hi = cal.pressure_range_kpa
        pressures = (lo, cal.nominal_pressure_kpa, hi)
        base = residual_info = None
        if residual is not None:
            from sphere_env.wrappers import ACTION_COMBINERS

            controller.check_env(env)  # binds the run's PD to the env, as evaluation does
            combiner = ACTION_COMBINERS[RESIDUAL_WRAPPER](env, **residual)  # the same builder
            base = (combiner.base, combiner.scale)
            residual_info = residual_layout(combiner.base, combiner.scale)
        # full observations, as SB3 takes them; the controller's actions (a residual's: PD included)
        obs, actions, starts = record_episodes(controller, env, pressures)
        observation_layout = u.observation_layout.describe()
        for rec in observation_layout:  # how the robot computes it (sphere_env.tasks.sensors)
            if rec["name"] in FROM_SENSORS:
                rec["from_sensors"] = FROM_SENSORS[rec["name"]]
            elif rec["name"] in FROM_OPERATOR:
                rec["from_operator"] = FROM_OPERATOR[rec["name"]]
        recorded = dict(
            obs=obs,
            actions=actions,
            starts=starts,
            observation_layout=observation_layout,
            action_layout=u.action_layout(),
            control_hz=1.0 / u.control_period_s,
            pressures=pressures,
        )
        return recorded, base, residual_info
    finally:
        env.close()


def _normalization(vn: Any, observation_layout: list[dict]) -> dict[str, Any] | None:
    """The VecNormalize statistics the file holds: each robot component's mean and variance written
    into its ``observation_layout`` record, and the formula's constants (None: no normalization)."""
    if vn is None or not vn.norm_obs:
        return None
    mean, var = np.asarray(vn.obs_rms.mean, float), np.asarray(vn.obs_rms.var, float)
    for rec, m, v in zip(observation_layout, mean, var):  # zip stops at the robot's components
        rec["normalization_mean"], rec["normalization_var"] = float(m), float(v)
    return {
        "epsilon": float(vn.epsilon),
        "clip_obs": float(vn.clip_obs),
        "formula": "clip((obs - mean) / sqrt(var + epsilon), -clip_obs, clip_obs), in float64",
    }


def _policy_json(
    fmt: str,
    n_obs: int,
    k: int,
    observation_layout: list[dict],
    stats: dict[str, Any] | None,
    action_layout: list[dict],
    control_hz: float,
    r: Mapping[str, Any],
    controller: Any,
    residual_info: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """``policy.json`` but its check, versions and time: the file's input (``n_obs`` components,
    without the ``k`` privileged ones) and output, the observation and action layouts, and the run."""
    name = EXPORT_FORMATS[fmt]
    return {
        "format": fmt,
        "file": name,
        "input": {
            "name": "observation",
            "shape": ["batch", int(n_obs)],
            "dtype": "float32",
            "meaning": "the env's raw observation (normalization is inside the file)"
            + (f", without the {k} privileged components the critic alone saw in training" if k else ""),
        },
        "output": {
            "name": "action",
            "shape": ["batch", 2],
            "dtype": "float32",
            "range": [-1.0, 1.0],
            "meaning": "the action the robot applies"
            + ("" if residual_info is None else ": the PD's plus scale × the network's residual (see residual)"),
            "non_finite_observation": "a row with a NaN or infinite component gives [0, 0] (zero torque)",
        },
        "deterministic_action": (
            "Gaussian mean clipped to [-1, 1] (SB3 predict, deterministic=True)"
            if r["config"].algo == "ppo"
            else "tanh of the Gaussian mean (SB3 predict, deterministic=True)"
        ),
        **(residual_info or {"state": None, "residual": None}),
        "observation": observation_layout,
        "observation_from_sensors": (
            "each component's from_sensors: the robot's channels, computation, frame "
            "and unit; sphere_env.tasks.sensors.SensorObserver runs it on sensor "
            f"samples at {control_hz:g} Hz (incline_deg: the ramp's); a component with from_operator "
            "instead is given by the operator"
        ),
        "observation_normalization": stats,
        "action": action_layout,
        "env_id": r["env_id"],
        "shell_model": r["shell_model"],
        "env_kwargs": r["env_kwargs"],
        "control_frequency_hz": control_hz,
        "algo": r["config"].algo,
        "run": str(r["folder"].resolve()),
        "model": "best/best_model.zip" if r["which"] == "best" else "model.zip",
        "num_timesteps": int(controller.model.num_timesteps),
    }


def _write_checked(module, fmt: str, path: Path, obs, expected, starts, residual: bool, tol: float) -> float:
    """Write ``module`` to ``path`` in ``fmt`` and run the file on ``obs``: batched, or (a
    ``residual`` policy) one step at a time, its PD state carried through each episode and reset at
    its ``starts``. Returns the largest difference from the ``expected`` actions; refuses
    (ValueError) one over ``tol``."""
    from sphere_env.controllers_torch import PD_STATE_RESET

    examples = {"observation": obs[:2]}
    if residual:
        examples["state"] = np.repeat(np.asarray([PD_STATE_RESET], np.float64), 2, axis=0)
    if fmt == "onnx":
        write_onnx(module, examples, ["action", "next_state"] if residual else ["action"], path)
    else:
        write_torchscript(module, list(examples.values()), path)
    if residual:
        got = run_exported_episodes(path, fmt, obs, starts, PD_STATE_RESET)
    else:
        got = run_exported(path, fmt, obs)
    diff = float(np.max(np.abs(got - expected)))
    if not diff <= tol:
        reference = "the evaluation's (PD + scale × residual)" if residual else "the SB3 policy's"
        raise ValueError(
            f"check: the exported policy's actions differ from {reference} by up to {diff:.3g} "
            f"(> tol {tol:g}) on {len(obs)} recorded observations; nothing written"
        )
    return diff


def _check_record(fmt: str, n_obs: int, pressures, residual: bool, diff: float, tol: float) -> dict[str, Any]:
    """policy.json's ``check``: what the exported file was compared with, on how many
    observations, and the largest difference found."""
    return {
        "observations": n_obs,
        "pressures_kpa": list(pressures),
        "reference": (
            "PolicyController's actions (the evaluation's PD + scale × residual) along its own "
            "episodes, one per pressure; the file run one step at a time, its state reset at each "
            "episode's start and carried through it"
            if residual
            else "model.predict(vecnormalize.normalize_obs(obs), deterministic=True), batched"
        ),
        "max_abs_action_diff": diff,
        "tol": tol,
        "runtime": "onnxruntime" if fmt == "onnx" else "torch.jit",
    }


def export(
    run: str,
    fmt: str = "onnx",
    out: str | Path | None = None,
    tol: float = DEFAULT_TOL,
    env_id: str | None = None,
    allow_env_mismatch: bool = False,
) -> dict[str, Path]:
    """Export ``run`` (a run folder, optionally ``@best``); returns ``{"policy": path, "layout": path}``.
    The options are loaded as :class:`~sphere_env.evaluation.command_options.ExportOptions` first."""
    import torch

    from sphere_env.evaluation.controller_specs import PolicyController, run_path
    from sphere_env.evaluation.enjoy import EnjoySpec

    opts = validate(
        ExportOptions, dict(run=run, format=fmt, out=out, tol=tol, env_id=env_id, allow_env_mismatch=allow_env_mismatch)
    )
    fmt, tol = opts.format, opts.tol
    if fmt == "onnx":
        check_onnx_support()
    torch.set_num_threads(1)
    # the run folder is read under its lock: never while a training (a resumed run) writes it
    folder = run_path(opts.run.partition("@")[0])
    with folder_lock(folder, "run", "export it once that process (a training writing the run) has ended", create=False):
        r = EnjoySpec(run=opts.run, env_id=opts.env_id, allow_env_mismatch=opts.allow_env_mismatch).resolve()
        controller = PolicyController(r["folder"], r["which"])
    out = opts.out
    cfg = r["config"]
    # a residual policy is exported with the PD it was trained over (residual_module)
    residual = residual_kwargs(controller.env_wrapper, str(r["folder"]))
    check_supported(controller.model, cfg.algo)
    network = module = policy_module(controller.model, controller.vecnormalize, cfg.algo)
    rec, base, residual_info = _recorded(controller, r, residual)
    if base is not None:
        module = residual_module(network, *base)
    obs, observation_layout = rec["obs"], rec["observation_layout"]
    # the reference: SB3's batched deterministic actions, or a residual's applied actions step by step
    expected = sb3_actions(controller, obs) if residual is None else rec["actions"]
    k = module.privileged_dims
    if k:  # the robot does not measure the privileged components: the file's input drops them
        obs = obs[:, :-k]
        observation_layout = observation_layout[:-k]

    from sphere_env.files import staged_folder

    name = EXPORT_FORMATS[fmt]
    # The files are written into a staging folder beside ``out`` that replaces it whole when every
    # check passed (_swap_in), so policy file and policy.json are never from two exports.
    with staged_folder(out, _swap_in) as work:
        tmp, tmp_json = work / name, work / "policy.json"
        diff = _write_checked(module, fmt, tmp, obs, expected, rec["starts"], residual is not None, tol)
        stats = _normalization(controller.vecnormalize, observation_layout)
        layout = _policy_json(
            fmt,
            obs.shape[1],
            k,
            observation_layout,
            stats,
            rec["action_layout"],
            rec["control_hz"],
            r,
            controller,
            residual_info,
        )
        layout["check"] = _check_record(fmt, len(obs), rec["pressures"], residual is not None, diff, tol)
        layout["versions"] = _versions(fmt)
        layout["created_utc"] = datetime.now(UTC).isoformat(timespec="seconds")
        tmp_json.write_text(json.dumps(layout, indent=2, ensure_ascii=False, default=str) + "\n")
    policy_path, layout_path = out / name, out / "policy.json"
    return {"policy": policy_path, "layout": layout_path, "max_abs_action_diff": diff}


def _swap_in(work: Path, out: Path) -> None:
    """Replace the export folder ``out`` by the staged ``work`` (two renames); files in ``out`` that
    no export writes are carried over, the previous export's files are not."""
    swap_folder(work, out, lambda name: name in (*EXPORT_FORMATS.values(), "policy.json"))


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter, allow_abbrev=False
    )
    parser.add_argument("run", help="training run folder (config.yaml, model.zip, vecnormalize.json); <run>@best")
    parser.add_argument("--format", default="onnx", help=f"{' | '.join(EXPORT_FORMATS)} (default onnx)")
    parser.add_argument("--out", default=None, help="output folder (default <run>/export)")
    parser.add_argument(
        "--tol",
        type=float,
        default=DEFAULT_TOL,
        help="largest allowed |exported - Python| action difference in the check",
    )
    parser.add_argument("--env", default=None, help="env id for the check rollouts and the layout (default: the run's)")
    parser.add_argument("--allow-env-mismatch", action="store_true", help="use an env id the run was not trained on")
    args = parser.parse_args(argv)
    try:
        res = export(args.run, args.format, args.out, args.tol, args.env, args.allow_env_mismatch)
    except (ValueError, OSError) as err:  # OSError: a failed write
        parser.exit(2, f"{parser.prog}: error: {err}\n")
    print(
        f"policy: {res['policy'].resolve()}\nlayout: {res['layout'].resolve()}\n"
        f"check: max |exported - Python| action difference {res['max_abs_action_diff']:.2e}"
    )
    return res


if __name__ == "__main__":
    from sphere_env.evaluation.export import main as _main

    _main()
