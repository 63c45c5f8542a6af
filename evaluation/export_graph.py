"""The exported file's graph: the torch module of a trained policy (raw observation in,
deterministic action out, the run's VecNormalize statistics folded in), the graph of a residual
policy (that network combined with the PD baseline it was trained over, the PD's state an explicit
input and output), their writers (ONNX, TorchScript) and the runners that execute a written file.
:mod:`sphere_env.evaluation.export` builds, checks and documents the export with them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np


def policy_module(model: Any, vecnormalize: Any, algo: str):
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


def residual_module(network: Any, pd: Any, scale: float):
    """The graph of a policy trained inside :class:`sphere_env.wrappers.PDResidualAction`: (raw
    observation (batch, n_obs) float32, PD state (batch, 3) float64) -> (applied action (batch, 2)
    float32, next PD state (batch, 3) float64), where applied action = clip(PD(observation, state) +
    ``scale`` · clip(network(observation), −1, 1), −1, 1), as
    :class:`sphere_env.wrappers.ResidualCombiner` computes it (the PD's action rounded to float32
    before the sum). ``network``: :func:`policy_module`; ``pd``: the
    :class:`~sphere_env.controllers.PendulumPDController` the run's wrapper builds for the env
    (:mod:`sphere_env.controllers_torch`). A row with a NaN or infinite component gets the action
    [0, 0] and its state back unchanged."""
    import torch

    from sphere_env.controllers_torch import PendulumPDModule

    class ResidualPolicy(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.network = network
            self.pd = PendulumPDModule(pd)
            self.scale = float(scale)
            self.privileged_dims = network.privileged_dims

        def forward(self, observation: torch.Tensor, state: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
            x = observation.to(torch.float64)
            state = state.to(torch.float64)
            valid = torch.isfinite(x).all(dim=1, keepdim=True) & torch.isfinite(state).all(dim=1, keepdim=True)
            x = torch.where(valid, x, torch.zeros_like(x))
            residual = torch.clamp(self.network(x.to(torch.float32)).to(torch.float64), -1.0, 1.0)
            base, next_state = self.pd(x, torch.where(valid, state, torch.zeros_like(state)))
            base = base.to(torch.float32).to(torch.float64)
            action = torch.clamp(base + self.scale * residual, -1.0, 1.0).to(torch.float32)
            action = torch.where(valid, action, torch.zeros_like(action))
            return action, torch.where(valid, next_state, state)

    return ResidualPolicy().eval()


def residual_layout(pd: Any, scale: float) -> dict[str, Any]:
    """What ``policy.json`` says of a residual policy's graph (:func:`residual_module`): the PD
    state's layout, its value at an episode's start and how to carry it (``state``), and the
    combination with the PD's gains (``residual``)."""
    import dataclasses

    from sphere_env.controllers_torch import PD_STATE, PD_STATE_RESET

    return {
        "state": {
            "input": "state",
            "output": "next_state",
            "shape": ["batch", len(PD_STATE)],
            "dtype": "float64",
            "components": [
                {"index": i, "name": name, "unit": unit, "meaning": meaning, "reset_value": value}
                for i, (name, unit, meaning, value) in enumerate(PD_STATE)
            ],
            "reset_value": list(PD_STATE_RESET),
            "use": (
                "at the start of every run (where the env resets) pass reset_value as state; at every "
                "later control step pass the previous step's next_state; a row with a NaN or infinite "
                "observation or state component gives its state back unchanged"
            ),
        },
        "residual": {
            "env_wrapper": "sphere_env.wrappers.PDResidualAction",
            "scale": float(scale),
            "action": (
                "clip(float32(PD(observation, state)) + scale * clip(network(normalized observation), -1, 1), "
                "-1, 1), as sphere_env.wrappers.ResidualCombiner applies it"
            ),
            "pd": {
                "controller": "sphere_env.controllers.PendulumPDController",
                **dataclasses.asdict(pd),
                "k_eq_nm": pd.k_eq_nm,  # the gravity feed-forward gains, from the robot's URDF
                "k_lean_nm": pd.k_lean_nm,
            },
        },
    }


def write_onnx(module, examples: Mapping[str, np.ndarray], output_names: Sequence[str], path: Path) -> None:
    """``torch.onnx.export`` (the torch.export-based exporter) with the inputs named as ``examples``'
    keys and one dynamic batch dimension shared by them. Its notes about unrelated operator
    libraries (torchvision) and deprecations are silenced."""
    import logging
    import warnings

    import torch

    args = tuple(torch.as_tensor(a) for a in examples.values())
    batch = torch.export.Dim("batch", min=1)
    log = logging.getLogger("torch.onnx")
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", (FutureWarning, DeprecationWarning, UserWarning))
            program = torch.onnx.export(
                module,
                args,
                input_names=list(examples),
                output_names=list(output_names),
                dynamic_shapes={name: {0: batch} for name in examples},
                dynamo=True,
                verbose=False,
            )
    finally:
        log.setLevel(level)
    program.save(str(path))


def write_torchscript(module, examples: Sequence[np.ndarray], path: Path) -> None:
    """``torch.jit.trace`` on the example inputs + ``torch.jit.save`` (loadable with
    ``torch::jit::load`` in C++). Recent torch marks TorchScript deprecated in favour of torch.export;
    the warning is silenced here and ONNX is the default format."""
    import warnings

    import torch

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        torch.jit.save(torch.jit.trace(module, tuple(torch.as_tensor(a) for a in examples)), str(path))


def _load_torchscript(path: Path):
    import warnings

    import torch

    with warnings.catch_warnings():  # torch >= 2.10 marks TorchScript deprecated; it still loads
        warnings.simplefilter("ignore", DeprecationWarning)
        return torch.jit.load(str(path))


def run_exported(path: Path, fmt: str, obs: np.ndarray) -> np.ndarray:
    """Actions of an exported file on a batch of raw observations."""
    if fmt == "onnx":
        import onnxruntime as ort

        session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
        (action,) = session.run(["action"], {"observation": np.asarray(obs, np.float32)})
        return np.asarray(action)
    import torch

    module = _load_torchscript(path)
    with torch.no_grad():
        return module(torch.as_tensor(np.asarray(obs, np.float32))).numpy()


def run_exported_episodes(
    path: Path, fmt: str, obs: np.ndarray, starts: np.ndarray, reset_state: Sequence[float]
) -> np.ndarray:
    """Actions of an exported residual policy run as on the robot: one observation per call, its
    ``next_state`` fed back as the next call's ``state``, the state set to ``reset_state`` where
    ``starts`` (bool per row) marks an episode's first step."""
    reset = np.asarray([reset_state], np.float64)
    obs = np.asarray(obs, np.float32)
    if fmt == "onnx":
        import onnxruntime as ort

        session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])

        def step(o, s):
            return session.run(["action", "next_state"], {"observation": o, "state": s})

    else:
        import torch

        module = _load_torchscript(path)

        def step(o, s):
            with torch.no_grad():
                a, n = module(torch.as_tensor(o), torch.as_tensor(s))
            return a.numpy(), n.numpy()

    out, state = [], reset
    for row, start in zip(obs, starts):
        action, state = step(row[None, :], reset if start else state)
        out.append(np.asarray(action)[0])
    return np.asarray(out, np.float32)
