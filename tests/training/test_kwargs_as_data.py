"""rl-zoo3's "dict(...)" strings (policy kwargs, VecNormalize arguments) are read as data: what a
user writes parses, and a crafted string that would run code is refused before anything runs."""

from __future__ import annotations

import pytest
import torch.nn as nn

from sphere_env.training.config import resolve_config
from sphere_env.training.zoo_forms import parse_dict_call

ENV = "sphere_env/RampDescent-v2"


def test_rl_zoo3_policy_kwargs_strings_parse():
    cfg = resolve_config(
        ENV,
        "ppo",
        overrides={
            "n_envs": 1,
            "policy_kwargs": "dict(net_arch=dict(pi=[32, 32], vf=[64, 64]), activation_fn=nn.ReLU, log_std_init=-1.5)",
        },
        build_env=False,
    )
    kw = cfg.algo_kwargs()["policy_kwargs"]
    assert kw == {"net_arch": {"pi": [32, 32], "vf": [64, 64]}, "activation_fn": nn.ReLU, "log_std_init": -1.5}


def test_normalize_string_parses():
    assert parse_dict_call("dict(norm_obs=True, norm_reward=False, gamma=0.99)", "normalize") == {
        "norm_obs": True,
        "norm_reward": False,
        "gamma": 0.99,
    }


@pytest.mark.parametrize(
    "text",
    [
        "dict(a=().__class__.__base__.__subclasses__())",  # the classic escape from eval without builtins
        "dict(a=__import__('os').system('touch /tmp/pwned'))",
        "dict(a=open('/etc/passwd').read())",
        "dict(activation_fn=nn.Module.__subclasses__)",
        "[x for x in ()]",
        "lambda: 1",
    ],
)
def test_code_in_a_dict_string_is_refused_by_name(tmp_path, text):
    with pytest.raises(ValueError, match="hyperparams.policy_kwargs"):
        resolve_config(ENV, "ppo", overrides={"n_envs": 1, "policy_kwargs": text}, build_env=False).algo_kwargs()
    with pytest.raises(ValueError, match="normalize"):
        parse_dict_call(text, "normalize")
