"""The hyperparameters of SB3's PPO and SAC, checked before anything is built: numbers in their
ranges, schedules (``lin_<x>``), policy kwargs parsed as data (never evaluated), SAC's entropy
options. Each error names ``hyperparams.<key>``, the value and what is allowed.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping


def _lin_value(key: str, val: str) -> float:
    if not val.startswith("lin_"):
        raise ValueError(f"hyperparams.{key}: value {val!r} must be a number or 'lin_<number>'")
    try:
        x = float(val[4:])
    except ValueError:
        raise ValueError(f"hyperparams.{key}: value {val!r} must be a number or 'lin_<number>'") from None
    if not math.isfinite(x) or x <= 0:
        raise ValueError(f"hyperparams.{key}: value {val!r} must be positive")
    return x


_ACTIVATIONS = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU"}


def _policy_kwargs(d: dict[str, Any]) -> dict[str, Any]:
    """Activation names (``"tanh"``, ``"nn.ReLU"``) to torch classes."""
    act = d.get("activation_fn")
    if isinstance(act, str):
        import torch.nn as nn

        name = act.removeprefix("nn.")
        name = _ACTIVATIONS.get(name.lower(), name)
        if not hasattr(nn, name):
            raise ValueError(f"hyperparams.policy_kwargs.activation_fn: unknown activation {act!r}")
        d["activation_fn"] = getattr(nn, name)
    return d


def parse_dict_call(text: str, field_name: str, names: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """rl-zoo3's ``"dict(key=value, ...)"`` strings (policy kwargs, VecNormalize arguments) read as
    data, never evaluated: the text must be one ``dict(...)`` call (or a ``{...}`` literal) whose
    values are Python literals, nested ``dict(...)`` calls, lists/tuples of these, or one of
    ``names`` (such as ``nn.ReLU``). Anything else raises ValueError naming the field."""
    import ast

    names = dict(names or {})

    def value(node: ast.AST) -> Any:
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "dict" and not node.args:
            return {kw.arg: value(kw.value) for kw in node.keywords if kw.arg is not None}
        if isinstance(node, ast.Dict):
            return {value(k): value(v) for k, v in zip(node.keys, node.values) if k is not None}
        if isinstance(node, (ast.List, ast.Tuple)):
            items = [value(e) for e in node.elts]
            return items if isinstance(node, ast.List) else tuple(items)
        if isinstance(node, (ast.Attribute, ast.Name)):
            dotted = ast.unparse(node)
            if dotted in names:
                return names[dotted]
            if dotted in ("True", "False", "None"):
                return ast.literal_eval(dotted)
            raise ValueError(f"name {dotted!r} is not allowed; allowed names: {sorted(names) or 'none'}")
        return ast.literal_eval(node)  # numbers, strings, -x; raises ValueError on anything else

    try:
        tree = ast.parse(text.strip(), mode="eval")
        out = value(tree.body)
    except (SyntaxError, ValueError, TypeError) as err:
        raise ValueError(f"{field_name}: cannot read {text!r} as data: {err}; allowed: dict(key=value, ...) with "
                         "literal values") from None
    if not isinstance(out, dict):
        raise ValueError(f"{field_name}: {text!r} must be a dict(...) of keyword arguments")
    return out


def _eval_policy_kwargs(text: str) -> dict[str, Any]:
    """rl-zoo3's ``"dict(net_arch=[64, 64], activation_fn=nn.Tanh)"``, read as data."""
    import torch.nn as nn

    activations = {f"nn.{n}": getattr(nn, n) for n in ("Tanh", "ReLU", "ELU", "LeakyReLU", "GELU", "SiLU")}
    return _policy_kwargs(parse_dict_call(text, "hyperparams.policy_kwargs", activations))


def _hp_number(key: str, val: Any, *, low: float | None = None, high: float | None = None,
               low_open: bool = False, high_open: bool = False) -> float:
    """A finite real number within the given bounds (bools are not numbers)."""
    lo = "" if low is None else f"{'>' if low_open else '>='} {low:g}"
    hi = "" if high is None else f"{'<' if high_open else '<='} {high:g}"
    allowed = " and ".join(x for x in (lo, hi) if x) or "finite"
    if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val):
        raise ValueError(f"hyperparams.{key}: value {val!r} must be a number {allowed}")
    if low is not None and (val < low or (low_open and val == low)):
        raise ValueError(f"hyperparams.{key}: value {val!r} must be {allowed}")
    if high is not None and (val > high or (high_open and val == high)):
        raise ValueError(f"hyperparams.{key}: value {val!r} must be {allowed}")
    return float(val)


def _hp_int(key: str, val: Any, low: int) -> int:
    if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val) or val != int(val) \
            or int(val) < low:
        raise ValueError(f"hyperparams.{key}: value {val!r} must be an integer >= {low}")
    return int(val)


def _hp_bool(key: str, val: Any) -> None:
    if not isinstance(val, bool):
        raise ValueError(f"hyperparams.{key}: value {val!r} must be true or false")


def _hp_schedule(key: str, val: Any) -> None:
    """A positive number or rl-zoo3's ``lin_<positive number>``."""
    if isinstance(val, str):
        _lin_value(key, val)
    else:
        _hp_number(key, val, low=0.0, low_open=True)


def _hp_optional(check: Callable[[str, Any], Any]) -> Callable[[str, Any], Any]:
    return lambda key, val: None if val is None else check(key, val)


def _hp_mapping(key: str, val: Any) -> None:
    if val is not None and not isinstance(val, Mapping):
        raise ValueError(f"hyperparams.{key}: value {val!r} must be a mapping")


