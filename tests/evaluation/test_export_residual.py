"""The PD baseline as a torch module (what a residual policy's export carries): it gives the Python
controller's actions and state over whole episodes, the integral's clip included."""

from __future__ import annotations

import numpy as np
import pytest
import torch

import sphere_env  # noqa: F401
from sphere_env.controllers import OMEGA_D, PD_PRESETS, controller_for
from sphere_env.controllers_torch import PD_STATE_RESET, PendulumPDModule


@pytest.mark.parametrize(
    "env_id, env_kwargs, preset, clips",
    [
        ("sphere_env/RampDescent-v2", {}, "RampDescent-v2", True),
        ("sphere_env/RampDescent-v1", {}, "RampDescent", True),
        ("sphere_env/Roll-v1", {"command_mode": "yaw_rate"}, "Roll", False),
    ],
)
def test_torch_pd_gives_the_controllers_actions_and_state_over_an_episode(make, env_id, env_kwargs, preset, clips):
    env = make(env_id, shell_model="point", randomization="off", **env_kwargs)
    pd = controller_for(env, "pd")
    assert {k: getattr(pd, k) for k in PD_PRESETS[preset]} == PD_PRESETS[preset]
    module = PendulumPDModule(pd)
    pd.reset()
    state = torch.tensor([PD_STATE_RESET], dtype=torch.float64)
    obs, info = env.reset(seed=0)
    limit, at_clip, n = pd.integral_limit_rad, 0, 0
    while True:
        want = pd(obs, info)
        with torch.no_grad():
            got, state = module(torch.as_tensor(obs[None]), state)
        np.testing.assert_allclose(got.numpy()[0].astype(np.float32), want, rtol=0, atol=1e-6)
        # the state is the controller's: its integral (private attribute), the ω_d it saw, no flag
        assert state[0, 0].item() == pytest.approx(pd._integral, abs=1e-12)
        assert state[0, 1].item() == float(obs[OMEGA_D]) and state[0, 2].item() == 0.0
        at_clip += abs(pd._integral) >= limit
        obs, _, terminated, truncated, info = env.step(want)
        n += 1
        if terminated or truncated:
            break
    assert n > 100  # a whole episode, not its first steps
    assert (at_clip > 0) == clips  # the integral's clip was exercised where the preset reaches it
