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
``policy.json``
    the observation layout (index, name, unit, meaning, how the robot computes it from its sensors
    (``from_sensors``: channels, computation, frame, unit; :mod:`sphere_env.tasks.sensors`) and the
    normalization statistics), the
    action layout (normalized range, motor torque limits [N m], joints and sign conventions), env
    id and kwargs, shell model, control frequency [Hz], the algorithm, the check below and the
    software versions.

Before anything is written, the exported file is run (onnxruntime, or the TorchScript module) on
observations recorded from env rollouts of the run's own policy at the calibration's lowest,
nominal and highest pressures, and compared with ``model.predict(vecnormalize.normalize_obs(obs),
deterministic=True)``; a largest difference above ``--tol`` (default 1e-5) refuses the export.
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
import math
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from sphere_env.evaluation.command_options import ExportOptions
from sphere_env.evaluation.schemas import EXPORT_FORMATS
from sphere_env.files import folder_lock, swap_folder
from sphere_env.schemas import validate
from sphere_env.tasks.sensors import FROM_OPERATOR, FROM_SENSORS

ONNX_PACKAGES = ("onnx", "onnxscript", "onnxruntime")
DEFAULT_TOL = 1e-5
#: Steps recorded per check episode (one episode per pressure: lowest, nominal, highest).
CHECK_STEPS = 100


def _policy_module(model: Any, vecnormalize: Any, algo: str):
    """A torch module: raw observation (batch, n_obs) float32 -> deterministic action (batch, 2)."""
    import torch

    class DeterministicPolicy(torch.nn.Module):
        def __init__(self):
            super().__init__()
            policy = model.policy
            n_obs = int(np.prod(model.observation_space.shape))
            # an asymmetric actor-critic's actor ignores the trailing privileged components: the
            # file takes the robot's observation without them and fills their slots with zeros
            self.privileged_dims = int(getattr(policy, "privileged_dims", 0))
            if vecnormalize is not None and vecnormalize.norm_obs:
                rms = vecnormalize.obs_rms
                mean, var = np.asarray(rms.mean, np.float64), np.asarray(rms.var, np.float64)
                eps, clip = float(vecnormalize.epsilon), float(vecnormalize.clip_obs)
            else:  # identity
                mean, var, eps, clip = np.zeros(n_obs), np.ones(n_obs), 0.0, math.inf
            self.register_buffer("obs_mean", torch.tensor(mean, dtype=torch.float64))
            self.register_buffer("obs_std", torch.tensor(np.sqrt(var + eps), dtype=torch.float64))
            self.clip_obs = clip
            low, high = model.action_space.low, model.action_space.high
            self.register_buffer("action_low", torch.tensor(low, dtype=torch.float32))
            self.register_buffer("action_high", torch.tensor(high, dtype=torch.float32))
            self.algo = algo
            if algo == "ppo":
                self.features = policy.pi_features_extractor
                self.latent = policy.mlp_extractor.policy_net
                self.head = policy.action_net
            else:
                self.features = policy.actor.features_extractor
                self.latent = policy.actor.latent_pi
                self.head = policy.actor.mu

        def forward(self, observation: torch.Tensor) -> torch.Tensor:
            x = observation.to(torch.float64)
            # a row with a NaN or infinite component is refused: its action is zero torque
            valid = torch.isfinite(x).all(dim=1, keepdim=True)
            x = torch.where(valid, x, torch.zeros_like(x))
            if self.privileged_dims:
                x = torch.cat([x, torch.zeros(x.shape[0], self.privileged_dims, dtype=x.dtype)], dim=1)
            x = (x - self.obs_mean) / self.obs_std
            if math.isfinite(self.clip_obs):
                x = torch.clamp(x, -self.clip_obs, self.clip_obs)
            mean = self.head(self.latent(self.features(x.to(torch.float32))))
            if self.algo == "sac":  # squashed Gaussian: tanh of the mean; the box is [-1, 1]
                action = torch.tanh(mean)
            else:
                action = torch.maximum(torch.minimum(mean, self.action_high), self.action_low)
            return torch.where(valid, action, torch.zeros_like(action))

    return DeterministicPolicy().eval()


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


def record_observations(
    controller: Any, env: Any, pressures_kpa: Sequence[float], steps: int = CHECK_STEPS, seed: int = 0
) -> np.ndarray:
    """Raw observations of rollouts of ``controller`` (one episode per pressure, up to ``steps``
    steps each; seeds ``seed``, ``seed + 1``, ...), stacked (n, n_obs) float32."""
    out = []
    for k, p in enumerate(pressures_kpa):
        obs, info = env.reset(seed=seed + k, options={"pressure_kpa": float(p)})
        out.append(obs)
        for _ in range(steps - 1):
            obs, _, terminated, truncated, info = env.step(np.clip(controller(obs, info), -1.0, 1.0))
            out.append(obs)
            if terminated or truncated:
                break
    return np.asarray(out, dtype=np.float32)


def sb3_actions(controller: Any, obs: np.ndarray) -> np.ndarray:
    """``model.predict(vecnormalize.normalize_obs(obs), deterministic=True)``, batched."""
    action, _ = controller.model.predict(controller.normalize(obs), deterministic=True)
    return np.asarray(action, dtype=np.float32)