def _hp_policy_kwargs(key: str, val: Any) -> None:
    if not isinstance(val, (Mapping, str)):
        raise ValueError(f"hyperparams.{key}: value {val!r} must be a mapping (or rl-zoo3's 'dict(...)' string)")


def _hp_sac_ent_coef(key: str, val: Any) -> None:
    """SAC's entropy coefficient: a number >= 0, ``"auto"`` or ``"auto_<initial value > 0>"``."""
    if isinstance(val, str):
        if val == "auto":
            return
        if val.startswith("auto_"):
            try:
                x = float(val[5:])
            except ValueError:
                x = math.nan
            if math.isfinite(x) and x > 0:
                return
        raise ValueError(f"hyperparams.{key}: value {val!r} must be a number >= 0, 'auto' or 'auto_<value > 0>'")
    _hp_number(key, val, low=0.0)


def _hp_target_entropy(key: str, val: Any) -> None:
    if val != "auto":
        if isinstance(val, str):
            raise ValueError(f"hyperparams.{key}: value {val!r} must be a number or 'auto'")
        _hp_number(key, val)


def _hp_train_freq(key: str, val: Any) -> None:
    """An integer >= 1 (steps) or ``[n, "step"|"episode"]``."""
    if isinstance(val, (list, tuple)):
        if len(val) != 2 or val[1] not in ("step", "episode"):
            raise ValueError(f"hyperparams.{key}: value {val!r} must be an integer >= 1 or [n, 'step'|'episode']")
        _hp_int(key, val[0], 1)
    else:
        _hp_int(key, val, 1)


def _hp_gradient_steps(key: str, val: Any) -> None:
    if _hp_int(key, val, -1) == 0:
        raise ValueError(f"hyperparams.{key}: value {val!r} must be an integer >= 1 or -1 (as many as env steps)")


def _hp_refuse_object(key: str, val: Any) -> None:
    if val is not None:
        raise ValueError(f"hyperparams.{key}: value {val!r} cannot be set from a configuration file (only null)")


_COMMON_CHECKS: dict[str, Callable[[str, Any], Any]] = {
    "learning_rate": _hp_schedule,
    "gamma": lambda k, v: _hp_number(k, v, low=0.0, high=1.0, low_open=True),
    "batch_size": lambda k, v: _hp_int(k, v, 1),
    "use_sde": _hp_bool,
    "sde_sample_freq": lambda k, v: _hp_int(k, v, -1),
    "stats_window_size": lambda k, v: _hp_int(k, v, 1),
    "policy_kwargs": _hp_policy_kwargs,
}
#: Type and range of every constructor argument a configuration may set, per algorithm.
HYPERPARAM_CHECKS: dict[str, dict[str, Callable[[str, Any], Any]]] = {
    "ppo": {
        **_COMMON_CHECKS,
        "n_steps": lambda k, v: _hp_int(k, v, 1),
        "n_epochs": lambda k, v: _hp_int(k, v, 1),
        "gae_lambda": lambda k, v: _hp_number(k, v, low=0.0, high=1.0),
        "clip_range": _hp_schedule,
        "clip_range_vf": _hp_optional(_hp_schedule),
        "normalize_advantage": _hp_bool,
        "ent_coef": lambda k, v: _hp_number(k, v, low=0.0),
        "vf_coef": lambda k, v: _hp_number(k, v, low=0.0),
        "max_grad_norm": lambda k, v: _hp_number(k, v, low=0.0, low_open=True),
        "target_kl": _hp_optional(lambda k, v: _hp_number(k, v, low=0.0, low_open=True)),
        "rollout_buffer_class": _hp_refuse_object,
        "rollout_buffer_kwargs": _hp_mapping,
    },
    "sac": {
        **_COMMON_CHECKS,
        "buffer_size": lambda k, v: _hp_int(k, v, 1),
        "learning_starts": lambda k, v: _hp_int(k, v, 0),
        "tau": lambda k, v: _hp_number(k, v, low=0.0, high=1.0, low_open=True),
        "train_freq": _hp_train_freq,
        "gradient_steps": _hp_gradient_steps,
        "n_steps": lambda k, v: _hp_int(k, v, 1),
        "ent_coef": _hp_sac_ent_coef,
        "target_update_interval": lambda k, v: _hp_int(k, v, 1),
        "target_entropy": _hp_target_entropy,
        "use_sde_at_warmup": _hp_bool,
        "optimize_memory_usage": _hp_bool,
        "action_noise": _hp_refuse_object,
        "replay_buffer_class": _hp_refuse_object,
        "replay_buffer_kwargs": _hp_mapping,
    },
}


def check_hyperparams(algo: str, hyper: Mapping[str, Any]) -> dict[str, Any]:
    """Refuse a hyperparameter of the wrong type or out of range (before anything starts).
    Returns the hyperparameters with integer arguments given as ``256.0`` turned into ints.

    :raises ValueError: ``hyperparams.<key>: value ... must be ...``.
    """
    checks = HYPERPARAM_CHECKS[algo]
    out = dict(hyper)
    for key, val in hyper.items():
        check = checks.get(key)
        if check is None:
            raise ValueError(f"hyperparams.{key}: not settable from a configuration; allowed: {sorted(checks)}")
        checked = check(key, val)
        if isinstance(checked, int) and not isinstance(checked, bool):
            out[key] = checked
    return out


def _number_or_str(val: Any) -> Any:
    """YAML 1.1 reads ``1e-3`` as a string; turn numeric strings into floats."""
    if isinstance(val, str):
        try:
            return float(val)
        except ValueError:
            return val
    return val
