"""The exported file's graph: the torch module of a trained policy (raw observation in,
deterministic action out, the run's VecNormalize statistics folded in), its writers (ONNX,
TorchScript) and the runners that execute a written file. :mod:`sphere_env.evaluation.export`
builds, checks and documents the export with them.
"""

from __future__ import annotations

import math
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


def write_onnx(module, n_obs: int, path: Path) -> None:
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


def write_torchscript(module, example: np.ndarray, path: Path) -> None:
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