def _write_onnx(module, n_obs: int, path: Path) -> None:
    """``torch.onnx.export`` (the torch.export-based exporter) with a dynamic batch dimension. Its
    notes about unrelated operator libraries (torchvision) and deprecations are silenced."""
    import logging
    import warnings

    import torch

    example = torch.zeros(1, n_obs, dtype=torch.float32)
    batch = torch.export.Dim("batch", min=1)
    log = logging.getLogger("torch.onnx")
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", (FutureWarning, DeprecationWarning, UserWarning))
            program = torch.onnx.export(
                module,
                (example,),
                input_names=["observation"],
                output_names=["action"],
                dynamic_shapes={"observation": {0: batch}},
                dynamo=True,
                verbose=False,
            )
    finally:
        log.setLevel(level)
    program.save(str(path))


def _write_torchscript(module, example: np.ndarray, path: Path) -> None:
    """``torch.jit.trace`` + ``torch.jit.save`` (loadable with ``torch::jit::load`` in C++). Recent torch
    marks TorchScript deprecated in favour of torch.export; the warning is silenced here and ONNX is
    the default format."""
    import warnings

    import torch

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        torch.jit.save(torch.jit.trace(module, torch.as_tensor(example)), str(path))


def run_exported(path: Path, fmt: str, obs: np.ndarray) -> np.ndarray:
    """Actions of an exported file on a batch of raw observations."""
    if fmt == "onnx":
        import onnxruntime as ort

        session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
        (action,) = session.run(["action"], {"observation": np.asarray(obs, np.float32)})
        return np.asarray(action)
    import warnings

    import torch

    with warnings.catch_warnings():  # torch >= 2.10 marks TorchScript deprecated; it still loads
        warnings.simplefilter("ignore", DeprecationWarning)
        module = torch.jit.load(str(path))
    with torch.no_grad():
        return module(torch.as_tensor(np.asarray(obs, np.float32))).numpy()


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


def _recorded(controller: Any, r: Mapping[str, Any]) -> tuple[np.ndarray, list, list, float, tuple[float, ...]]:
    """The run's env (randomization off) at the calibration's low, nominal and high pressures:
    (the observations the policy met there, as SB3 takes them; the observation layout, each
    component with how the robot computes it; the action layout; the control rate [Hz]; the
    pressures [kPa])."""
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
        obs = record_observations(controller, env, pressures)  # full observations, as SB3 takes them
        observation_layout = u.observation_layout.describe()
        for rec in observation_layout:  # how the robot computes it (sphere_env.tasks.sensors)
            if rec["name"] in FROM_SENSORS:
                rec["from_sensors"] = FROM_SENSORS[rec["name"]]
            elif rec["name"] in FROM_OPERATOR:
                rec["from_operator"] = FROM_OPERATOR[rec["name"]]
        return obs, observation_layout, u.action_layout(), 1.0 / u.control_period_s, pressures
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
            "non_finite_observation": "a row with a NaN or infinite component gives [0, 0] (zero torque)",
        },
        "deterministic_action": (
            "Gaussian mean clipped to [-1, 1] (SB3 predict, deterministic=True)"
            if r["config"].algo == "ppo"
            else "tanh of the Gaussian mean (SB3 predict, deterministic=True)"
        ),
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
    if controller.env_wrapper:
        raise ValueError(
            f"run: {str(r['folder'])!r} was trained inside env_wrapper "
            f"{[p for item in controller.env_wrapper for p in item]}: its network gives a correction "
            "to another controller, not the robot's action, so it is not exported alone"
        )
    check_supported(controller.model, cfg.algo)
    module = _policy_module(controller.model, controller.vecnormalize, cfg.algo)

    obs, observation_layout, action_layout, control_hz, pressures = _recorded(controller, r)
    expected = sb3_actions(controller, obs)
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
        if fmt == "onnx":
            _write_onnx(module, obs.shape[1], tmp)
        else:
            _write_torchscript(module, obs[:2], tmp)
        got = run_exported(tmp, fmt, obs)
        diff = float(np.max(np.abs(got - expected)))
        if not diff <= tol:
            raise ValueError(
                f"check: the exported policy's actions differ from the SB3 policy's by up to {diff:.3g} "
                f"(> tol {tol:g}) on {len(obs)} recorded observations; nothing written"
            )
        stats = _normalization(controller.vecnormalize, observation_layout)
        check = {
            "observations": len(obs),
            "pressures_kpa": list(pressures),
            "max_abs_action_diff": diff,
            "tol": tol,
            "runtime": "onnxruntime" if fmt == "onnx" else "torch.jit",
        }
        layout = _policy_json(fmt, obs.shape[1], k, observation_layout, stats, action_layout, control_hz, r, controller)
        layout["check"] = check
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
        "--tol", type=float, default=DEFAULT_TOL, help="largest allowed |exported - SB3| action difference in the check"
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
        f"check: max |exported - SB3| action difference {res['max_abs_action_diff']:.2e}"
    )
    return res


if __name__ == "__main__":
    from sphere_env.evaluation.export import main as _main

    _main()
